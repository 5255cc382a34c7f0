"""Fuzz target for the simulator's request handling: any request data, then a probe.

One :class:`SimHarness` keeps a virtual controller across inputs (its state drifts as a real
controller's would). Each input is framed and sent as a request (or, when it holds framing
bytes, sent raw); the controller's answers are ACKed as a host would, time runs on past every
timer, and then an AA exchange must still complete: the simulator never raises, never writes a
damaged frame and never stops answering.
"""

from __future__ import annotations

from reliability.targets import Violation
from robostar.commands.status import ReadStatus
from robostar.protocol.frame import ACK, CorruptPacket, FrameDecoder, Packet, encode_packet
from robostar.protocol.link import AnswerReceived, ExchangeComplete, ExchangeFailed, HostLink
from robostar.sim import SimConfig, VirtualController

__all__ = ["SimHarness", "check_sim_request"]

_ROUNDS = 2000
"""Steps a fuzzed exchange may take before the harness calls the controller stuck."""
_PROBE = ReadStatus()


class SimHarness:
    """A virtual controller, fast model time, short timers, and a clock the harness moves."""

    def __init__(self) -> None:
        self.sim = VirtualController(SimConfig(speedup=1000.0, ack_timeout=0.2))
        self.now = 0.0
        self.inputs = 0

    def take(self) -> bytes:
        try:
            return self.sim.output(self.now)
        except Exception as exc:
            raise Violation(f"VirtualController.data_to_send raised {exc!r}") from exc

    def give(self, data: bytes) -> None:
        try:
            self.sim.feed(data, self.now)
        except Exception as exc:
            raise Violation(f"VirtualController.receive_data({data!r}) raised {exc!r}") from exc

    def settle(self) -> None:
        """ACK every intact packet as a host does; let every timer run out."""
        decoder = FrameDecoder()
        for _ in range(_ROUNDS):
            out = self.take()
            acks = b""
            for event in decoder.feed(out):
                if isinstance(event, CorruptPacket):
                    raise Violation(f"the simulator wrote a damaged frame {event.raw!r}")
                if isinstance(event, Packet):
                    acks += bytes((ACK,))
            if acks:
                self.give(acks)
                continue
            if out:
                continue
            deadline = self.sim.next_deadline()
            if deadline is None or (self.sim.link.idle and deadline > self.now + 5):
                return
            self.now = max(self.now, deadline) + 0.001
        if not self.sim.link.idle:
            raise Violation(f"the simulator is stuck in {self.sim.link.state}")

    def probe(self) -> None:
        """An AA exchange must complete with a well-formed status answer."""
        link = HostLink(timeout=1.0)
        self.now += 0.01
        events = link.send_request(_PROBE.encode(), _PROBE.SHAPE, self.now)
        answers: list[bytes] = []
        for _ in range(_ROUNDS):
            self.give(link.data_to_send())
            self.now += 0.001
            out = self.take()
            events += link.receive_data(out, self.now)
            answers += [e.data for e in events if isinstance(e, AnswerReceived)]
            if any(isinstance(e, ExchangeComplete | ExchangeFailed) for e in events):
                break
            events = []
        self.give(link.data_to_send())
        done = [e for e in events if isinstance(e, ExchangeComplete | ExchangeFailed)]
        if not done or not isinstance(done[0], ExchangeComplete):
            raise Violation(f"the simulator did not answer AA after a fuzzed request: {done!r}")
        _PROBE.decode_answer(answers)

    def feed(self, data: bytes) -> str:
        self.inputs += 1
        self.now += 0.01
        try:
            frame = encode_packet(data)
        except Exception:
            frame = b"\x02" + data + b"\x03\x00"
        requests = self.sim.requests
        self.give(frame)
        self.settle()
        self.probe()
        self.settle()
        return "answered" if self.sim.requests > requests else "not a request"


_harness: SimHarness | None = None


def check_sim_request(data: bytes) -> str:
    """Feed ``data`` to a shared harness (renewed every 2000 inputs, so runs stay quick, and
    after a violation)."""
    global _harness
    if _harness is None or _harness.inputs >= 2000:
        _harness = SimHarness()
    try:
        return _harness.feed(data)
    except Violation:
        _harness = None  # a controller that broke a promise is not fuzzed further
        raise
