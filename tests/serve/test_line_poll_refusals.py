"""The poller and the controller's refusals: a refusal of the moment (0x31/0x32) leaves the key
polled and its old value stale; only 0x33 (not supported) gives a key up, and only until the line
reopens."""

from __future__ import annotations

import asyncio

from robostar.commands.control import ReadSpeed, SetSpeed
from robostar.commands.status import ReadStatus
from robostar.errors import FunctionFailedError, NotSupportedError, PortError
from robostar.serve import LineConfig, Quality, Who
from robostar.serve.line import Line
from robostar.serve.model import Subscription

from .line_fakes import FaultySim, wait_for

ANN = Who("ann", "api")


def _fast(name: str = "cell1") -> LineConfig:
    return LineConfig(name, "sim://", poll_interval=0.02, slow_interval=0.05)


async def _seen(changes: Subscription, key: str, quality: Quality, timeout: float = 2.0) -> bool:
    """True once a change of ``key`` with ``quality`` arrives within ``timeout``."""

    async def look() -> None:
        async for change in changes:
            if change.key == key and change.sample.quality is quality:
                return

    try:
        await asyncio.wait_for(look(), timeout)
    except TimeoutError:
        return False
    return True


def test_a_status_poll_refused_for_the_moment_goes_stale_and_is_polled_again() -> None:
    sim = FaultySim()

    async def main() -> None:
        line = Line(_fast(), client_factory=sim.client)
        await line.start()
        try:
            await line.wait_polled()
            with line.model.subscribe() as changes:
                sim.refuse_once(ReadStatus, FunctionFailedError("AA", "cannot be done now"))
                # the cycle that was refused: the status it holds is no longer vouched for
                assert await _seen(changes, "ch1/status", Quality.STALE)
            channel = sim.controller.model.channels[0]
            channel.servo = not channel.servo  # switched at the pendant
            # AA is still polled: the model catches up, and says good again
            assert await wait_for(
                lambda: (
                    (s := line.model.get("ch1/status")) is not None
                    and s.quality is Quality.GOOD
                    and s.value.servo_on == channel.servo
                )
            )
            assert not line.poller.unsupported
        finally:
            await line.stop()

    asyncio.run(main())


def test_a_slow_poll_refused_for_the_moment_goes_stale_and_follows_a_later_write() -> None:
    sim = FaultySim()

    async def main() -> None:
        line = Line(_fast(), client_factory=sim.client)
        await line.start()
        try:
            await line.wait_polled()
            with line.model.subscribe() as changes:
                busy = FunctionFailedError("CS", "busy")
                sim.refuse_once(ReadSpeed, busy, lambda c: c.channel == 1)
                assert await _seen(changes, "ch1/speed", Quality.STALE)
            await line.execute(SetSpeed(1, 123), who=ANN, implicit_lease=True)
            assert await wait_for(
                lambda: (
                    (s := line.model.get("ch1/speed")) is not None
                    and s.quality is Quality.GOOD
                    and s.value == 123
                )
            )
        finally:
            await line.stop()

    asyncio.run(main())


def test_a_key_not_supported_is_given_up_as_stale_until_the_line_reopens() -> None:
    sim = FaultySim()

    def speed_reads() -> int:
        return sum(isinstance(c, ReadSpeed) and c.channel == 1 for c in sim.sent)

    async def main() -> None:
        line = Line(_fast(), client_factory=sim.client)
        await line.start()
        try:
            await line.wait_polled()
            sim.refuse_once(ReadSpeed, NotSupportedError("CS"), lambda c: c.channel == 1)
            assert await wait_for(lambda: "ch1/speed" in line.poller.unsupported)
            sample = line.model.get("ch1/speed")
            assert sample is not None and sample.quality is Quality.STALE  # not vouched for
            given_up_at = speed_reads()
            await asyncio.sleep(0.3)  # several slow cycles: CS is not asked again
            assert speed_reads() == given_up_at
            assert line.model.get("ch1/speed").quality is Quality.STALE  # type: ignore[union-attr]

            # the line drops and reopens (it may be another controller now): asked again
            sim.refuse_once(ReadStatus, PortError("the port went away"))
            assert await wait_for(lambda: line.health.reconnects >= 1)
            assert await wait_for(lambda: speed_reads() > given_up_at)
            assert await wait_for(
                lambda: (s := line.model.get("ch1/speed")) is not None and s.quality is Quality.GOOD
            )
            assert "ch1/speed" not in line.poller.unsupported
        finally:
            await line.stop()

    asyncio.run(main())
