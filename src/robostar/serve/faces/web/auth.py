"""Who is signed in, what they may do, and the guards of every state-changing request.

Sessions live in a signed, HTTP-only cookie (Starlette's SessionMiddleware) that holds the user's
name, a CSRF token and a session id; the server keeps the ids it gave out (:class:`SignInSessions`,
bounded, each expiring), so signing out ends a session for good (its cookie, replayed, is
anonymous), and a session ends when its user is removed or their password changes. The users
file is looked at again on every request, so a lowered role takes effect on the next one.
Every POST (and the jog WebSocket) must carry the CSRF token, and state changes need a role.
"""

from __future__ import annotations

import secrets
import time
from collections.abc import Callable
from dataclasses import dataclass

from starlette.datastructures import FormData
from starlette.requests import HTTPConnection, Request

from robostar.serve.faces.web.limits import MAX_UPLOAD_BODY
from robostar.serve.http_guard import same_secret
from robostar.serve.users import LoginLimiter, Role, User, UserStore

__all__ = [
    "CSRF_FIELD",
    "CSRF_HEADER",
    "Account",
    "LoginLimiter",
    "SignInSessions",
    "account_of",
    "csrf_ok",
    "read_form",
]

CSRF_FIELD = "csrf_token"
CSRF_HEADER = "x-csrf-token"
FORM_MAX_FILES = 1
"""Files in one form (the upload form has one)."""
FORM_MAX_FIELDS = 64
"""Fields in one form (the point editor's is the largest: a dozen)."""
FORM_MAX_PART = MAX_UPLOAD_BODY
"""Bytes of one multipart field that is not a file (an upload's confirmed content): as much as
the upload routes' body limit, so the confirm route's own check (``MAX_UPLOAD``, 413 naming it)
is what a too long content meets."""
SESSION_LIFETIME = 12 * 3600.0
"""Seconds a session lasts since it was last used (the cookie's max_age)."""


@dataclass(frozen=True, slots=True)
class Account:
    """The visitor: a signed-in user, or an anonymous viewer (``user`` None)."""

    user: User | None
    csrf: str

    @property
    def name(self) -> str:
        return self.user.name if self.user is not None else "anonymous"

    @property
    def role(self) -> Role | None:
        return self.user.role if self.user is not None else None

    def may(self, role: Role) -> bool:
        return self.user is not None and self.user.role >= role


@dataclass(slots=True)
class _SignIn:
    name: str
    password_hash: str
    expires: float


class SignInSessions:
    """The signed-in sessions the server gave out: id -> user, at most ``limit`` (the least
    recently used goes first), each ending ``lifetime`` seconds after its last use. Kept in
    memory: a restart signs everyone out."""

    def __init__(
        self,
        lifetime: float = SESSION_LIFETIME,
        limit: int = 10_000,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.lifetime = lifetime
        self.limit = limit
        self._clock = clock
        self._sessions: dict[str, _SignIn] = {}

    def __len__(self) -> int:
        return len(self._sessions)

    def open(self, user: User) -> str:
        """A new session of ``user``; its id goes in the cookie."""
        now = self._clock()
        for sid in [s for s, e in self._sessions.items() if e.expires <= now]:
            del self._sessions[sid]
        while len(self._sessions) >= self.limit:
            del self._sessions[next(iter(self._sessions))]
        sid = secrets.token_urlsafe(32)
        self._sessions[sid] = _SignIn(user.name, user.password_hash, now + self.lifetime)
        return sid

    def check(self, sid: str, user: User) -> bool:
        """Is ``sid`` a live session of ``user`` (same name, same password)? Extends it."""
        entry = self._sessions.pop(sid, None)
        now = self._clock()
        if entry is None or entry.expires <= now:
            return False
        if entry.name != user.name or entry.password_hash != user.password_hash:
            return False
        entry.expires = now + self.lifetime
        self._sessions[sid] = entry  # the most recently used is last
        return True

    def close(self, sid: object) -> None:
        if isinstance(sid, str):
            self._sessions.pop(sid, None)


def account_of(connection: HTTPConnection, users: UserStore, sessions: SignInSessions) -> Account:
    """The account of a request or WebSocket; gives the session a CSRF token if it has none.
    A session the server no longer knows, or whose user is gone, is anonymous from now on."""
    users.refresh(every=0.0)  # a stat() of the users file; read again only when it changed
    session = connection.session
    token = session.get("csrf")
    if not isinstance(token, str):
        token = secrets.token_urlsafe(32)
        session["csrf"] = token
    name, sid = session.get("user"), session.get("sid")
    user = None
    if isinstance(name, str):
        found = users.get(name)
        if found is not None and isinstance(sid, str) and sessions.check(sid, found):
            user = found
        else:
            sessions.close(sid)
            session.pop("user", None)
            session.pop("sid", None)
    return Account(user, token)


async def read_form(request: Request) -> FormData:
    """The request's form, parsed within the dashboard's limits (a file, a few fields)."""
    return await request.form(
        max_files=FORM_MAX_FILES, max_fields=FORM_MAX_FIELDS, max_part_size=FORM_MAX_PART
    )


def csrf_header_ok(request: Request, account: Account) -> bool:
    """Does the request carry the session's CSRF token in its header?"""
    return same_secret(request.headers.get(CSRF_HEADER), account.csrf)


async def csrf_ok(request: Request, account: Account) -> bool:
    """Does a state-changing request carry the session's CSRF token (header or form field)?"""
    sent = request.headers.get(CSRF_HEADER)
    if sent is None and request.headers.get("content-type", "").startswith(
        ("application/x-www-form-urlencoded", "multipart/form-data")
    ):
        form = await read_form(request)
        value = form.get(CSRF_FIELD)
        sent = value if isinstance(value, str) else None
    return same_secret(sent, account.csrf)
