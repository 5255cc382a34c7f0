"""The peers a listener serves (``allow_from``, one parser and one check for every face whose
protocol has no authentication): a clear error naming the option for anything that is not a
list of addresses and networks, loopback always served, and nobody else unless named."""

from __future__ import annotations

import ipaddress

import pytest

from robostar.errors import UsageError
from robostar.listen import admits, parse_networks


def test_addresses_and_networks_of_both_families_are_read() -> None:
    assert parse_networks(["192.0.2.7", " 10.1.0.0/16 ", "2001:db8::/32"]) == (
        ipaddress.ip_network("192.0.2.7/32"),
        ipaddress.ip_network("10.1.0.0/16"),
        ipaddress.ip_network("2001:db8::/32"),
    )
    assert parse_networks(("10.1.2.3/16",)) == (ipaddress.ip_network("10.1.0.0/16"),)
    assert parse_networks([]) == ()


@pytest.mark.parametrize(
    ("bad", "words"),
    [
        ("192.0.2.7", "is not a list of addresses or networks"),
        (b"192.0.2.7", "is not a list of addresses or networks"),
        ({"plc": "192.0.2.7"}, "is not a list of addresses or networks"),
        (7, "is not a list of addresses or networks"),
        (["plc-7"], "'plc-7' is not an address or network"),
        (["10.1.0.300"], "'10.1.0.300' is not an address or network"),
        (["192.0.2.7", None], "None is not an address or network"),
    ],
)
def test_anything_else_is_a_clear_error_naming_the_option(bad: object, words: str) -> None:
    with pytest.raises(UsageError, match=rf"^modbus\.allow_from: .*{words}"):
        parse_networks(bad, "modbus.allow_from")
    with pytest.raises(UsageError, match=r"^allow_from: "):
        parse_networks(bad)


def test_loopback_always_and_the_named_peers_only() -> None:
    allowed = parse_networks(["192.0.2.7", "10.1.0.0/16", "2001:db8::/32"])
    for peer in [
        ("192.0.2.7", 4000),
        ("10.1.200.3", 4000),
        ("::ffff:10.1.0.9", 4000, 0, 0),  # IPv4 on an IPv6 socket
        ("2001:db8::5", 4000, 0, 0),
        ("127.0.0.1", 4000),
        ("127.9.9.9", 4000),
        ("::1", 4000, 0, 0),
    ]:
        assert admits(allowed, peer), peer
    link_local = ("fe80::1%eth0", 4000, 0, 2)  # a scope id is not part of the address
    assert admits(parse_networks(["fe80::/10"]), link_local)
    assert not admits(allowed, link_local)
    for peer in [("192.0.2.8", 4000), ("198.51.100.9", 4000), ("::ffff:192.0.2.8", 1, 0, 0)]:
        assert not admits(allowed, peer), peer
    assert not admits(allowed, "/a/unix/socket")
    assert not admits(allowed, None)
    assert not admits(allowed, ())
    assert not admits((), ("192.0.2.7", 4000))  # an empty list: loopback only
    assert admits((), ("127.0.0.1", 4000))


def test_no_list_serves_everyone_the_listener_reaches() -> None:
    assert admits(None, ("198.51.100.9", 4000))
    assert admits(None, "/a/unix/socket")
