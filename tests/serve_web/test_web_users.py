"""The users file: hashed passwords, roles, no default user, and the CLI that writes it."""

from __future__ import annotations

import stat
from pathlib import Path

import pytest
from click.testing import CliRunner

from robostar.cli.serve_users import user
from robostar.errors import UsageError
from robostar.serve.users import Role, UserStore


def test_passwords_are_stored_hashed_and_verified(tmp_path: Path) -> None:
    path = tmp_path / "users.toml"
    UserStore(path).add("olga", Role.OPERATOR, "correct horse")
    text = path.read_text()
    assert "correct horse" not in text and "$argon2" in text
    assert stat.S_IMODE(path.stat().st_mode) == 0o600
    store = UserStore(path)
    found = store.verify("olga", "correct horse")
    assert found is not None and found.role is Role.OPERATOR
    assert store.verify("olga", "wrong horse") is None
    assert store.verify("nobody", "correct horse") is None


def test_there_is_no_default_user(tmp_path: Path) -> None:
    store = UserStore(tmp_path / "missing.toml")
    assert len(store) == 0
    assert store.verify("admin", "admin") is None


@pytest.mark.parametrize(
    ("name", "password"), [("bad name", "long enough"), ("olga", "short"), ("", "long enough")]
)
def test_bad_names_and_short_passwords_are_refused(
    tmp_path: Path, name: str, password: str
) -> None:
    with pytest.raises(UsageError):
        UserStore(tmp_path / "users.toml").add(name, Role.VIEWER, password)


def test_a_hand_edited_file_with_a_plain_password_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "users.toml"
    path.write_text('[users.olga]\nrole = "operator"\npassword_hash = "secret"\n')
    with pytest.raises(UsageError, match="argon2"):
        UserStore(path)


def test_the_cli_adds_lists_and_removes_users(tmp_path: Path) -> None:
    path = str(tmp_path / "users.toml")
    runner = CliRunner()
    added = runner.invoke(
        user,
        ["add", "olga", "--role", "operator", "--users", path],
        input="s3cret-pass\ns3cret-pass\n",
    )
    assert added.exit_code == 0, added.output
    listed = runner.invoke(user, ["list", "--users", path])
    assert listed.output.strip() == "olga\toperator"
    assert "$argon2" not in listed.output
    removed = runner.invoke(user, ["remove", "olga", "--users", path])
    assert removed.exit_code == 0
    assert runner.invoke(user, ["list", "--users", path]).output == ""
