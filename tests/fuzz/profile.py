"""Settings of the fuzz tests, by profile: ``ci`` (200 examples per reader, the default) and ``dev``
(2000 per reader, for local runs: ``SCANGEO_FUZZ=dev python -m pytest tests/fuzz``). The round trips run
a quarter of that (each example writes and reads a whole file). Applied per test, not loaded as the
global hypothesis profile, so other tests keep their own settings."""
from __future__ import annotations

import os

from hypothesis import HealthCheck, settings

PROFILES = {"ci": 200, "dev": 2000}
EXAMPLES = PROFILES[os.environ.get("SCANGEO_FUZZ", "ci")]
_SUPPRESS = [HealthCheck.too_slow, HealthCheck.data_too_large, HealthCheck.function_scoped_fixture]

#: For readers fed corrupted files.
_CI = os.environ.get("SCANGEO_FUZZ", "ci") == "ci"  # CI: the same examples every run (no flaky failures)
FUZZ = settings(max_examples=EXAMPLES, deadline=None, suppress_health_check=_SUPPRESS, derandomize=_CI)
#: For round trips write -> read.
ROUND_TRIP = settings(max_examples=max(EXAMPLES // 4, 10), deadline=None, suppress_health_check=_SUPPRESS,
                      derandomize=_CI)
