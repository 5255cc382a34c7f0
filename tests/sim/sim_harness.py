"""Test helper: a real HostLink talking to a VirtualController in memory, on a fake clock.

``Harness.run(command)`` frames the request, pumps bytes both ways (stepping the fake clock to
the next deadline when the line is quiet) and returns the decoded answer, or the error flag
with KD's text. Nothing sleeps: time is ``harness.now``, moved by hand.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from robostar.commands.base import Command, Shape
from robostar.commands.files import UploadFile
from robostar.commands.system import ReadLastError
from robostar.protocol.link import (
    AnswerReceived,
    ExchangeComplete,
    ExchangeFailed,
    HostLink,
    UploadReady,
)
from robostar.sim import SimConfig, VirtualController


@dataclass(frozen=True)
class Failure:
    """An error answer: its flag and what KD said right after."""

    flag: int
    reason: str


class Stuck(AssertionError):
    """The exchange neither finished nor had anything left to wait for."""


class Harness:
    def __init__(
        self,
        config: SimConfig | None = None,
        *,
        store: Any = None,
        speedup: float = 50.0,
        **config_fields: Any,
    ):
        self.config = config or SimConfig(speedup=speedup, **config_fields)
        self.controller = VirtualController(self.config, store=store)
        self.model = self.controller.model
        self.host = HostLink(timeout=2.0)
        self.now = 0.0
        self.controller.output(self.now)

    # -- the line --------------------------------------------------------------------------------
    def _pump(self) -> tuple[list[Any], bool]:
        """Move bytes both ways once; the host's events and whether any byte moved."""
        events: list[Any] = []
        moved = False
        out = self.host.data_to_send()
        if out:
            moved = True
            self.controller.feed(out, self.now)
        back = self.controller.output(self.now)
        if back:
            moved = True
            events += self.host.receive_data(back, self.now)
        return events, moved

    def _flush(self) -> None:
        out = self.host.data_to_send()
        if out:
            self.controller.feed(out, self.now)

    def _step_clock(self, limit: float | None = None) -> bool:
        deadlines = [
            d for d in (self.controller.next_deadline(), self.host.next_deadline()) if d is not None
        ]
        if not deadlines:
            return False
        target = max(self.now, min(deadlines))
        if limit is not None and target > limit:
            return False
        self.now = target
        events = self.host.handle_timeout(self.now)
        assert not events or all(not isinstance(e, AnswerReceived) for e in events)
        return True

    def exchange(self, command: Command[Any]) -> tuple[list[bytes], Failure | None]:
        """Run one exchange; the answer packets, or the error answer (without reading KD)."""
        bodies = command.upload_bodies() if isinstance(command, UploadFile) else []
        return self.exchange_raw(command.encode(), command.SHAPE, bodies)

    def exchange_raw(
        self, data: bytes, shape: Shape = Shape.SINGLE, bodies: list[bytes] | None = None
    ) -> tuple[list[bytes], Failure | None]:
        """Run one exchange from a request packet's data (``FF G1 G2 ...``), as sent."""
        bodies = list(bodies or [])
        code = data[1:3].decode("ascii", "replace")
        events = self.host.send_request(data, shape, self.now)
        packets: list[bytes] = []
        error: int | None = None
        for _ in range(100_000):
            for event in events:
                if isinstance(event, AnswerReceived):
                    packets.append(event.data)
                    if event.flag in (0x31, 0x32, 0x33):
                        error = event.flag
                elif isinstance(event, UploadReady):
                    packets.append(event.data)
                    if bodies:
                        self.host.send_upload_line(bodies.pop(0), self.now)
                    else:
                        self.host.send_upload_end(self.now)
                elif isinstance(event, ExchangeComplete):
                    self._flush()  # the host's last ACK
                    return packets, (Failure(error, "") if error is not None else None)
                elif isinstance(event, ExchangeFailed):
                    raise AssertionError(f"exchange failed: {event}")
            events, moved = self._pump()
            if not moved and not events and not self._step_clock():
                raise Stuck(f"{code}: nothing more happens at t={self.now}")
        raise Stuck(f"{code}: no end")

    def run(self, command: Command[Any]) -> Any:
        """The decoded answer, or a Failure with KD's text."""
        packets, error = self.exchange(command)
        if error is not None:
            return Failure(error.flag, self.kd())
        return command.decode_answer(packets)

    def ok(self, command: Command[Any]) -> Any:
        """The decoded answer; fails the test on an error flag."""
        result = self.run(command)
        assert not isinstance(result, Failure), f"{command.CODE} refused: {result}"
        return result

    def fail(self, command: Command[Any], flag: int = 0x32) -> str:
        """Expect the error ``flag``; KD's reason."""
        result = self.run(command)
        assert isinstance(result, Failure), f"{command.CODE} was not refused: {result!r}"
        assert result.flag == flag, f"{command.CODE}: flag 0x{result.flag:02X}: {result.reason}"
        return result.reason

    def raw(self, data: bytes, shape: Shape = Shape.SINGLE) -> Failure | list[bytes]:
        """A raw request: the answer packets, or a Failure with KD's text."""
        packets, error = self.exchange_raw(data, shape)
        if error is not None:
            return Failure(error.flag, self.kd())
        return packets

    def kd(self) -> str:
        packets, error = self.exchange(ReadLastError())
        assert error is None
        return ReadLastError().decode_answer(packets)

    # -- time ------------------------------------------------------------------------------------
    def wait(self, seconds: float) -> None:
        """Let ``seconds`` of real time pass, with the line quiet (the host answers nothing)."""
        end = self.now + seconds
        for _ in range(100_000):
            self._pump()
            if not self._step_clock(limit=end):
                break
        else:
            raise Stuck(f"time does not move on at t={self.now}")
        self.now = end
        self._pump()

    def wait_model(self, seconds: float) -> None:
        """Let ``seconds`` of model time pass."""
        self.wait(seconds / self.config.speedup)

    def until(self, predicate: Any, timeout: float = 60.0) -> None:
        """Wait (real seconds) until ``predicate()`` holds."""
        end = self.now + timeout
        while not predicate():
            if self.now >= end:
                raise AssertionError(f"condition not met within {timeout} s")
            deadline = self.controller.next_deadline()
            step = 0.05 if deadline is None else max(min(deadline - self.now, 0.05), 1e-4)
            self.wait(step)
