"""Which client applications may open a session: a trust list, as OPC UA servers keep one.

``pki_dir`` (``<state_dir>/pki`` unless configured) holds two folders:

- ``trusted/``: the certificates (DER or PEM) of the client applications accepted; a client
  whose certificate is not there, byte for byte, is refused (``BadCertificateUntrusted``), as
  is one whose certificate is outside its validity period (``BadCertificateTimeInvalid``);
- ``rejected/``: where a refused client's certificate is copied (``<sha1 thumbprint>.der``), so
  that an administrator who knows the client moves it to ``trusted/``; the folder keeps at most
  :data:`MAX_REJECTED` certificates, so that clients making up certificates cannot fill the
  disk.

The trusted folder is read again when it changes (its modification time), so a certificate
moved there takes effect at the client's next attempt, without a restart. With
``accept_unknown_clients = true`` every client application is accepted (the user is what is
checked), and an unknown one is still copied to ``rejected/`` for the record.

A client that opens no signed channel sends no certificate: that is the anonymous, read-only
endpoint on loopback, when configured, and is not checked here.
"""

from __future__ import annotations

import datetime as dt
import hashlib
import logging
import os
from pathlib import Path

from asyncua import ua
from asyncua.ua import uaerrors
from cryptography import x509
from cryptography.hazmat.primitives.serialization import Encoding

__all__ = ["MAX_REJECTED", "ClientTrustList"]

log = logging.getLogger("robostar.serve.opcua")

MAX_REJECTED = 200
"""The most certificates ``rejected/`` keeps."""


class ClientTrustList:
    """asyncua's certificate validator (called at CreateSession) over a pki folder."""

    def __init__(self, pki_dir: Path, *, accept_unknown: bool = False) -> None:
        self.pki_dir = pki_dir
        self.trusted_dir = pki_dir / "trusted"
        self.rejected_dir = pki_dir / "rejected"
        self.accept_unknown = accept_unknown
        self._trusted: frozenset[bytes] = frozenset()
        self._seen_mtime: int | None = None
        for folder in (self.trusted_dir, self.rejected_dir):
            folder.mkdir(parents=True, exist_ok=True, mode=0o700)

    def trusted(self) -> frozenset[bytes]:
        """The DER bytes of the trusted certificates (read again when the folder changed)."""
        try:
            mtime = self.trusted_dir.stat().st_mtime_ns
        except OSError:
            return frozenset()
        if mtime != self._seen_mtime:
            self._trusted = frozenset(_read_all(self.trusted_dir))
            self._seen_mtime = mtime
        return self._trusted

    async def __call__(self, cert: x509.Certificate, app: ua.ApplicationDescription) -> None:
        der = cert.public_bytes(Encoding.DER)
        uri = app.ApplicationUri if app is not None else None
        now = dt.datetime.now(dt.UTC)
        if not cert.not_valid_before_utc <= now <= cert.not_valid_after_utc:
            log.warning("opcua: client %s refused: its certificate is out of date", uri)
            raise uaerrors.BadCertificateTimeInvalid
        if der in self.trusted():
            return
        self._keep_rejected(der)
        if self.accept_unknown:
            log.info("opcua: client %s accepted, unknown (accept_unknown_clients)", uri)
            return
        log.warning(
            "opcua: client %s refused: its certificate is not in %s (a copy is in %s)",
            uri,
            self.trusted_dir,
            self.rejected_dir,
        )
        raise uaerrors.BadCertificateUntrusted

    def _keep_rejected(self, der: bytes) -> None:
        name = self.rejected_dir / f"{hashlib.sha1(der).hexdigest()}.der"
        try:
            if name.exists() or len(os.listdir(self.rejected_dir)) >= MAX_REJECTED:
                return
            name.write_bytes(der)
        except OSError as exc:
            log.warning("opcua: cannot keep a rejected certificate in %s: %s", name, exc)


def _read_all(folder: Path) -> list[bytes]:
    """Every certificate in ``folder`` as DER (files that are none are skipped, and said)."""
    found = []
    for path in sorted(folder.iterdir()):
        if not path.is_file():
            continue
        try:
            data = path.read_bytes()
            if path.suffix.lower() == ".pem" or data.startswith(b"-----BEGIN"):
                found.append(x509.load_pem_x509_certificate(data).public_bytes(Encoding.DER))
            else:
                found.append(x509.load_der_x509_certificate(data).public_bytes(Encoding.DER))
        except (OSError, ValueError) as exc:
            log.warning("opcua: %s is not a certificate (%s); not trusted", path, exc)
    return found
