"""The push faces' view, judged too: the line's model sampled all along the run.

What MQTT, OPC UA, the web page and the Modbus image publish is the line's model: each value
with the time it holds for (``Sample.at``: the start of the exchange that read it, or of the
status read that confirmed it, see robostar/serve/status_witness.py). The watcher records every
new good sample of the channels' angles as a read the judge checks like a consumer's: its value
must be the controller's position at some instant from ``at`` to the end of that exchange
(at most the line's timeout later). A position confirmed while the arm in fact moved, or
stamped later than it held, is a violation.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import Any

from reliability.history_judge import OK, Op
from robostar.serve.model import ControllerModel, Quality

__all__ = ["ModelWatcher"]

CONSUMER = "model"
"""The ops' consumer name (their rule 1 figures are the model's)."""


class ModelWatcher:
    """Samples ``model()`` every ``every`` seconds on a thread of its own (see the module)."""

    def __init__(
        self,
        model: Callable[[], ControllerModel | None],
        channels: tuple[int, ...],
        exchange_bound: float,
        every: float = 0.01,
    ) -> None:
        self._model = model
        self._channels = channels
        self._bound = exchange_bound
        self._every = every
        self.ops: list[Op] = []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="history-model", daemon=True)
        # the model's stamps are time.time(), the journal's time.monotonic()
        self._offset = time.time() - time.monotonic()

    def start(self) -> ModelWatcher:
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(10)

    def _run(self) -> None:
        last: dict[str, tuple[Any, float]] = {}
        while not self._stop.wait(self._every):
            model = self._model()
            if model is None:
                continue
            for channel in self._channels:
                key = f"ch{channel}/angles"
                sample = model.get(key)
                if sample is None or sample.quality is not Quality.GOOD:
                    continue
                seen = (sample.value, sample.at)
                if last.get(key) == seen:
                    continue
                last[key] = seen
                at = sample.at - self._offset
                self.ops.append(
                    Op(
                        CONSUMER,
                        len(self.ops),
                        "AC",
                        {"channel": channel, "kind": "angle"},
                        False,
                        at,
                        at + self._bound,
                        OK,
                        list(sample.value.axes),
                    )
                )
