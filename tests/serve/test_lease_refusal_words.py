"""A state change refused because another consumer holds the line's control reads as the line
server's lease refusal, through serve:// and in the console: a ControlHeldError naming the line,
the holder, its face and until when (not a controller 0x32 with the controller's recovery
hints); a later `last-error` tells the controller's text and the server's refusal apart."""

from __future__ import annotations

import asyncio
import re

import pytest

from robostar.cli.failures import explain
from robostar.client import Client
from robostar.errors import ControlHeldError, FunctionFailedError, error_for_flag
from robostar.serve import LineConfig, LineServer, ServeConfig

UNTIL = re.compile(r"^\d\d:\d\d:\d\d UTC$")


def _config() -> ServeConfig:
    return ServeConfig(
        lines=(LineConfig("cell1", "sim://", poll_interval=0.5),),
        faces={"api": {"listen": "127.0.0.1:0"}, "n1": {"lines": {"cell1": "127.0.0.1:0"}}},
    )


def test_a_refusal_through_serve_names_the_holder_as_the_servers() -> None:
    async def main() -> None:
        async with LineServer(_config()) as server:
            api_host, api_port = server.faces["api"].address  # type: ignore[attr-defined]
            n1_host, n1_port = server.faces["n1"].addresses["cell1"]  # type: ignore[attr-defined]
            serve = f"serve://{api_host}:{api_port}/cell1"

            def hosts() -> None:
                with Client(f"tcp://{n1_host}:{n1_port}", timeout=2.0) as host_a:
                    host_a.set_speed(1, 40)  # the cell's host program holds control
                    with (
                        Client(serve, timeout=2.0) as console,
                        pytest.raises(ControlHeldError) as caught,
                    ):
                        console.servo(1, True)
                    error = caught.value
                    assert isinstance(error, FunctionFailedError)  # old handlers still catch it
                    assert error.line == "cell1" and error.face == "n1"
                    assert error.holder.startswith("n1:127.0.0.1:")
                    assert UNTIL.match(error.until), error.until
                    assert "control of line cell1 is held by n1:" in str(error)
                    assert "by the controller" not in str(error)
                    failure = explain(error, serve)
                    assert failure.message.startswith("Control of line cell1 is held by n1:")
                    assert "refused by the controller" not in failure.message
                    assert "servo" not in (failure.hint or "").lower()  # no controller recovery
                    # a new connection (the console's `last-error`): not a bare "no error"
                    with Client(serve, timeout=2.0) as later:
                        text = later.last_error()
                    assert text.startswith("controller: no error;"), text
                    assert "refused by the line server: control of line cell1" in text

            await asyncio.to_thread(hosts)

    asyncio.run(main())


def test_a_controllers_own_refusal_stays_a_controller_error() -> None:
    error = error_for_flag(0x32, "DB", "channel 2 has an alarm")
    assert type(error) is FunctionFailedError
    held = error_for_flag(
        0x32,
        "CB",
        "line server: control of line a-1 is held by Ann (Lab) (web) until 10:00:00 UTC;"
        " nothing was sent",
    )
    assert isinstance(held, ControlHeldError)
    assert (held.line, held.holder, held.face, held.until) == (
        "a-1",
        "Ann (Lab)",
        "web",
        "10:00:00 UTC",
    )
