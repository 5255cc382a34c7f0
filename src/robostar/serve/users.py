"""The line server's users: names, roles and argon2-hashed passwords in a TOML file (shared by
the faces that sign people in: the web dashboard, OPC UA).

The file is written by ``robostar serve user add NAME --role ROLE`` and read by the web face at
start. There is no default user and no default password: with no users file, the dashboard is
read-only for everyone.
"""

from __future__ import annotations

import enum
import functools
import os
import tempfile
import time
import tomllib
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from argon2 import PasswordHasher
from argon2.exceptions import InvalidHashError, VerificationError, VerifyMismatchError

from robostar.errors import UsageError

__all__ = ["MAX_NAME", "LoginLimiter", "Role", "User", "UserStore", "hash_password", "shown"]

_HASHER = PasswordHasher()
MIN_PASSWORD = 8
"""Shortest password accepted when a user is added."""


class Role(enum.IntEnum):
    """What a signed-in user may do; each role may do what the ones below it may."""

    VIEWER = 1
    """Look at everything; change nothing."""
    OPERATOR = 2
    """Servo, job start/stop, alarm reset, outputs, speed, jog."""
    ENGINEER = 3
    """Also file uploads, point tables and variables."""
    ADMIN = 4
    """Everything."""

    @classmethod
    def parse(cls, text: str) -> Role:
        try:
            return cls[text.strip().upper()]
        except KeyError:
            names = ", ".join(role.name.lower() for role in cls)
            raise UsageError(f"role: {text!r} is not one of {names}") from None


@dataclass(frozen=True, slots=True)
class User:
    name: str
    role: Role
    password_hash: str


def hash_password(password: str) -> str:
    if len(password) < MIN_PASSWORD:
        raise UsageError(f"password: at least {MIN_PASSWORD} characters")
    return _HASHER.hash(password)


MAX_NAME = 64
"""The longest user name: a sign-in with a longer one is refused before any check, since no
such user can exist (a 4 MiB name was logged, and kept by the limiter, whole)."""


def shown(name: str) -> str:
    """A user name as logs and the limiter keep it: a name longer than any user's is cut (with
    its length), so a hostile sign-in cannot fill the log or the memory with one."""
    return name if len(name) <= MAX_NAME else f"{name[:MAX_NAME]}... ({len(name)} characters)"


def _check_name(name: str) -> str:
    if not name or not name.replace("-", "").replace("_", "").replace(".", "").isalnum():
        raise UsageError(f"user name: {name!r} may hold letters, digits, '-', '_' and '.' only")
    if len(name) > MAX_NAME:
        raise UsageError(f"user name: at most {MAX_NAME} characters")
    return name


class UserStore:
    """The users of one server, loaded from ``path`` (missing file: no users)."""

    def __init__(self, path: str | os.PathLike[str] | None) -> None:
        self.path = Path(path) if path is not None else None
        self._users: dict[str, User] = {}
        self._stamp: int | None = None
        self._checked = 0.0
        if self.path is not None and self.path.exists():
            self._users = _load(self.path)
            self._stamp = self.path.stat().st_mtime_ns

    def refresh(self, every: float = 1.0) -> None:
        """Read the file again if it changed (looked at once per ``every`` seconds at most): a
        user removed or a role lowered takes effect in a running server. A file that cannot be
        read keeps the users as they were."""
        now = time.monotonic()
        if self.path is None or now - self._checked < every:
            return
        self._checked = now
        try:
            stamp = self.path.stat().st_mtime_ns
        except OSError:
            stamp = None
        if stamp == self._stamp:
            return
        try:
            self._users = _load(self.path) if stamp is not None else {}
        except UsageError:
            return
        self._stamp = stamp

    def __len__(self) -> int:
        return len(self._users)

    def get(self, name: str) -> User | None:
        return self._users.get(name)

    def names(self) -> list[str]:
        return sorted(self._users)

    def verify(self, name: str, password: str) -> User | None:
        """The user if ``password`` is theirs. Takes the same time for an unknown name."""
        user = self._users.get(name)
        stored = user.password_hash if user is not None else _dummy_hash()
        try:
            _HASHER.verify(stored, password)
        except (VerifyMismatchError, VerificationError, InvalidHashError):
            return None
        return user

    def add(self, name: str, role: Role, password: str) -> User:
        """Add or replace a user and write the file at once (atomically)."""
        if self.path is None:
            raise UsageError("users: no users file is configured")
        user = User(_check_name(name), role, hash_password(password))
        self._users[user.name] = user
        self._save()
        return user

    def remove(self, name: str) -> None:
        if name not in self._users:
            raise UsageError(f"user {name!r} does not exist")
        del self._users[name]
        self._save()

    def _save(self) -> None:
        assert self.path is not None
        self.path.parent.mkdir(parents=True, exist_ok=True)
        lines = ["# robostar serve users: written by `robostar serve user add`", ""]
        for user in sorted(self._users.values(), key=lambda u: u.name):
            lines += [
                f'[users."{user.name}"]',
                f'role = "{user.role.name.lower()}"',
                f'password_hash = "{user.password_hash}"',
                "",
            ]
        fd, tmp = tempfile.mkstemp(dir=self.path.parent, prefix=".users-", suffix=".toml")
        try:
            with os.fdopen(fd, "w", encoding="utf-8") as handle:
                handle.write("\n".join(lines))
            os.chmod(tmp, 0o600)  # hashes are secrets too
            os.replace(tmp, self.path)
            self._stamp = self.path.stat().st_mtime_ns
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise


def _load(path: Path) -> dict[str, User]:
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise UsageError(f"{path}: cannot read the users file: {exc}") from exc
    table = data.get("users", {})
    if not isinstance(table, dict):
        raise UsageError(f"{path}: 'users' must be a table")
    users: dict[str, User] = {}
    for name, entry in table.items():
        where = f"{path}: users.{name}"
        if not isinstance(entry, dict):
            raise UsageError(f"{where}: must be a table")
        role_text, hashed = entry.get("role"), entry.get("password_hash")
        if not isinstance(role_text, str):
            raise UsageError(f"{where}.role: missing or not a string")
        if not isinstance(hashed, str) or not hashed.startswith("$argon2"):
            raise UsageError(f"{where}.password_hash: missing or not an argon2 hash")
        users[name] = User(_check_name(name), Role.parse(role_text), hashed)
    return users


class LoginLimiter:
    """At most ``attempts`` failed sign-ins per ``window`` seconds from one address (the web
    face) or for one user name (OPC UA, which is not told the address)."""

    def __init__(
        self, attempts: int = 5, window: float = 60.0, clock: Callable[[], float] = time.monotonic
    ) -> None:
        self.attempts = attempts
        self.window = window
        self._clock = clock
        self._failures: dict[str, deque[float]] = {}

    def blocked_for(self, address: str, now: float | None = None) -> float:
        """Seconds until ``address`` may try again (0: now)."""
        now = self._clock() if now is None else now
        failures = self._failures.get(shown(address))
        if not failures:
            return 0.0
        while failures and now - failures[0] > self.window:
            failures.popleft()
        if len(failures) < self.attempts:
            return 0.0
        return self.window - (now - failures[0])

    def failed(self, address: str, now: float | None = None) -> None:
        now = self._clock() if now is None else now
        # keyed by the shown form: 10,000 keys stay small whatever the names tried
        self._failures.setdefault(shown(address), deque()).append(now)
        if len(self._failures) > 10_000:  # bounded: forget the oldest addresses
            for stale in list(self._failures)[:5_000]:
                del self._failures[stale]

    def succeeded(self, address: str) -> None:
        self._failures.pop(shown(address), None)


@functools.cache
def _dummy_hash() -> str:
    """A hash to check unknown names against, so that they take as long as known ones."""
    return _HASHER.hash("robostar: no such user")
