"""Simulated blocks shared by the simulator's tests (made once per test session)."""
from __future__ import annotations

import pytest

from scangeo.simulate.block import simulate
from scangeo.simulate.config import load_preset


@pytest.fixture(scope="session")
def small_block(tmp_path_factory):
    """The ``small`` preset with images, truth orthoimage, sensor noise and 6 blunders."""
    config = load_preset("small", {"points": {"blunders": 6}, "sensor": {"noise_dn": 10.0}})
    return simulate(tmp_path_factory.mktemp("sim") / "small", config)


@pytest.fixture(scope="session")
def vienna_geometry(tmp_path_factory):
    """The ``vienna2000`` preset without images (trajectories, errors and points only)."""
    config = load_preset("vienna2000", {"output": {"images": False, "truth_ortho": False}})
    return simulate(tmp_path_factory.mktemp("sim") / "vienna2000", config)
