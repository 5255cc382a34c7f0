"""Serving the dashboard beyond loopback needs saying so, and TLS or a proxy that terminates it."""

from __future__ import annotations

from pathlib import Path

import pytest

from robostar.errors import UsageError
from robostar.serve.config import ServeConfig
from robostar.serve.faces.web import WebFace
from robostar.serve.line_server import LineServer


def _server() -> LineServer:
    return LineServer(ServeConfig(lines=(), faces={}))


def test_a_network_address_needs_allow_remote() -> None:
    with pytest.raises(UsageError, match="allow_remote"):
        WebFace(_server(), {"listen": "0.0.0.0:8080"})


def test_allow_remote_still_needs_tls_or_a_proxy() -> None:
    with pytest.raises(UsageError, match="TLS"):
        WebFace(_server(), {"listen": "0.0.0.0:8080", "allow_remote": True})


def test_half_a_tls_pair_is_refused(tmp_path: Path) -> None:
    cert = tmp_path / "cert.pem"
    cert.write_text("not used")
    with pytest.raises(UsageError, match="both tls_cert and tls_key"):
        WebFace(_server(), {"listen": "127.0.0.1:0", "tls_cert": str(cert)})


def test_behind_a_proxy_the_cookies_are_https_only() -> None:
    face = WebFace(
        _server(), {"listen": "0.0.0.0:8080", "allow_remote": True, "behind_proxy": True}
    )
    assert face.settings.https_only


def test_unknown_options_are_named() -> None:
    with pytest.raises(UsageError, match="unknown option"):
        WebFace(_server(), {"listen": "127.0.0.1:0", "passwd": "x"})
