"""Who is signed in, what they may do, and the guards of every state-changing request.

Sessions live in a signed, HTTP-only cookie (Starlette's SessionMiddleware); the session holds
the user's name and a CSRF token. Every POST (and the jog WebSocket) must carry that token, and
state changes need a role. Logins are rate-limited per client address.
"""

from __future__ import annotations

import hmac
import secrets
from dataclasses import dataclass

from starlette.requests import HTTPConnection, Request

from robostar.serve.users import LoginLimiter, Role, User, UserStore

__all__ = ["CSRF_FIELD", "CSRF_HEADER", "Account", "LoginLimiter", "account_of", "csrf_ok"]

CSRF_FIELD = "csrf_token"
CSRF_HEADER = "x-csrf-token"


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


def account_of(connection: HTTPConnection, users: UserStore) -> Account:
    """The account of a request or WebSocket; gives the session a CSRF token if it has none."""
    session = connection.session
    token = session.get("csrf")
    if not isinstance(token, str):
        token = secrets.token_urlsafe(32)
        session["csrf"] = token
    name = session.get("user")
    user = users.get(name) if isinstance(name, str) else None
    return Account(user, token)


async def csrf_ok(request: Request, account: Account) -> bool:
    """Does a state-changing request carry the session's CSRF token (header or form field)?"""
    sent = request.headers.get(CSRF_HEADER)
    if sent is None and request.headers.get("content-type", "").startswith(
        ("application/x-www-form-urlencoded", "multipart/form-data")
    ):
        form = await request.form()
        value = form.get(CSRF_FIELD)
        sent = value if isinstance(value, str) else None
    return sent is not None and hmac.compare_digest(sent, account.csrf)
