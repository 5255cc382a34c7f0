"""Suite-wide settings: hypothesis profiles.

No per-example deadline anywhere: these machines are shared and noisy, and a deadline turns load
into false failures (speed is measured in bench/, never asserted here). Under CI (``CI`` set) the
examples are derandomized so that a run is reproducible; ``HYPOTHESIS_PROFILE`` picks another.
"""

from __future__ import annotations

import os

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
