"""TOML spells nan and inf; a number of seconds in the config must be finite (and positive)."""

from __future__ import annotations

import tomllib

import pytest

from robostar.serve.config import ConfigError, LineConfig, ServeConfig, config_from_mapping

LINE = '[lines.press]\nurl = "sim://"\n'


@pytest.mark.parametrize("value", ["nan", "inf", "-inf", "+nan"])
def test_lease_ttl_must_be_finite(value: str) -> None:
    data = tomllib.loads(f"lease_ttl = {value}\n{LINE}")
    with pytest.raises(ConfigError, match=r"^lease_ttl: .* is not a positive number of seconds"):
        config_from_mapping(data)


@pytest.mark.parametrize(
    "key", ["timeout", "poll_interval", "slow_interval", "history_interval", "max_age"]
)
@pytest.mark.parametrize("value", ["nan", "inf"])
def test_a_lines_seconds_must_be_finite(key: str, value: str) -> None:
    data = tomllib.loads(f"{LINE}{key} = {value}\n")
    with pytest.raises(ConfigError, match=rf"^lines\.press\.{key}: {value} is not "):
        config_from_mapping(data)


def test_the_dataclasses_refuse_nan_too() -> None:
    with pytest.raises(ConfigError, match="lease_ttl"):
        ServeConfig(lines=(), lease_ttl=float("nan"))
    with pytest.raises(ConfigError, match="max_age"):
        LineConfig("press", "sim://", max_age=float("inf"))


def test_finite_values_still_pass() -> None:
    data = tomllib.loads(f"lease_ttl = 12.5\n{LINE}timeout = 3\nmax_age = 0\n")
    config = config_from_mapping(data)
    assert config.lease_ttl == 12.5
    assert (config.lines[0].timeout, config.lines[0].max_age) == (3.0, 0.0)
