"""A state change without the lease while nobody holds it: the refusal says to take it first."""

from __future__ import annotations

import asyncio

import pytest

from robostar.commands.control import SetSpeed
from robostar.serve import LeaseHeldError, Who
from robostar.serve.lease import Lease

from .conftest import sim_server


def test_renewing_a_free_lease_says_nobody_holds_it() -> None:
    lease = Lease("press", clock=lambda: 1000.0)
    with pytest.raises(LeaseHeldError) as caught:
        lease.renew(Who("ann", "api"))
    assert caught.value.holder is None
    assert str(caught.value) == "line press: nobody holds the control lease; take it first"


def test_a_write_when_nobody_holds_the_lease_is_told_to_take_it_first() -> None:
    async def main() -> str:
        async with sim_server(poll_interval=0.5) as server:
            line = server.lines["cell1"]
            assert line.lease.holder is None
            with pytest.raises(LeaseHeldError) as caught:  # the API without implicit_lease
                await line.execute(SetSpeed(1, 10), who=Who("ann", "api"))
            return str(caught.value)

    text = asyncio.run(main())
    assert "nobody holds the control lease; take it first" in text
    assert "held by" not in text and "expires" not in text


def test_a_held_lease_still_names_its_holder() -> None:
    lease = Lease("press", ttl=30.0, clock=lambda: 1000.0)
    lease.acquire(Who("bob", "n1"))
    with pytest.raises(LeaseHeldError, match=r"control is held by bob \(n1\)"):
        lease.acquire(Who("ann", "api"))
