"""The virtual N1 controller's model: its state and every operation, in model time, with no I/O.

:class:`Model` holds the channels (servo, origin, position, motion, jog, files, job), the I/O
contacts, the global variables, the alarms, the parameters and the KD text (see
:mod:`robostar.sim.state`), and the operations the commands call (``ops_*`` modules); they check
the controller rules and raise :class:`Refused` (the answer flag and KD's reason) when one is
broken. Tests drive the hooks directly: ``set_input``, ``raise_alarm``, ``channel(n).joints``,
files, globals. :meth:`Model.snapshot` and :meth:`Model.restore` keep what a controller keeps
across power-off.
"""

from __future__ import annotations

from typing import Any

from robostar.errors import UsageError
from robostar.protocol.fields import FileName
from robostar.sim.alarms import AlarmEntry
from robostar.sim.filesystem import ChannelFiles, StoredJob
from robostar.sim.jobs import JobRunner, JobSyntaxError, parse_job
from robostar.sim.ops_data import DataOps
from robostar.sim.ops_files import FileOps
from robostar.sim.ops_jobs import JobOps
from robostar.sim.parameters import public_parameters
from robostar.sim.snapshot import check_snapshot
from robostar.sim.state import Refused, Timer
from robostar.types import (
    ArmForm,
    Point,
)

__all__ = ["Model", "Refused", "Timer"]

SNAPSHOT_FORMAT = 1


class Model(JobOps, FileOps, DataOps):
    """The virtual controller. Model time (``clock``, the work timer) is in seconds."""

    # -- persistence ---------------------------------------------------------------------------
    def snapshot(self) -> dict[str, Any]:
        """Everything a controller keeps across power-off, as JSON-ready data."""
        return {
            "format": SNAPSHOT_FORMAT,
            "work_timer": self.clock,
            "channels": [
                {
                    "files": ch.files.to_json(),
                    "speed": ch.speed,
                    "job": str(ch.job_name) if ch.job_name is not None else None,
                    "points": [
                        [i, list(p.axes), int(p.arm), p.used] for i, p in sorted(ch.points.items())
                    ],
                }
                for ch in self.channels
            ],
            "ints": [[i, v] for i, v in sorted(self.ints.items())],
            "floats": [[i, v] for i, v in sorted(self.floats.items())],
            "outputs": [[int(c) for c in port] for port in self.outputs],
            "alarm_history": [entry.to_json() for entry in reversed(self.alarms.history)],
            "parameters": {str(i): t for i, t in sorted(self.public_parameters.items())},
        }

    def restore(self, data: dict[str, Any]) -> None:
        """Load a :meth:`snapshot` (channels beyond this configuration's are ignored).

        A snapshot that does not read as one raises UsageError and leaves the model as it was.
        """
        if not isinstance(data, dict) or data.get("format") != SNAPSHOT_FORMAT:
            found = data.get("format") if isinstance(data, dict) else type(data).__name__
            raise UsageError(f"state snapshot: format {found!r} is not {SNAPSHOT_FORMAT}")
        check_snapshot(data)
        fresh = Model(self.config)
        try:
            fresh._restore(data)
        except (KeyError, TypeError, ValueError, IndexError) as exc:
            raise UsageError(f"state snapshot: unreadable ({type(exc).__name__}: {exc})") from None
        self.__dict__.update(fresh.__dict__)

    def _restore(self, data: dict[str, Any]) -> None:
        self.clock = float(data["work_timer"])
        for ch, saved in zip(self.channels, data["channels"], strict=False):
            ch.files = ChannelFiles.from_json(saved["files"])
            ch.speed = int(saved["speed"])
            ch.points = {
                int(i): Point(tuple(float(v) for v in axes), ArmForm(int(arm)), bool(used))
                for i, axes, arm, used in saved["points"]
            }
            ch.job = None
            ch.job_name = None
            stored = ch.files.get(FileName.parse(saved["job"])) if saved["job"] else None
            if isinstance(stored, StoredJob):
                try:
                    ch.job = JobRunner(ch.number, parse_job(stored.lines))
                except JobSyntaxError:
                    continue
                ch.job_name = stored.name
        self.ints = {int(i): int(v) for i, v in data["ints"]}
        self.floats = {int(i): float(v) for i, v in data["floats"]}
        self.outputs = [[bool(c) for c in port] for port in data["outputs"]]
        self.alarms.history = [AlarmEntry.from_json(e) for e in reversed(data["alarm_history"])]
        saved_parameters = {int(i): str(t) for i, t in data["parameters"].items()}
        derived = public_parameters(self.config)
        # The configuration decides what it describes; other texts come back as they were.
        self.public_parameters = {**derived, **saved_parameters, **_config_owned(derived)}


def _config_owned(derived: dict[int, str]) -> dict[int, str]:
    """The public parameters the configuration sets (AUTO SVON, DIO, MAX_CH, NAME)."""
    return {i: derived[i] for i in (4, 8, 10, 54)}
