"""Simulated blocks shared by the simulator's tests (made once per test session)."""
from __future__ import annotations

import dataclasses

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


@pytest.fixture(scope="session")
def pair_block(tmp_path_factory):
    """``pushbroom_pair_quick`` without images: the SWIR without any control, a relative-mounting prior."""
    config = load_preset("pushbroom_pair_quick", {
        "output": {"images": False, "truth_ortho": False},
        "platform": {"relative_mountings": [{"sensor": "swir", "reference": "vnir",
                                             "boresight_sigma_deg": [0.005, 0.005, 0.01],
                                             "lever_arm_sigma_m": [0.01, 0.01, 0.01]}]},
    })
    swir = next(s for s in config.platform.sensors if s.id == "swir")
    sensors = tuple(dataclasses.replace(s, measures_control=False) if s is swir else s for s in config.platform.sensors)
    config = dataclasses.replace(config, platform=dataclasses.replace(config.platform, sensors=sensors))
    return simulate(tmp_path_factory.mktemp("sim") / "pair", config)


@pytest.fixture(scope="session")
def platform_block(tmp_path_factory):
    """``platform_quick`` without images: a laser and a pushbroom on three flight lines, control on the middle one."""
    config = load_preset("platform_quick", {"output": {"images": False, "truth_ortho": False}})
    return simulate(tmp_path_factory.mktemp("sim") / "platform", config)
