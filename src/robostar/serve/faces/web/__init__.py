"""The web face of the line server: a dashboard to see the cell and operate a robot, safely.

``robostar serve --web HOST:PORT`` (or a ``[web]`` section in the config) serves it with uvicorn.
Options (the ``[web]`` section):

- ``listen``: ``HOST:PORT`` (default ``127.0.0.1:8080``); a non-loopback address needs
  ``allow_remote = true`` and either ``tls_cert``/``tls_key`` or ``behind_proxy = true`` (a
  reverse proxy that terminates TLS; see docs/web.md);
- ``users``: the users file written by ``robostar serve user add`` (no file: read-only for all);
- ``secret_file``: where the cookie-signing secret is kept (made on first start, mode 0600);
  without it a new secret is drawn at every start (sessions are kept by the server: a restart
  signs everyone out either way);
- ``hosts``: host names the dashboard answers to besides its listen address (and, on loopback,
  ``localhost``/``127.0.0.1``/``::1``): the names a reverse proxy passes on in ``Host``. Any
  other ``Host`` gets a 400 (DNS rebinding);
- ``programs``: the folder where the versions of the JOB and PNT files the dashboard writes and
  reads are kept (default: ``programs`` beside the audit log; without an audit log, in memory);
  ``program_versions``: how many versions of each file are kept (default 50);
  ``program_check_at``: ``"HH:MM"``, local time, for a daily check of every line's files
  against their last versions (edits made at the pendant; the result in the audit log);
- ``max_body``: the largest request body read, in bytes, on every route but the two upload
  routes (default 64 KiB; 413 past it). An upload takes the largest file the N1 protocol carries
  (``limits.MAX_UPLOAD``: 9999 steps of 100 bytes) and its form, whatever this says.

See :mod:`robostar.serve.faces.web.app` for the pages and the rules every request follows.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import os
import secrets
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from robostar.errors import UsageError
from robostar.serve.http_guard import is_loopback_name
from robostar.serve.line_server import LineServer
from robostar.transport.url import netloc

__all__ = ["DEFAULT_LISTEN", "WebFace", "create"]

DEFAULT_LISTEN = "127.0.0.1:8080"
_KNOWN = frozenset(
    (
        "listen",
        "allow_remote",
        "token",
        "users",
        "secret_file",
        "tls_cert",
        "tls_key",
        "behind_proxy",
        "hosts",
        "max_body",
        "programs",
        "program_versions",
        "program_check_at",
    )
)
log = logging.getLogger(__name__)


class WebFace:
    """The dashboard, served by uvicorn on the line server's event loop."""

    def __init__(self, server: LineServer, options: Mapping[str, Any]) -> None:
        unknown = set(options) - _KNOWN
        if unknown:
            raise UsageError(f"web: unknown option(s) {', '.join(sorted(unknown))}")
        from robostar.serve.faces.web.app import WebSettings, build_app
        from robostar.serve.faces.web.limits import DEFAULT_MAX_BODY
        from robostar.serve.faces.web.nightly import parse_time
        from robostar.serve.http_guard import hosts_option, max_body_option
        from robostar.serve.programs import DEFAULT_RETENTION
        from robostar.serve.users import UserStore

        self.host, self.port = _listen(str(options.get("listen", DEFAULT_LISTEN)))
        tls = (options.get("tls_cert"), options.get("tls_key"))
        if (tls[0] is None) != (tls[1] is None):
            raise UsageError("web: give both tls_cert and tls_key, or neither")
        self._tls = tls if tls[0] is not None else None
        self._behind_proxy = bool(options.get("behind_proxy"))
        if not is_loopback_name(self.host):
            if not options.get("allow_remote"):
                raise UsageError(
                    f"web: {self.host} is not a loopback address; set allow_remote = true "
                    "(--allow-remote) to serve the dashboard to the network"
                )
            if self._tls is None and not options.get("behind_proxy"):
                raise UsageError(
                    "web: serving to the network needs TLS (tls_cert and tls_key) or a reverse "
                    "proxy that terminates it (behind_proxy = true); see docs/web.md"
                )
        hosts = hosts_option(options.get("hosts"), "web")
        if options.get("behind_proxy") and not hosts:
            log.warning(
                "web: behind_proxy without hosts: only a Host of %s (or a loopback name) is "
                "answered; list the names the proxy serves in hosts",
                self.host,
            )
        users_path = options.get("users")
        self.users = UserStore(str(users_path) if users_path is not None else None)
        audit = getattr(server.config, "audit_path", None)
        programs = options.get("programs")
        if programs is None and audit is not None:
            programs = Path(str(audit)).parent / "programs"
        versions = options.get("program_versions", DEFAULT_RETENTION)
        if isinstance(versions, bool) or not isinstance(versions, int) or versions < 1:
            raise UsageError(f"web: program_versions {versions!r} is not a whole number >= 1")
        self.settings = settings = WebSettings(
            users=self.users,
            secret=_secret(options.get("secret_file")),
            https_only=self._tls is not None or bool(options.get("behind_proxy")),
            audit_path=str(audit) if audit is not None else None,
            listen_host=self.host,
            hosts=hosts,
            max_body=max_body_option(options.get("max_body"), "web", DEFAULT_MAX_BODY),
            programs_dir=str(programs) if programs is not None else None,
            program_versions=versions,
        )
        self.app = build_app(server, settings)
        self.server = server
        at = options.get("program_check_at")
        self._nightly_at = None if at is None else parse_time(at)
        self._nightly: asyncio.Task[None] | None = None
        self._unobserve: list[Callable[[], None]] = []
        self._server: Any = None
        self._task: asyncio.Task[None] | None = None

    @property
    def url(self) -> str:
        scheme = "https" if self._tls is not None else "http"
        return f"{scheme}://{netloc(self.host, self.port)}"

    async def start(self) -> None:
        import uvicorn

        from robostar.serve.faces.web.nightly import run_nightly

        config = uvicorn.Config(
            self.app,
            host=self.host,
            port=self.port,
            log_level="warning",
            lifespan="off",
            ssl_certfile=self._tls[0] if self._tls else None,
            ssl_keyfile=self._tls[1] if self._tls else None,
            ws="auto",
            # X-Forwarded-For names the client only behind a proxy (from 127.0.0.1); otherwise a
            # local client could pick its address for the sign-in limits with that header
            proxy_headers=self._behind_proxy,
            timeout_graceful_shutdown=2,
        )
        self._server = uvicorn.Server(config)
        self._server.install_signal_handlers = lambda: None  # the line server owns the signals
        self._task = asyncio.create_task(self._server.serve())
        while not self._server.started:
            if self._task.done():
                self._task.result()  # raises why it could not start (port taken, ...)
                raise UsageError(f"web: could not listen on {self.host}:{self.port}")
            await asyncio.sleep(0.01)
        if self.port == 0:
            sockets = self._server.servers[0].sockets
            self.port = int(sockets[0].getsockname()[1])
        log.info("web dashboard on %s", self.url)
        from robostar.serve.faces.web.transfers import observe_transfers

        store = self.app.state.deps.store
        self._unobserve = [observe_transfers(line, store) for line in self.server.lines.values()]
        if self._nightly_at is not None:
            self._nightly = asyncio.create_task(run_nightly(self.server, store, self._nightly_at))

    async def stop(self) -> None:
        for unobserve in self._unobserve:
            unobserve()
        self._unobserve = []
        if self._nightly is not None:
            self._nightly.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._nightly
        if self._server is None or self._task is None:
            return
        self._server.should_exit = True
        with contextlib.suppress(asyncio.CancelledError):
            await self._task


def create(server: LineServer, options: Mapping[str, Any]) -> WebFace:
    """The line server's hook: the web face for ``server`` with the ``[web]`` options."""
    return WebFace(server, options)


def _listen(text: str) -> tuple[str, int]:
    host, sep, port = text.strip().rpartition(":")
    host = host.strip("[]")
    if not sep or not host or not port.isdigit() or not 0 <= int(port) <= 65535:
        raise UsageError(f"web: listen {text!r} is not HOST:PORT (e.g. {DEFAULT_LISTEN})")
    return host, int(port)


def _secret(path: object) -> str:
    """The cookie secret: kept in ``path`` (made on first use, owner-only), or drawn now."""
    if path is None:
        return secrets.token_urlsafe(32)
    file = Path(str(path))
    if file.exists():
        text = file.read_text(encoding="utf-8").strip()
        if len(text) < 32:
            raise UsageError(f"web: the secret in {file} is too short (32 characters at least)")
        return text
    file.parent.mkdir(parents=True, exist_ok=True)
    secret = secrets.token_urlsafe(32)
    fd = os.open(file, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    with os.fdopen(fd, "w", encoding="utf-8") as handle:
        handle.write(secret + "\n")
    return secret
