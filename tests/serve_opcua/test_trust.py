"""The client trust list: only client applications whose certificate is in ``pki/trusted`` get
a session; an unknown one is refused and its certificate kept in ``pki/rejected`` for an
administrator to move, which takes effect without a restart; ``accept_unknown_clients`` lets any
application in (the user is still checked); out-of-date certificates are refused; the rejected
folder cannot be filled without bound."""

from __future__ import annotations

import asyncio
import datetime as dt
import shutil
from pathlib import Path

import pytest
from asyncua import Client, ua
from asyncua.crypto.cert_gen import setup_self_signed_certificate
from cryptography import x509
from cryptography.hazmat.primitives import hashes
from cryptography.hazmat.primitives.asymmetric import rsa
from cryptography.x509.oid import ExtendedKeyUsageOID, NameOID

from robostar.serve.faces.opcua.trust import MAX_REJECTED, ClientTrustList

from .conftest import PASSWORDS, Setup, serving

pytestmark = pytest.mark.timeout(120)

STRANGER_URI = "urn:robostar:tests:stranger"


async def _stranger(root: Path) -> tuple[Path, Path]:
    cert, key = root / "stranger-cert.der", root / "stranger-key.pem"
    await setup_self_signed_certificate(
        key, cert, STRANGER_URI, "localhost", [ExtendedKeyUsageOID.CLIENT_AUTH], {}
    )
    return cert, key


async def _sign_in(address: str, cert: Path, key: Path) -> None:
    client = Client(address, timeout=10)
    client.application_uri = STRANGER_URI
    await client.set_security_string(f"Basic256Sha256,SignAndEncrypt,{cert},{key}")
    client.set_user("olga")
    client.set_password(PASSWORDS["olga"])
    async with client:
        await client.get_namespace_array()


def test_an_unknown_client_is_refused_until_trusted(opcua_setup: Setup, tmp_path: Path) -> None:
    async def main() -> None:
        cert, key = await _stranger(tmp_path)
        async with serving(opcua_setup) as server:
            address = server.faces["opcua"].address  # type: ignore[attr-defined]
            with pytest.raises(ua.UaStatusCodeError) as refused:
                await _sign_in(address, cert, key)
            assert refused.value.code == ua.StatusCodes.BadCertificateUntrusted
            pki = opcua_setup.state / "pki"
            kept = list((pki / "rejected").glob("*.der"))
            assert [p.read_bytes() for p in kept] == [cert.read_bytes()]
            # the administrator moves it: accepted at the next attempt, no restart
            shutil.move(kept[0], pki / "trusted" / kept[0].name)
            try:
                await _sign_in(address, cert, key)
            finally:
                (pki / "trusted" / kept[0].name).unlink()

    asyncio.run(main())


def test_unknown_clients_may_be_accepted_by_configuration(
    opcua_setup: Setup, tmp_path: Path
) -> None:
    async def main() -> None:
        cert, key = await _stranger(tmp_path)
        async with serving(
            opcua_setup, accept_unknown_clients=True, pki_dir=str(tmp_path / "pki")
        ) as server:
            await _sign_in(server.faces["opcua"].address, cert, key)  # type: ignore[attr-defined]
        assert len(list((tmp_path / "pki" / "rejected").glob("*.der"))) == 1  # for the record

    asyncio.run(main())


def _certificate(days: tuple[int, int]) -> x509.Certificate:
    key = rsa.generate_private_key(public_exponent=65537, key_size=2048)
    name = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, "old")])
    now = dt.datetime.now(dt.UTC)
    return (
        x509.CertificateBuilder()
        .subject_name(name)
        .issuer_name(name)
        .public_key(key.public_key())
        .serial_number(x509.random_serial_number())
        .not_valid_before(now + dt.timedelta(days=days[0]))
        .not_valid_after(now + dt.timedelta(days=days[1]))
        .sign(key, hashes.SHA256())
    )


def test_an_out_of_date_certificate_is_refused_even_if_trusted(tmp_path: Path) -> None:
    from cryptography.hazmat.primitives.serialization import Encoding

    trust = ClientTrustList(tmp_path / "pki")
    expired = _certificate((-30, -1))
    (tmp_path / "pki" / "trusted" / "old.der").write_bytes(expired.public_bytes(Encoding.DER))
    app = ua.ApplicationDescription()
    with pytest.raises(ua.UaStatusCodeError) as refused:
        asyncio.run(trust(expired, app))
    assert refused.value.code == ua.StatusCodes.BadCertificateTimeInvalid


def test_the_rejected_folder_is_bounded(tmp_path: Path) -> None:
    trust = ClientTrustList(tmp_path / "pki")
    for index in range(MAX_REJECTED + 5):
        (tmp_path / "pki" / "rejected" / f"{index}.der").write_bytes(b"x")
    with pytest.raises(ua.UaStatusCodeError):
        asyncio.run(trust(_certificate((-1, 1)), ua.ApplicationDescription()))
    assert len(list((tmp_path / "pki" / "rejected").iterdir())) == MAX_REJECTED + 5


def test_the_trust_settings_are_checked(opcua_setup: Setup) -> None:
    from robostar.errors import UsageError
    from robostar.serve.faces.opcua import settings_from

    users = str(opcua_setup.users)
    with pytest.raises(UsageError, match="pki_dir"):
        settings_from({"users": users, "pki_dir": 3})
    with pytest.raises(UsageError, match="accept_unknown_clients"):
        settings_from({"users": users, "accept_unknown_clients": "yes"})
    settings = settings_from({"users": users, "state_dir": "/srv/opcua"})
    assert settings.pki == Path("/srv/opcua/pki") and not settings.accept_unknown_clients
