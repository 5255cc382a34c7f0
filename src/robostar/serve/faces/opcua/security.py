"""Who may do what on the OPC UA face: users, roles, the application certificate.

- Users come from the line server's users file (``robostar serve user add``): a user name and
  password token is checked against its argon2 hash (five failures in a minute hold that name
  off for the rest of the minute); the role (viewer, operator, ...) decides
  what the session may call. Anonymous sessions exist only when the configuration allows
  anonymous reading, and are viewers.
- Every variable is read-only to every client but the setpoints (``setpoints.py``), which
  operators may write over a signed channel; changes to the address space are refused for
  everyone (``BadUserAccessDenied``).
- Methods that move the robot check the caller's role themselves (an asyncua method handler is
  not told who calls it: the ruleset, which is, leaves the session's user and channel in a
  context variable for the handler of the same request).
- The unencrypted endpoint (only with anonymous reading, only on loopback) is read-only for
  everyone, whatever the user.
"""

from __future__ import annotations

import contextvars
import logging
import os
import socket
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from asyncua import ua
from asyncua.crypto.cert_gen import setup_self_signed_certificate
from asyncua.crypto.permission_rules import SimpleRoleRuleset, User, UserRole
from cryptography.x509.oid import ExtendedKeyUsageOID

from robostar.serve.faces.opcua._ua import ObjectIds, node_id
from robostar.serve.ratelimit import TokenBucket
from robostar.serve.users import MAX_NAME, LoginLimiter, Role, UserStore, shown

__all__ = [
    "Caller",
    "RefuseAllRuleset",
    "RoleRuleset",
    "SignInBudget",
    "UsersManager",
    "current_caller",
    "ensure_certificate",
]

log = logging.getLogger("robostar.serve.opcua")

_WRITE = node_id(ObjectIds.WriteRequest_Encoding_DefaultBinary)
"""Let through on signed channels only, and there checked value by value (setpoints.py)."""
_ALWAYS_REFUSED = frozenset(
    node_id(i)
    for i in (
        ObjectIds.AddNodesRequest_Encoding_DefaultBinary,
        ObjectIds.DeleteNodesRequest_Encoding_DefaultBinary,
        ObjectIds.AddReferencesRequest_Encoding_DefaultBinary,
        ObjectIds.DeleteReferencesRequest_Encoding_DefaultBinary,
        ObjectIds.HistoryUpdateRequest_Encoding_DefaultBinary,
        ObjectIds.RegisterServerRequest_Encoding_DefaultBinary,
        ObjectIds.RegisterServer2Request_Encoding_DefaultBinary,
    )
)
"""Requests no client may make: the model is the controller's, read-only from outside but for
its setpoints."""


@dataclass(frozen=True)
class Caller:
    """The session behind the request being served."""

    name: str | None
    """The user name; None for an anonymous session."""
    role: Role
    secure: bool
    """Whether the request came over a signed (and possibly encrypted) channel."""

    def may_operate(self) -> bool:
        return self.secure and self.name is not None and self.role >= Role.OPERATOR


_caller: contextvars.ContextVar[Caller | None] = contextvars.ContextVar(
    "robostar_opcua_caller", default=None
)


def current_caller() -> Caller | None:
    """The caller of the request being served (None outside a client's request)."""
    return _caller.get()


class RoleRuleset(SimpleRoleRuleset):
    """asyncua's per-request check: refuse writes to everyone, remember who asks. (A
    SimpleRoleRuleset only because asyncua's signature names that class.)"""

    def __init__(self, users: UserStore, *, secure: bool) -> None:
        super().__init__()  # type: ignore[no-untyped-call]
        self.users = users
        self.secure = secure

    def check_validity(self, user: User, action_type_id: ua.NodeId, body: Any) -> bool:
        _caller.set(None)  # until this request is known to be allowed
        if action_type_id in _ALWAYS_REFUSED or (action_type_id == _WRITE and not self.secure):
            return False
        self.users.refresh()
        role = Role.VIEWER
        if user is not None and user.name is not None:
            stored = self.users.get(user.name)
            if stored is None:  # removed from the file since the session began
                return False
            role = stored.role
        name = None if user is None else user.name
        _caller.set(Caller(name, role, self.secure))
        return True


class RefuseAllRuleset(SimpleRoleRuleset):
    """For an unsigned channel where the configuration offers none: asyncua falls back to an
    unprotected None policy when no endpoint matches a client's request, so one is put in its
    place that lets nothing through (a session can be made, and used for nothing)."""

    def __init__(self) -> None:
        super().__init__()  # type: ignore[no-untyped-call]

    def check_validity(self, user: User, action_type_id: ua.NodeId, body: Any) -> bool:
        _caller.set(None)
        return False


class SignInBudget(TokenBucket):
    """At most ``rate`` password checks a second for the whole face, ``burst`` at once (each
    about 50-100 ms of argon2 on the event loop; two a second keep the loop's worst stall at
    about a jog keepalive's period).

    asyncua asks for the user synchronously, on the event loop, and argon2 takes tens of
    milliseconds: without a budget, a few clients trying names would stall every line of the
    server. Beyond the budget a sign-in is refused without hashing.
    """

    def __init__(
        self, rate: float = 2.0, burst: int = 2, clock: Callable[[], float] = time.monotonic
    ) -> None:
        super().__init__(rate, burst, clock=clock)


class UsersManager:
    """asyncua's user manager over the line server's users file."""

    def __init__(
        self,
        users: UserStore,
        *,
        allow_anonymous: bool,
        limiter: LoginLimiter | None = None,
        budget: SignInBudget | None = None,
    ) -> None:
        self.users = users
        self.allow_anonymous = allow_anonymous
        self.limiter = limiter if limiter is not None else LoginLimiter()
        """Failed sign-ins per user name: after 5 in a minute, that name is refused for the
        rest of the minute, right password or not (asyncua does not tell the address)."""
        self.budget = budget if budget is not None else SignInBudget()

    def get_user(
        self,
        iserver: Any,
        username: str | None = None,
        password: str | None = None,
        certificate: Any = None,
    ) -> User | None:
        # X509 user tokens are not offered (asyncua rejects them before this), so no user
        # name means an anonymous token; ``certificate`` is then the channel's application
        # certificate, which says nothing about a user
        if username is None:
            return User(role=UserRole.Anonymous) if self.allow_anonymous else None
        if password is None:
            return None
        name = shown(username)  # what the log says: a hostile name is cut, not written whole
        if len(username) > MAX_NAME:
            # no user has such a name: refused before the limiter or the budget keep it
            log.warning("opcua: sign-in of %r refused: no user has so long a name", name)
            return None
        if not certificate:
            # an unsigned channel (no peer certificate: None, or b"" as asyncua has it): a
            # password never crosses one, whatever the client offers
            log.warning("opcua: sign-in of %r refused: not over an unsigned channel", name)
            return None
        self.users.refresh()
        wait = self.limiter.blocked_for(username)
        if wait > 0:  # before the budget: a name held off costs no password check
            log.warning("opcua: sign-in of %r refused: too many failures (%.0f s)", name, wait)
            return None
        if not self.budget.take():
            log.warning("opcua: sign-in of %r refused: too many sign-ins at once", name)
            return None
        # argon2 takes tens of milliseconds, once per session activation
        user = self.users.verify(username, password)
        if user is None:
            self.limiter.failed(username)
            log.warning("opcua: sign-in refused for %r", name)
            return None
        self.limiter.succeeded(username)
        return User(role=UserRole.User, name=user.name)


async def ensure_certificate(
    directory: Path, application_uri: str, hostname: str | None = None
) -> tuple[Path, Path]:
    """The application certificate and key in ``directory``: made on first start (self-signed,
    valid one year, renewed when expired or when its URI no longer matches), then kept."""
    directory.mkdir(parents=True, exist_ok=True, mode=0o700)
    key = directory / "opcua-key.pem"
    cert = directory / "opcua-cert.der"
    await setup_self_signed_certificate(
        key,
        cert,
        application_uri,
        hostname or socket.gethostname(),
        [ExtendedKeyUsageOID.SERVER_AUTH, ExtendedKeyUsageOID.CLIENT_AUTH],
        {"commonName": "robostar serve", "organizationName": "robostar"},
    )
    os.chmod(key, 0o600)  # the private key is a secret
    return cert, key
