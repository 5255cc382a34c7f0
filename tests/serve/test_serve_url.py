"""``serve://[::1]:PORT/LINE``: the serve:// transport with an IPv6 API address, brackets kept
in the request it makes, in its URL and in its error messages."""

from __future__ import annotations

import asyncio
import socket

import pytest

from robostar import AsyncClient, Client
from robostar.errors import PortError
from robostar.serve import LineConfig, LineServer, ServeConfig
from robostar.transport.line_server import ServeTransport, resolve_line
from robostar.transport.opener import async_transport_for_url, transport_for_url


def _has_ipv6_loopback() -> bool:
    if not socket.has_ipv6:
        return False
    try:
        with socket.socket(socket.AF_INET6, socket.SOCK_STREAM) as probe:
            probe.bind(("::1", 0))
    except OSError:
        return False
    return True


needs_ipv6 = pytest.mark.skipif(not _has_ipv6_loopback(), reason="no IPv6 loopback (::1) here")


def _free_v6_port() -> int:
    """A port nothing listens on at ::1 (bound, then closed)."""
    with socket.socket(socket.AF_INET6, socket.SOCK_STREAM) as probe:
        probe.bind(("::1", 0))
        return int(probe.getsockname()[1])


def _config(**faces: object) -> ServeConfig:
    lines = (LineConfig("cell1", "sim://", poll_interval=0.05),)
    return ServeConfig(lines=lines, faces={"api": {"listen": "[::1]:0"}, **faces})  # type: ignore[dict-item]


@needs_ipv6
@pytest.mark.parametrize("n1", [None, "[::1]:0"], ids=["api-own-n1", "n1-on-ipv6"])
def test_a_client_reaches_a_line_through_an_api_on_ipv6_loopback(n1: str | None) -> None:
    faces = {} if n1 is None else {"n1": {"lines": {"cell1": n1}}}

    async def main() -> None:
        async with LineServer(_config(**faces)) as server:
            host, port = server.faces["api"].address  # type: ignore[attr-defined]
            assert host == "::1"
            url = f"serve://[::1]:{port}/cell1"

            def through() -> None:
                with Client(url) as client:
                    assert client.url == url
                    client.set_speed(1, 62)
                    assert client.speed(1) == 62
                    assert client.info().name == "N1-SIM"
                    assert f"[::1]:{port}" in repr(client.transport)
                # the N1 address the API gave, IPv6 when the N1 face listens there
                address = resolve_line("::1", port, "cell1", None, 5.0)
                assert address[0] == ("::1" if n1 else "127.0.0.1")

            await asyncio.to_thread(through)
            async with AsyncClient(url) as client:
                assert await client.speed(1) == 62

    asyncio.run(main())


@needs_ipv6
def test_an_ipv6_line_the_server_does_not_have_is_named_with_brackets() -> None:
    async def main() -> None:
        async with LineServer(_config()) as server:
            _, port = server.faces["api"].address  # type: ignore[attr-defined]

            def nope() -> None:
                with pytest.raises(PortError) as caught:
                    Client(f"serve://[::1]:{port}/nope").connect()
                text = str(caught.value)
                assert text.startswith(f"serve://[::1]:{port}/nope: 404"), text
                assert "no line 'nope'" in text

            await asyncio.to_thread(nope)

    asyncio.run(main())


@needs_ipv6
def test_no_server_at_an_ipv6_address_is_said_with_brackets() -> None:
    port = _free_v6_port()
    with pytest.raises(PortError) as caught:
        resolve_line("::1", port, "cell1", None, 2.0)
    text = str(caught.value)
    assert text.startswith(f"serve://[::1]:{port}/cell1: no line server API there"), text
    assert "[::1]" in text and "nonnumeric" not in text


def test_the_url_keeps_its_brackets_however_the_transport_is_made() -> None:
    url = "serve://[::1]:8470/cell1"
    for transport in (transport_for_url(url), async_transport_for_url(url)):
        assert transport.url == url and "[::1]:8470" in repr(transport)
        assert transport.api == ("::1", 8470)  # type: ignore[attr-defined]
    # made by hand, with no url: its own, in brackets, with the serve:// scheme
    assert ServeTransport("::1", 8470, "cell1").url == url
    assert ServeTransport("127.0.0.1", 8470, "cell1").url == "serve://127.0.0.1:8470/cell1"
