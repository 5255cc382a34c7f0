"""A sign-in with a user name longer than any user's is refused before anything keeps it: the
log shows it cut, the limiter and the budget never see it (a 4 MiB name was logged whole and
kept as a limiter key, so 44 tries wrote 176 MiB of log)."""

from __future__ import annotations

import logging
from pathlib import Path

import pytest

from robostar.serve.faces.opcua.security import SignInBudget, UsersManager
from robostar.serve.users import MAX_NAME, LoginLimiter, Role, UserStore, shown


def test_a_huge_user_name_is_refused_cut_and_never_kept(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    users = UserStore(tmp_path / "users.toml")
    users.add("olga", Role.OPERATOR, "operator-pass-1")
    limiter = LoginLimiter()
    budget = SignInBudget(rate=1e6, burst=1000)
    manager = UsersManager(users, allow_anonymous=False, limiter=limiter, budget=budget)
    huge = "x" * (4 << 20)
    with caplog.at_level(logging.WARNING):
        for _ in range(3):
            assert manager.get_user(None, huge, "wrong", b"a channel certificate") is None
    logged = "".join(record.getMessage() for record in caplog.records)
    assert len(logged) < 1000 and "4194304 characters" in logged
    assert not limiter._failures  # nothing kept for a name no user can have
    assert manager.get_user(None, "olga", "operator-pass-1", b"a channel certificate")


def test_the_limiter_keeps_long_names_short() -> None:
    limiter = LoginLimiter(attempts=2)
    name = "y" * 100_000
    limiter.failed(name)
    limiter.failed(name)
    assert limiter.blocked_for(name) > 0  # the same name is still held off
    assert all(len(key) < 2 * MAX_NAME for key in limiter._failures)
    limiter.succeeded(name)
    assert limiter.blocked_for(name) == 0
    assert shown("olga") == "olga"
