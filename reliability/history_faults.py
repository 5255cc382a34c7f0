"""Faults during a history run: what the checker's consumers must see through unharmed.

- :data:`LINE_FAULTS`: the fault matrix's kinds (robostar.sim.faults) at low rates on the
  server<->controller line, for the whole run;
- :class:`FaultPlayer`: now and then the controller hangs for seconds (its host's lock held: no
  byte in or out, time runs on) or the simulator is restarted (its state kept in its state
  directory, the journal appended to), chosen from a seeded generator;
- consumers with reply timeouts shorter and longer than the server's line timeout, and consumers
  that drop their connection mid-exchange, are set up by :mod:`reliability.history`.
"""

from __future__ import annotations

import random
import threading
from collections import Counter
from typing import Protocol

__all__ = ["CONSUMER_TIMEOUTS", "LINE_FAULTS", "FaultPlayer"]

LINE_FAULTS = (
    "corrupt:0.0005",
    "drop:0.0003",
    "dup:0.0003",
    "corrupt-lrc:0.002",
    "nak:0.002",
    "rst:0.0002",
    "repeat:to_host:0.001",
    "disconnect:0.00005",
    "delay:to_host:0.5:0.002",
)
"""Rates per byte (per packet for corrupt-lrc, nak and delay): a few faults a minute of traffic."""

CONSUMER_TIMEOUTS = (1.0, 3.0, 2.0)
"""Reply timeouts of the consumers in turn: shorter than, longer than and as the line's 2 s."""


class _Target(Protocol):
    def hang(self, seconds: float) -> None: ...

    def restart_sim(self) -> None: ...


class FaultPlayer:
    """Plays a hang or a restart every ``every`` seconds or so (seeded) until stopped."""

    def __init__(self, target: _Target, seed: int, every: float = 6.0) -> None:
        self.target = target
        self.rng = random.Random(seed * 31 + 5)
        self.every = every
        self.played: Counter[str] = Counter()
        self.begun: Counter[str] = Counter()
        """Faults begun (a hang counts in ``played`` only once over)."""
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="history-faults", daemon=True)
        self.failure: BaseException | None = None

    def start(self) -> FaultPlayer:
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(30)

    def _run(self) -> None:
        try:
            while not self._stop.wait(self.rng.uniform(0.5, 1.5) * self.every):
                if self.rng.random() < 0.7:
                    self.begun["hang"] += 1
                    self.target.hang(self.rng.uniform(1.0, 4.0))
                    self.played["hang"] += 1
                else:
                    self.begun["restart"] += 1
                    self.target.restart_sim()
                    self.played["restart"] += 1
        except BaseException as exc:
            self.failure = exc
