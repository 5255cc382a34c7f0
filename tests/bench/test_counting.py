"""The wire item's breakdown: the host's turnaround is the time the line waited on the host."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from bench.counting import CountingTransport  # noqa: E402
from bench.measure import wire_seconds  # noqa: E402

from robostar.transport import Transport  # noqa: E402


class _Line(Transport):
    url = "test://"
    is_open = True

    def __init__(self, answers: list[bytes]) -> None:
        self.answers = answers

    def open(self) -> None: ...

    def close(self) -> None: ...

    def write(self, data: bytes) -> None: ...

    def read(self, timeout: float) -> bytes:
        return self.answers.pop(0)


def test_host_turnaround_counts_only_while_nothing_is_on_the_wire(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    now = [100.0]
    monkeypatch.setattr("bench.counting.time.perf_counter", lambda: now[0])
    line = CountingTransport(_Line([b"\x02\xff0\x03\x00", b""]))
    line.restart_busy()
    request = b"\x02\xffAA\x03\x00"
    line.write(request)  # the first write: nothing read before it, nothing counted
    now[0] += 0.010
    line.read(1.0)  # the answer's last byte came in at 100.010
    now[0] += 0.000_040
    line.write(b"\x06")  # 40 µs deciding to ACK: the line waited
    assert line.host_busy == pytest.approx(0.000_040)
    now[0] += wire_seconds(1) / 2
    line.write(request)  # the next request while the ACK is still on the wire: no wait
    assert line.host_busy == pytest.approx(0.000_040)
    now[0] += 0.001
    line.read(0.1)  # nothing came: the line is not free on account of it
    line.write(b"\x06")
    # the request went on the wire after the ACK: the line was free at 1 byte + the request
    waited = 0.001 + wire_seconds(1) / 2 - wire_seconds(1) - wire_seconds(len(request))
    assert line.host_busy == pytest.approx(0.000_040 + waited)
    assert line.sent == 2 * len(request) + 2 and line.received == 5
