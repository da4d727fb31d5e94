"""The criteria the platform presets exist for, on their fast versions and the simulated truth.

Two pushbrooms, the SWIR without any control: the joint adjustment georeferences it through its sister, from
the flight lines' GPS/IMU corrections the VNIR's control determines and the relative mounting the tie points
between the two sensors (and a relative-mounting prior) determine. Its true ground error (``scangeo.truth``,
rms over the strips' sample grids) stays within 1.5 times the VNIR's.
"""
from __future__ import annotations

import re
import shutil

import numpy as np
import pytest

from scangeo.adjustment.results import run_variant
from scangeo.adjustment.variants import Variant
from scangeo.io.project import Project
from scangeo.truth.true_error import Truth

#: degree-0 position corrections per flight line and every sensor's boresight calibrated (an attitude constant
#: per flight line beside the boresights would be one unknown twice)
SE_B = Variant("SE_B", "SE", attitude_degree=-1, calibrate=("boresight",))


def _true_ground_error(root, variant: Variant) -> tuple[dict[str, float], object]:
    project = Project.load(root)
    truth = Truth.load(project)
    result = run_variant(project, variant)
    errors = {sid: truth.error(sid, result.geometry(sid)).rms_ground_m for sid in truth.geometries}
    by_sensor = {}
    for sensor in project.sensors:
        mine = [e for sid, e in errors.items() if project.strip(sid).sensor == sensor]
        by_sensor[sensor] = float(np.sqrt(np.mean(np.square(mine))))
    return by_sensor, result


@pytest.fixture(scope="module")
def without_prior(pair_block, tmp_path_factory):
    root = tmp_path_factory.mktemp("pair") / "no_prior"
    shutil.copytree(pair_block.root, root)
    text = (root / "project.toml").read_text()
    (root / "project.toml").write_text(re.sub(r"\[\[relative_mountings\]\]\n(.+\n)+\n", "", text))
    assert not Project.load(root).relative_mountings
    return root


def test_a_sensor_without_control_through_its_sisters_control_and_the_ties(without_prior):
    errors, result = _true_ground_error(without_prior, SE_B)
    assert errors["swir"] <= 1.5 * errors["vnir"]
    (rel,) = result.relative_mountings()
    assert (rel.sensor, rel.reference) == ("swir", "vnir") and rel.prior is None
    assert np.all(rel.boresight_sigma > 0)


def test_a_sensor_without_control_through_a_relative_mounting_prior(pair_block):
    errors, result = _true_ground_error(pair_block.root, SE_B)
    assert errors["swir"] <= 1.5 * errors["vnir"]
    (rel,) = result.relative_mountings()
    assert rel.prior is not None
    # the prior (sigma 0.005, 0.005, 0.01 deg) and the ties together: more precise than the prior alone
    assert np.all(np.degrees(rel.boresight_sigma) < [0.005, 0.005, 0.01])
