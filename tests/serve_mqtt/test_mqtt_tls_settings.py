"""Client certificates without TLS: ``cert``/``key`` on an ``mqtt://`` URL would be silently
unused, the face connecting in clear (its password too), so they are refused, clearly."""

from __future__ import annotations

from typing import Any

import pytest

from robostar.errors import UsageError
from robostar.serve.faces.mqtt import settings_from


@pytest.mark.parametrize(
    "options",
    [
        {"cert": "/etc/robostar/client.pem", "key": "/etc/robostar/client.key"},
        {"cert": "/etc/robostar/client.pem"},
        {"key": "/etc/robostar/client.key"},
    ],
)
def test_client_certificates_without_tls_are_refused(options: dict[str, Any]) -> None:
    with pytest.raises(UsageError, match="need TLS"):
        settings_from({"url": "mqtt://broker.plant:1883", **options})


@pytest.mark.parametrize(
    "options",
    [
        {"url": "mqtts://broker.plant"},
        {"url": "mqtt://broker.plant:8883", "ca": "/etc/robostar/plant-ca.pem"},
    ],
)
def test_client_certificates_with_tls_are_taken(options: dict[str, Any]) -> None:
    cert = {"cert": "/etc/robostar/client.pem", "key": "/etc/robostar/client.key"}
    settings = settings_from({**options, **cert})
    assert settings.tls and settings.cert == cert["cert"] and settings.key == cert["key"]


def test_a_key_without_a_certificate_is_refused() -> None:
    with pytest.raises(UsageError, match=r"mqtt\.key"):
        settings_from({"url": "mqtts://broker.plant", "key": "/etc/robostar/client.key"})


def test_the_refusal_does_not_show_a_password_from_the_url() -> None:
    with pytest.raises(UsageError) as refused:
        settings_from({"url": "mqtt://cell3:s3cret@broker.plant:1883", "cert": "/c.pem"})
    assert "s3cret" not in str(refused.value) and "mqtts://broker.plant:1883" in str(refused.value)
