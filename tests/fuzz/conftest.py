"""Hypothesis profiles of the fuzz tests: ``ci`` (200 examples per reader, the default) and ``dev``
(2000 per reader, for local runs: ``SCANGEO_FUZZ=dev python -m pytest tests/fuzz``). The round trips
(test_round_trips.py) run a quarter of that: each example writes and reads a whole file."""
from __future__ import annotations

import os

from hypothesis import HealthCheck, settings

_COMMON = {"deadline": None, "suppress_health_check": [HealthCheck.too_slow, HealthCheck.data_too_large],
           "derandomize": False}
settings.register_profile("ci", max_examples=200, **_COMMON)
settings.register_profile("dev", max_examples=2000, **_COMMON)
settings.load_profile(os.environ.get("SCANGEO_FUZZ", "ci"))
