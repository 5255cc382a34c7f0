"""What every page of the dashboard shares: the line server, the users and their sessions, the
sign-in limits, the refusals record, and the guards of state-changing requests.

One :class:`WebDeps` per application, kept in ``app.state.deps``; a page's endpoints reach it
with :func:`deps_of`. A page module holds no state of its own, so a test can serve one page
alone (``build_app(server, settings, pages=(health,))``) and talk to it with httpx.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NoReturn

from starlette.requests import HTTPConnection, Request
from starlette.responses import HTMLResponse
from starlette.templating import Jinja2Templates

from robostar.commands.base import Command
from robostar.serve.faces.web.auth import (
    CSRF_FIELD,
    Account,
    LoginLimiter,
    SignInSessions,
    account_of,
    csrf_ok,
)
from robostar.serve.faces.web.limits import DEFAULT_MAX_BODY
from robostar.serve.http_guard import Refusals
from robostar.serve.lease import Who
from robostar.serve.line import Line
from robostar.serve.line_server import LineServer
from robostar.serve.programs import DEFAULT_RETENTION, ProgramStore
from robostar.serve.users import Role, UserStore

__all__ = ["STALE", "Forbidden", "WebDeps", "WebSettings", "deps_of", "needs"]

log = logging.getLogger(__name__)
_HERE = Path(__file__).parent
SIGN_IN_ATTEMPTS_PER_ADDRESS = 20
"""Failed sign-ins from one address, whatever the names, in a minute (5 per address and name)."""
CONCURRENT_VERIFIES = 2
"""Password checks running at once (argon2 takes 64 MiB and a core's worth of time each)."""
WAITING_SIGN_INS = 32
"""Sign-ins waiting for a password check; more are told to try again."""

STALE = "the form is stale or forged (CSRF token missing or wrong)"


def needs(role: Role) -> str:
    return f"this needs the {role.name.lower()} role; sign in first"


@dataclass(frozen=True, slots=True)
class WebSettings:
    """How the dashboard runs: its users, its cookie secret, and whether cookies need HTTPS."""

    users: UserStore
    secret: str
    https_only: bool = False
    audit_path: str | None = None
    listen_host: str = "127.0.0.1"
    """The address the dashboard listens on (with ``hosts``: the Host headers it answers)."""
    hosts: tuple[str, ...] = ()
    """Host names besides the listen address (the names a reverse proxy passes on)."""
    max_body: int = DEFAULT_MAX_BODY
    """The largest request body read, in bytes, on every route but the uploads (which take
    ``limits.MAX_UPLOAD_BODY``: the largest file the N1 protocol carries, and its form)."""
    programs_dir: str | None = None
    """Where the program versions are kept (None: in memory, until the server stops)."""
    program_versions: int = DEFAULT_RETENTION
    """Versions kept per file (the oldest go first)."""


class Forbidden(Exception):
    """A request refused by the dashboard itself: its HTTP status and why, in words."""

    def __init__(self, status: int, message: str) -> None:
        super().__init__(message)
        self.status = status
        self.message = message


@dataclass(eq=False)
class WebDeps:
    """The dependencies of every page (see the module docstring)."""

    server: LineServer
    settings: WebSettings
    templates: Jinja2Templates
    sessions: SignInSessions = field(default_factory=SignInSessions)
    refusals: Refusals = field(default_factory=Refusals)
    limiter: LoginLimiter = field(default_factory=LoginLimiter)
    """Failed sign-ins per address and name: one user's lock-out spares the others."""
    address_limiter: LoginLimiter = field(
        default_factory=lambda: LoginLimiter(attempts=SIGN_IN_ATTEMPTS_PER_ADDRESS)
    )
    """Failed sign-ins per address, whatever the names."""
    verifying: asyncio.Semaphore = field(
        default_factory=lambda: asyncio.Semaphore(CONCURRENT_VERIFIES)
    )
    waiting: int = 0
    """Sign-ins waiting for a password check."""
    transferring: set[str] = field(default_factory=set)
    """Lines with a backup or file download for a browser running: one at a time per line, so
    browsers cannot queue transfer after transfer ahead of the writes of the other faces."""
    programs: ProgramStore | None = None
    """The versions of the files the dashboard writes and reads (made from the settings)."""
    extras: dict[str, Any] = field(default_factory=dict)
    """Caches of single pages (the XY view's workspaces), by name."""

    def __post_init__(self) -> None:
        if self.programs is None:
            self.programs = ProgramStore(self.settings.programs_dir, self.settings.program_versions)

    @property
    def store(self) -> ProgramStore:
        assert self.programs is not None
        return self.programs

    @property
    def users(self) -> UserStore:
        return self.settings.users

    def account(self, request: HTTPConnection) -> Account:
        return account_of(request, self.users, self.sessions)

    def line_of(self, request: HTTPConnection) -> Line:
        name = request.path_params["line"]
        line = self.server.lines.get(name)
        if line is None:
            raise Forbidden(404, f"no line named {name!r}")
        return line

    def page(self, request: Request, template: str, /, **context: Any) -> HTMLResponse:
        from robostar.serve.faces.web.pages.lease import lease_row

        account = self.account(request)
        lines = list(self.server.lines.values())
        return self.templates.TemplateResponse(
            request,
            template,
            {
                "account": account,
                "lines": lines,
                "leases": [lease_row(line, account) for line in lines],
                "logins": len(self.users) > 0,
                **context,
            },
        )

    def refuse(
        self, line: Line | None, account: Account, what: str, status: int, why: str
    ) -> NoReturn:
        """Refuse a request (Forbidden), in the line's audit log when it names a line."""
        if line is not None:
            self.refusals.record(line, what, Who(account.name, "web"), why)
        raise Forbidden(status, why)

    async def guard(self, request: Request, role: Role, line: Line | None, what: str) -> Account:
        """The account of a state-changing request, or Forbidden (audited): the role first (no
        body is read for a visitor without it), then the CSRF token."""
        account = self.account(request)
        if not account.may(role):
            self.refuse(line, account, what, 403, needs(role))
        if not await csrf_ok(request, account):
            self.refuse(line, account, what, 403, STALE)
        return account

    def signed_in(self, request: Request, line: Line, what: str) -> Account:
        """The account of a GET that holds the line for file transfers (FA), or Forbidden
        (audited): a signed-in user, a viewer at least. A GET carries no CSRF token, and any
        page the operator opens can fire one (an <img src=...>); the session cookie is
        SameSite=Strict, so such a request arrives anonymous and is refused here."""
        account = self.account(request)
        if not account.may(Role.VIEWER):
            self.refuse(line, account, what, 403, needs(Role.VIEWER))
        return account

    @contextlib.contextmanager
    def one_transfer(self, line: Line) -> Iterator[None]:
        if line.name in self.transferring:
            raise Forbidden(
                429,
                f"line {line.name}: a backup or file download is already running;"
                " try again when it is done",
            )
        self.transferring.add(line.name)
        try:
            yield
        finally:
            self.transferring.discard(line.name)

    def keep(self, line: Line, channel: int, name: object, text: str, who: Who, how: str) -> None:
        """Keep a file's text as a version (see serve/programs.py). A store that cannot be
        written (a full disk) is logged: the transfer it records has happened either way."""
        try:
            self.store.record(line.name, channel, str(name), text, who, how)
        except OSError as exc:
            log.error("programs: %s of %s on %s not kept: %s", how, name, line.name, exc)

    async def run(self, line: Line, command: Command[Any], account: Account) -> Any:
        """A state change for ``account``: a free lease is taken for it (see the line)."""
        return await line.execute(command, who=Who(account.name, "web"), implicit_lease=True)


def templates() -> Jinja2Templates:
    """The pages' templates, with the globals and filters they use."""
    from robostar.serve.faces.web.views import clock, job_name

    found = Jinja2Templates(directory=str(_HERE / "templates"))
    found.env.globals["csrf_field"] = CSRF_FIELD
    found.env.filters["clock"] = clock
    found.env.filters["job_name"] = job_name
    return found


def deps_of(request: HTTPConnection) -> WebDeps:
    deps: WebDeps = request.app.state.deps
    return deps
