"""Signing in and out: the sign-in limits (per address and name, per address), a few password
checks at a time, and a new session and CSRF token at every sign-in."""

from __future__ import annotations

import asyncio
import secrets

from starlette.requests import Request
from starlette.responses import RedirectResponse, Response
from starlette.routing import BaseRoute, Route

from robostar.serve.faces.web.auth import csrf_ok, read_form
from robostar.serve.faces.web.deps import WAITING_SIGN_INS, deps_of

__all__ = ["ROUTES"]


async def login_page(request: Request) -> Response:
    return deps_of(request).page(request, "login.html", error=None)


async def login(request: Request) -> Response:
    deps = deps_of(request)
    account = deps.account(request)
    if not await csrf_ok(request, account):
        return deps.page(request, "login.html", error="The form is stale: reload and try again.")
    form = await read_form(request)
    name = str(form.get("username", ""))
    address = request.client.host if request.client else "?"
    # per address and name (a user's lock-out spares the others at that address), and per
    # address alone (many names tried from one place)
    keys = ((deps.limiter, f"{address}|{name}"), (deps.address_limiter, address))

    def blocked() -> float:
        return max(which.blocked_for(key) for which, key in keys)

    if (wait := blocked()) > 0:
        return deps.page(request, "login.html", error=f"Too many attempts: wait {wait:.0f} s.")
    if deps.waiting >= WAITING_SIGN_INS:
        return deps.page(request, "login.html", error="Too many sign-ins at once: try again.")
    deps.waiting += 1
    try:
        async with deps.verifying:  # a few argon2 checks at a time, however many ask
            if (wait := blocked()) > 0:  # failures while this one waited count too
                return deps.page(
                    request, "login.html", error=f"Too many attempts: wait {wait:.0f} s."
                )
            password = str(form.get("password", ""))
            user = await asyncio.to_thread(deps.users.verify, name, password)
    finally:
        deps.waiting -= 1
    if user is None:
        for which, key in keys:
            which.failed(key)
        return deps.page(request, "login.html", error="Wrong name or password.")
    deps.limiter.succeeded(keys[0][1])  # this name's count only: the address's stays
    deps.sessions.close(request.session.get("sid"))
    request.session.clear()
    request.session["user"] = user.name
    request.session["sid"] = deps.sessions.open(user)
    request.session["csrf"] = secrets.token_urlsafe(32)  # a new session, a new token
    return RedirectResponse("/", status_code=303)


async def logout(request: Request) -> Response:
    deps = deps_of(request)
    account = deps.account(request)
    if await csrf_ok(request, account):
        deps.sessions.close(request.session.get("sid"))  # the cookie, replayed, is anonymous
        request.session.clear()
    return RedirectResponse("/", status_code=303)


ROUTES: list[BaseRoute] = [
    Route("/login", login_page, methods=["GET"]),
    Route("/login", login, methods=["POST"]),
    Route("/logout", logout, methods=["POST"]),
]
