"""Suite-wide settings: hypothesis profiles.

No per-example deadline anywhere: these machines are shared and noisy, and a deadline turns load
into false failures (speed is measured in bench/, never asserted here). Under CI (``CI`` set) the
examples are derandomized so that a run is reproducible; ``HYPOTHESIS_PROFILE`` picks another.
"""

from __future__ import annotations

import os
from collections.abc import Iterator

import pytest
from hypothesis import HealthCheck, settings

# tests/plugin runs an integrator's test file through pytest (pytester); it must be declared
# here, at the top, since pytest takes plugins only from the root conftest.
pytest_plugins = ["pytester"]

settings.register_profile("dev", deadline=None)
settings.register_profile(
    "ci",
    deadline=None,
    derandomize=True,
    print_blob=True,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci" if os.environ.get("CI") else "dev"))


@pytest.fixture(autouse=True, scope="session")
def _own_user_folders(tmp_path_factory: pytest.TempPathFactory) -> Iterator[None]:
    """The user's config, state, data and cache folders (platformdirs: robots.toml, the audit
    log `robostar serve` keeps by default, OPC UA certificates) inside the run's temporary
    folder, for this process and any it starts: a test run neither reads nor writes the home
    of whoever runs it."""
    root = tmp_path_factory.mktemp("home")
    saved = {key: os.environ.get(key) for key in _XDG}
    for key in _XDG:
        os.environ[key] = str(root / key.lower())
    try:
        yield
    finally:
        for key, value in saved.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value


_XDG = ("XDG_CONFIG_HOME", "XDG_STATE_HOME", "XDG_DATA_HOME", "XDG_CACHE_HOME")
