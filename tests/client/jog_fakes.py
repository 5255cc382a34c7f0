"""Helpers for the jog tests: a peer that notes the requests as the simulator gets them, and a
simulated clock for the jog's keepalive schedule (moved by the test, one interval at a time)."""

from __future__ import annotations

import time
from collections.abc import Callable
from types import SimpleNamespace

import pytest

from robostar.client import jog as jog_module
from robostar.protocol.frame import FrameDecoder, Packet
from robostar.sim import controller as controller_module
from robostar.transport import BytePeer

INTERVAL = 0.2
"""The client's keepalive interval (its default), in simulated seconds here."""
INTERVALS = 8
GIVE_UP = 20.0
"""Real seconds after which a wait for the next keepalive fails the test: reached only when a
keepalive never comes, never a measure of speed."""


class Arrivals:
    """A byte peer in front of the simulator that notes when each request arrives."""

    def __init__(self, peer: BytePeer) -> None:
        self.peer = peer
        self._decoder = FrameDecoder()
        self.times: list[tuple[float, str]] = []

    def feed(self, data: bytes, now: float) -> None:
        for event in self._decoder.feed(data):
            if isinstance(event, Packet) and event.data[:1] == b"\xff":
                self.times.append((now, event.data[1:3].decode()))
        self.peer.feed(data, now)

    @property
    def codes(self) -> list[str]:
        """The requests' codes, in the order they arrived."""
        return [code for _, code in self.times]

    def output(self, now: float) -> bytes:
        return self.peer.output(now)

    def next_deadline(self) -> float | None:
        return self.peer.next_deadline()

    def count(self, code: str) -> int:
        return sum(1 for _, c in self.times if c == code)


class SimulatedClock:
    """``time.monotonic`` for the jog's keepalive schedule, moved only by :meth:`advance`."""

    def __init__(self) -> None:
        self.now = 1000.0
        self.reads = 0

    def monotonic(self) -> float:
        self.reads += 1
        return self.now

    def advance(self, seconds: float) -> None:
        self.now += seconds


def simulate_jog_clock(monkeypatch: pytest.MonkeyPatch) -> SimulatedClock:
    """The jog module's clock, simulated. The simulator's jog watchdog (500 ms in real seconds)
    is set out of reach: real gaps mean nothing on a simulated schedule (bench.jog times them)."""
    simulated = SimulatedClock()
    monkeypatch.setattr(jog_module, "time", SimpleNamespace(monotonic=simulated.monotonic))
    monkeypatch.setattr(controller_module, "JOG_WATCHDOG", 3600.0)
    return simulated


def wait_for(condition: Callable[[], bool], what: str) -> None:
    """Block until ``condition()`` holds (GIVE_UP real seconds: it never will, a failure)."""
    give_up = time.monotonic() + GIVE_UP
    while not condition():
        assert time.monotonic() < give_up, f"never: {what}"
        time.sleep(0.002)
