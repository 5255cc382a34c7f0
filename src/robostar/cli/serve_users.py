"""``robostar serve user``: the web dashboard's users (names, roles, argon2-hashed passwords)."""

from __future__ import annotations

import click

__all__ = ["user"]

_ROLES = ["viewer", "operator", "engineer", "admin"]


@click.group()
def user() -> None:
    """Manage the users of the web dashboard (the file its [web] section names).

    \b
    Examples:
      robostar serve user add olga --role operator --users /etc/robostar/users.toml
      robostar serve user list --users /etc/robostar/users.toml
    """


_users_option = click.option(
    "--users",
    "users_file",
    required=True,
    type=click.Path(dir_okay=False),
    help="The users file (TOML; created if missing, written with mode 0600).",
)


@user.command("add")
@click.argument("name")
@click.option("--role", type=click.Choice(_ROLES), required=True, help="What the user may do.")
@_users_option
@click.password_option(
    "--password", help="The password (asked for, twice, when not given; at least 8 characters)."
)
def add(name: str, role: str, users_file: str, password: str) -> None:
    """Add a user, or give an existing one a new role and password."""
    from robostar.serve.users import Role, UserStore

    store = UserStore(users_file)
    added = store.add(name, Role.parse(role), password)
    click.echo(f"{added.name}: {added.role.name.lower()} (in {users_file})")


@user.command("remove")
@click.argument("name")
@_users_option
def remove(name: str, users_file: str) -> None:
    """Remove a user."""
    from robostar.serve.users import UserStore

    UserStore(users_file).remove(name)
    click.echo(f"{name}: removed")


@user.command("list")
@_users_option
def list_users(users_file: str) -> None:
    """List the users and their roles (never the hashes)."""
    from robostar.serve.users import UserStore

    store = UserStore(users_file)
    for name in store.names():
        found = store.get(name)
        assert found is not None
        click.echo(f"{name}\t{found.role.name.lower()}")
