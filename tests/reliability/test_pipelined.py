"""Pipelined requests under every fault: a host that writes two requests at once
(no robostar client does; third-party hosts and a line shared badly do) must never crash the
simulator, make it carry a state change out twice, or leave the line unusable, whatever byte of
the pair a fault hits."""

from __future__ import annotations

import pytest

from robostar.commands.status import ReadStatus
from robostar.commands.variables import WriteGlobalInt
from robostar.protocol.frame import ACK, FrameDecoder, Packet, encode_packet
from robostar.protocol.link import ExchangeComplete, ExchangeFailed, HostLink
from robostar.protocol.packets import Shape
from robostar.sim import SimConfig, VirtualController
from robostar.sim.faults import Direction, FaultInjector, FaultKind

PAIR = encode_packet(ReadStatus().encode()) + encode_packet(WriteGlobalInt(9, 42).encode())
KINDS = (
    FaultKind.CORRUPT,
    FaultKind.DROP,
    FaultKind.DUPLICATE,
    FaultKind.RST,
    FaultKind.REPEAT,
)


def _drive(injector: FaultInjector, start: float, seconds: float) -> float:
    """Feed the pair, ACK every answer packet, for ``seconds`` of fake time."""
    injector.feed(PAIR, start)
    decoder = FrameDecoder()
    now = start
    while now < start + seconds:
        for event in decoder.feed(injector.output(now)):
            if isinstance(event, Packet):
                injector.feed(bytes((ACK,)), now)
        now = round(now + 0.01, 6)
    return now


def _next_exchange_works(injector: FaultInjector, now: float) -> bool:
    host = HostLink(timeout=2.0)
    events = host.send_request(ReadStatus().encode(), Shape.SINGLE, now)
    end = now + 10.0
    while now < end:
        out = host.data_to_send()
        if out:
            injector.feed(out, now)
        data = injector.output(now)
        if data:
            events += host.receive_data(data, now)
        events += host.handle_timeout(now)
        out = host.data_to_send()
        if out:
            injector.feed(out, now)
        if any(isinstance(e, ExchangeComplete) for e in events):
            return True
        if any(isinstance(e, ExchangeFailed) for e in events):
            return False
        now = round(now + 0.01, 6)
    return False


@pytest.mark.parametrize("kind", KINDS, ids=lambda k: k.value)
@pytest.mark.parametrize("direction", [Direction.TO_CONTROLLER, Direction.TO_HOST])
def test_pipelined_requests_under_a_fault_at_every_byte(
    kind: FaultKind, direction: Direction
) -> None:
    if kind is FaultKind.REPEAT and direction is Direction.TO_CONTROLLER:
        pytest.skip("a repeat is of the controller's answers")
    positions = len(PAIR) if direction is Direction.TO_CONTROLLER else 24
    for position in range(positions):
        sim = VirtualController(SimConfig(seed=position, ack_timeout=0.3))
        injector = FaultInjector(sim, seed=position)
        injector.schedule(kind, direction, at_byte=position)
        now = _drive(injector, 0.0, 3.0)
        assert sim.executions["GW"] <= 1, f"@{position}: GW carried out twice"
        injector.clear()
        assert _next_exchange_works(injector, now + 1.0), f"@{position}: the line is stuck"


def test_without_a_fault_both_pipelined_requests_are_served() -> None:
    sim = VirtualController(SimConfig(seed=1, ack_timeout=0.3))
    injector = FaultInjector(sim)
    now = _drive(injector, 0.0, 3.0)
    assert sim.executions["GW"] == 1
    assert sim.session.requests == 2
    assert _next_exchange_works(injector, now)
