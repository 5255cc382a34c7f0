"""The history checker: K consumers through ``robostar serve`` in front of the simulator, judged
against the simulator's journal (issue 30's proof that what every consumer sees is the robot as
it is).

One process holds it all, so that every time is the same ``time.monotonic()``: the simulator
(:class:`~robostar.sim.listeners.SimServer` on loopback TCP, journaling), the line server on an
asyncio thread of its own (its N1 face and its JSON API), and the consumers, each a thread: N1
face connections, ``serve://`` clients, API callers, doing seeded random reads and state changes.
:func:`run_history` returns a :class:`HistoryReport`; the judge is
:mod:`reliability.history_judge`, the consumers :mod:`reliability.history_ops`.

    python reliability/run.py history --ops 100000 --seeds 1 2 3
"""

from __future__ import annotations

import asyncio
import contextlib
import tempfile
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import robostar
from reliability.history_faults import CONSUMER_TIMEOUTS, LINE_FAULTS, FaultPlayer
from reliability.history_judge import Op, Verdict, judge
from reliability.history_model import CONSUMER as MODEL
from reliability.history_model import ModelWatcher
from reliability.history_ops import JOB_CHANNEL, ApiConsumer, ClientConsumer
from robostar.errors import PortError
from robostar.serve import LineConfig, LineServer, ServeConfig
from robostar.serve.model import ControllerModel
from robostar.sim import SimConfig
from robostar.sim.controller import VirtualController
from robostar.sim.faults import parse_fault
from robostar.sim.journal import Journal
from robostar.sim.listeners import SimServer, SimSessions
from robostar.sim.store import StateStore

__all__ = ["HistoryConfig", "HistoryReport", "Rig", "run_history"]

JOB_LINES = ("MAIN", "LOOP:", "DELAY 100", "DELAY 50", "GOTO LOOP", "EOP")


@dataclass(frozen=True)
class HistoryConfig:
    """One run: ``ops`` operations over ``n1`` N1 face connections, ``serve`` serve://
    clients and ``api`` API callers, seeded. ``max_age`` is the line's (None: the server's
    default); ``timeouts`` the consumers' reply timeouts, one per consumer in turn."""

    ops: int = 600
    seed: int = 1
    n1: int = 2
    serve: int = 2
    api: int = 1
    write_share: float = 0.3
    max_age: float | None = None
    poll_interval: float = 0.05
    line_timeout: float = 2.0
    timeouts: tuple[float, ...] = (2.0,)
    lease_ttl: float = 5.0
    faults: bool = False
    """Faults during the run (see :mod:`reliability.history_faults`)."""
    fault_every: float = 6.0
    """Seconds between the hangs and restarts, about."""
    min_faults: int = 0
    """With faults: the consumers go on past ``ops`` until the player has begun at least this
    many hangs and restarts, so that a short run (a CI slice, on a fast machine) is never over
    before its first fault."""
    watch_model: bool = True
    """Judge the line's model too (what the push faces publish), sampled all along: see
    :mod:`reliability.history_model`."""
    stale_consumer: bool = False
    """Plant a fake: one consumer answers its reads from its own earlier answers (a stale
    cache), so that the checker is seen to catch it."""


@dataclass
class HistoryReport:
    config: HistoryConfig
    ops: list[Op]
    verdict: Verdict
    journal_entries: int
    wall: float
    crashes: list[str] = field(default_factory=list)
    faults: dict[str, int] = field(default_factory=dict)
    """Hangs and restarts played (the line faults run throughout)."""

    @property
    def violations(self) -> int:
        return len(self.verdict.violations)

    def _examples(self, per_kind: int = 3) -> list[str]:
        """Up to ``per_kind`` rendered violations of each rule and command."""
        seen: dict[str, int] = {}
        out = []
        for v in self.verdict.violations:
            kind = f"{v.rule} {v.ops[0].code}" if v.ops else v.rule
            seen[kind] = seen.get(kind, 0) + 1
            if seen[kind] <= per_kind:
                out.append(v.render())
        return out

    def as_json(self) -> dict[str, Any]:
        outcomes: dict[str, int] = {}
        for op in self.ops:
            outcomes[op.outcome] = outcomes.get(op.outcome, 0) + 1
        rules: dict[str, int] = {}
        for v in self.verdict.violations:
            what = f"{v.rule} {v.ops[0].code}" if v.ops else v.rule
            rules[what] = rules.get(what, 0) + 1
        return {
            "seed": self.config.seed,
            "ops": len(self.ops),
            "checked_reads": self.verdict.reads,
            "checked_writes": self.verdict.writes,
            "model_samples": sum(1 for op in self.ops if op.consumer == MODEL),
            "unchecked": self.verdict.unchecked,
            "outcomes": outcomes,
            "violations": self.violations,
            "violations_by_rule": rules,
            "journal_entries": self.journal_entries,
            "wall_s": round(self.wall, 1),
            "max_age": self.config.max_age,
            "faults": {"line": list(LINE_FAULTS), **self.faults} if self.config.faults else None,
            "crashes": self.crashes,
            "examples": self._examples(),
        }


class _ServerThread:
    """``robostar serve`` (a LineServer with its N1 face and API) on a thread of its own."""

    def __init__(self, config: ServeConfig) -> None:
        self.config = config
        self.server: LineServer | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._stop: asyncio.Event | None = None
        self._ready = threading.Event()
        self._failure: BaseException | None = None
        self._thread = threading.Thread(target=self._run, name="history-serve", daemon=True)

    def _run(self) -> None:
        async def main() -> None:
            async with LineServer(self.config) as server:
                self.server = server
                self._loop = asyncio.get_running_loop()
                self._stop = asyncio.Event()
                self._ready.set()
                await self._stop.wait()

        try:
            asyncio.run(main())
        except BaseException as exc:
            self._failure = exc
            self._ready.set()

    def start(self) -> _ServerThread:
        self._thread.start()
        self._ready.wait(30)
        if self._failure is not None:
            raise self._failure
        return self

    def close(self) -> None:
        if self._loop is not None and self._stop is not None:
            self._loop.call_soon_threadsafe(self._stop.set)
        self._thread.join(30)

    @property
    def n1_url(self) -> str:
        assert self.server is not None
        host, port = self.server.faces["n1"].addresses["cell1"]  # type: ignore[attr-defined]
        return f"tcp://{host}:{port}"

    @property
    def api_address(self) -> tuple[str, int]:
        assert self.server is not None
        host, port = self.server.faces["api"].address  # type: ignore[attr-defined]
        return str(host), int(port)


class Rig:
    """The simulator (journaling, its state in ``state_dir``) and the server in front of it."""

    def __init__(self, config: HistoryConfig, state_dir: Path) -> None:
        self.config = config
        self.journal = Journal(keep=True)
        self.state_dir = state_dir
        self.sim_config = SimConfig(seed=config.seed)
        self.sim: SimServer | None = None
        self.sessions: SimSessions | None = None
        self.port = 0
        self.server: _ServerThread | None = None
        self.line_faults = False
        """Once True, every new line connection to the simulator runs through LINE_FAULTS."""
        self._swap = threading.Lock()
        self.restarts = 0

    def start_sim(self) -> None:
        controller = VirtualController(
            self.sim_config, store=StateStore(self.state_dir), journal=self.journal
        )
        faults = [parse_fault(spec) for spec in LINE_FAULTS] if self.line_faults else []
        self.sessions = SimSessions(controller, faults=faults, seed=self.config.seed)
        for attempt in range(50):
            try:
                self.sim = SimServer(self.sessions, port=self.port).start()
                break
            except PortError:
                if attempt == 49:
                    raise
                time.sleep(0.1)  # the old listener's port is not free yet
        assert self.sim is not None
        self.port = self.sim.address[1]

    def stop_sim(self) -> None:
        if self.sim is not None:
            self.sim.close()
            self.sim = None

    def faults_on(self) -> None:
        """LINE_FAULTS on the line from now on (on the connections opened from now on)."""
        self.line_faults = True
        assert self.sessions is not None
        self.sessions.faults = [parse_fault(spec) for spec in LINE_FAULTS]

    def hang(self, seconds: float) -> None:
        """The controller hangs: no byte in or out for ``seconds`` (time runs on)."""
        with self._swap:
            if self.sim is not None:
                with self.sim.lock:
                    time.sleep(seconds)

    def restart_sim(self) -> None:
        """The simulator stops and starts again on the same port, its state kept."""
        with self._swap:
            self.stop_sim()
            time.sleep(0.3)
            self.start_sim()
            self.restarts += 1

    def prepare(self) -> None:
        """The cell's starting state, set directly on the simulator: both robots homed, a job
        that loops selected on JOB_CHANNEL."""
        assert self.sim is not None
        with robostar.Client(self.sim.url) as client:
            for channel in (1, 2):
                client.servo(channel, True)
                client.home(channel, wait=True)
            client.upload_job(JOB_CHANNEL, "LOOP.JOB", list(JOB_LINES))
            client.select_job(JOB_CHANNEL, "LOOP.JOB")

    def start_server(self) -> None:
        assert self.sim is not None
        line = LineConfig(
            "cell1",
            self.sim.url,
            timeout=self.config.line_timeout,
            poll_interval=self.config.poll_interval,
            max_age=self.config.max_age,
        )
        serve = ServeConfig(
            lines=(line,),
            faces={"n1": {"lines": {"cell1": "127.0.0.1:0"}}, "api": {"listen": "127.0.0.1:0"}},
            lease_ttl=self.config.lease_ttl,
            audit=False,
        )
        self.server = _ServerThread(serve).start()

    def close(self) -> None:
        if self.server is not None:
            self.server.close()
        self.stop_sim()
        self.journal.close()


class _StaleConsumer(ClientConsumer):
    """The planted fake: reads answered from this consumer's own earlier answers."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._cache: dict[str, Any] = {}

    def one(self, seq: int, planned: Any) -> None:
        super().one(seq, planned)
        op = self.ops[-1] if self.ops and self.ops[-1].seq == seq else None
        if op is None or op.write or op.outcome != "ok":
            return
        key = op.code + repr(sorted(op.args.items()))
        if key in self._cache:
            op.value = self._cache[key]
        else:
            self._cache[key] = op.value


def _consumers(config: HistoryConfig, rig: Rig) -> list[Any]:
    server = rig.server
    assert server is not None
    total = config.n1 + config.serve + config.api
    share = max(1, config.ops // max(1, total))
    out: list[Any] = []
    index = 0
    timeouts = CONSUMER_TIMEOUTS if config.faults else (config.timeouts or (2.0,))

    def n1_address() -> tuple[str, int]:
        host, port = server.n1_url.removeprefix("tcp://").rsplit(":", 1)
        return host, int(port)

    def api_base() -> str:
        host, port = server.api_address
        return f"http://{host}:{port}/lines/cell1"

    def serve_url() -> str:
        host, port = server.api_address
        return f"serve://{host}:{port}/cell1"

    for face, count in (("n1", config.n1), ("serve", config.serve), ("api", config.api)):
        for _ in range(count):
            index += 1
            name = f"{face}-{index}"
            if face == "api":
                out.append(
                    ApiConsumer(
                        name, index, config.seed, share, api_base, write_share=config.write_share
                    )
                )
                continue
            kind = _StaleConsumer if config.stale_consumer and index == 1 else ClientConsumer
            url = (lambda: server.n1_url) if face == "n1" else serve_url
            out.append(
                kind(
                    name,
                    index,
                    config.seed,
                    share,
                    url,
                    timeout=timeouts[(index - 1) % len(timeouts)],
                    write_share=config.write_share,
                    drop_share=0.02 if config.faults else 0.0,
                    raw_address=n1_address,
                )
            )
    return out


@contextlib.contextmanager
def _rig(config: HistoryConfig) -> Iterator[Rig]:
    with tempfile.TemporaryDirectory(prefix="robostar-history-") as state:
        rig = Rig(config, Path(state))
        try:
            rig.start_sim()
            rig.prepare()
            rig.start_server()
            yield rig
        finally:
            rig.close()


def _watcher(config: HistoryConfig, rig: Rig) -> ModelWatcher:
    def model() -> ControllerModel | None:
        server = rig.server.server if rig.server is not None else None
        return None if server is None else server.lines["cell1"].model

    # an AC's exchange ends within the line's timeout, or one resend's
    return ModelWatcher(model, (1, 2), exchange_bound=2 * config.line_timeout).start()


def run_history(
    config: HistoryConfig, progress: Callable[[int], None] | None = None
) -> HistoryReport:
    """One seeded run: the rig, the consumers to their last op, then the judge;
    ``progress(ops)`` now and then."""
    start = time.monotonic()
    player: FaultPlayer | None = None
    with _rig(config) as rig:
        since = time.monotonic()
        consumers = _consumers(config, rig)
        threads = [threading.Thread(target=c.run, name=c.plan.name) for c in consumers]
        watcher = _watcher(config, rig) if config.watch_model else None
        if config.faults:
            rig.faults_on()
            player = FaultPlayer(rig, config.seed, config.fault_every).start()
            if config.min_faults:
                faults = player

                def more() -> bool:
                    return faults.failure is None and sum(faults.begun.values()) < config.min_faults

                for consumer in consumers:
                    consumer.more = more
        for thread in threads:
            thread.start()
        next_report = 10_000
        while any(thread.is_alive() for thread in threads):
            threads[0].join(1.0)
            done = sum(len(c.ops) for c in consumers)
            if progress is not None and done >= next_report:
                progress(done)
                next_report += 10_000
        if player is not None:
            player.stop()
        if watcher is not None:
            watcher.stop()
        time.sleep(0.2)  # the last unknown-outcome writes reach the journal
    entries = rig.journal.entries or []
    ops: list[Op] = [op for c in consumers for op in c.ops]
    if watcher is not None:
        ops += watcher.ops
    verdict = judge(entries, ops, since=since)
    crashes = [f"{c.plan.name}: {c.crash!r}" for c in consumers if c.crash is not None]
    if player is not None and player.failure is not None:
        crashes.append(f"faults: {player.failure!r}")
    report = HistoryReport(config, ops, verdict, len(entries), time.monotonic() - start, crashes)
    if player is not None:
        report.faults = dict(player.played)
    return report


def run_seeds(base: HistoryConfig, seeds: Sequence[int]) -> list[HistoryReport]:
    import dataclasses

    return [run_history(dataclasses.replace(base, seed=seed)) for seed in seeds]
