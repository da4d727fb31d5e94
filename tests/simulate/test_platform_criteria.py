"""The criteria the platform presets exist for, on their fast versions and the simulated truth.

Two pushbrooms, the SWIR without any control: the joint adjustment georeferences it through its sister, from
the flight lines' GPS/IMU corrections the VNIR's control determines and the relative mounting the tie points
between the two sensors (and a relative-mounting prior) determine. Its true ground error (``scangeo.truth``,
rms over the strips' sample grids) stays within 1.5 times the VNIR's.

A laser and a pushbroom, control on one flight line of three: the joint adjustment (``scangeo.lidar.joint``)
of the laser's patches and the images' points, sharing the flight lines' corrections, puts the image strips
closer to the truth than the imager alone, and the laser strips no worse than the laser alone.
"""
from __future__ import annotations

import re
import shutil

import numpy as np
import pytest

from scangeo.adjustment.keys import Boresight
from scangeo.adjustment.results import run_variant
from scangeo.adjustment.variants import Variant
from scangeo.io.project import Project
from scangeo.lidar.adjust import build, run
from scangeo.lidar.evaluation import apply, evaluate
from scangeo.lidar.joint import laser_part, run_joint
from scangeo.lidar.options import LaserOptions
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


#: degree-1 position corrections per flight line (the GPS/IMU's drift and height wander inside a flight line, which
#: the laser's patches see to the centimetre), the GPS/IMU's own accuracy as a prior on the constants (1 m: the
#: imager alone keeps the flight lines without control near their GPS/IMU instead of letting their tie points
#: float them), every sensor's boresight calibrated; no data snooping (fast, and the same observations alone and
#: joint)
P1_B_GPS = Variant("P1_B_GPS", "P", position_degree=1, attitude_degree=-1, calibrate=("boresight",),
                   constant_sigma_m=1.0, snooping=False)


@pytest.fixture(scope="module")
def joint(platform_block):
    return run_joint(platform_block.root, P1_B_GPS)


def test_the_joint_block_shares_the_flight_lines_corrections(joint):
    """One correction model per flight line, observed by the image strip and the laser strip on it; the laser's
    calibration unknowns are its own (keys of its sensor id)."""
    block = joint.block
    assert [m.id for m in block.image.models] == ["01", "02", "03"]
    for m in block.image.models:
        observers = [g for g in block.groups if m.key in g.keys()]
        assert {type(g).__name__ for g in observers} >= {"StripAnchors"} and any(
            getattr(g, "strip", None) == f"lidar-{m.id}" for g in observers)
    assert Boresight("lidar") in block.parameters and Boresight("nis") in block.parameters
    assert block.parameters[Boresight("lidar")].free.all()


def test_the_laser_and_the_imager_together_beat_the_imager_alone(platform_block, joint):
    """Control on one flight line of three: the laser's patches tie the flight lines and its control patches hold
    them, so the image strips' true ground error falls below the imager's alone; the laser's strip differences
    are no worse than the laser's alone."""
    project = Project.load(platform_block.root)
    truth = Truth.load(project)

    def rms(result):
        return float(np.sqrt(np.mean([truth.error(sid, result.geometry(sid)).rms_ground_m ** 2
                                      for sid in truth.geometries])))

    alone = run_variant(project, P1_B_GPS)
    assert rms(joint.images) < rms(alone)
    view = laser_part(project)
    block = build(view, LaserOptions.from_table(project.adjustment, str(project.file)), P1_B_GPS,
                  project.root / "patches.csv", found=joint.block.laser.found)
    laser = run(block)
    laser_alone = evaluate(block, laser, apply(block, laser.parameters.values())).summary()
    mine = joint.laser.summary()
    key = "strip_differences_flat_rms_m"
    assert mine[key]["after"] <= 1.05 * laser_alone[key]["after"] and mine[key]["after"] < 0.5 * mine[key]["before"]
