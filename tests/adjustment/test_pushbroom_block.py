"""The adjustment of a small pushbroom block against its truth.

The simulator renders whiskbroom scanners only, so the block is made here from the core API: the
simulated small block's terrain, true trajectories and GPS/IMU (with a known datum shift per strip)
are kept, its sensor is replaced by a pushbroom with a look-angle table (across-track angles
nonlinear, along-track angles with a smile), and every true ground point is rendered into the strips
through the true orientation with ``StripGeometry.ground_to_image``, plus measurement noise.
"""
from __future__ import annotations

import json
import re
import shutil

import numpy as np
import pytest

from scangeo.adjustment.keys import Boresight
from scangeo.adjustment.results import evaluate_checks, run_variant
from scangeo.adjustment.variants import Variant
from scangeo.errors import AdjustmentError
from scangeo.io.project import Project
from scangeo.sensors.strip import Mounting, StripGeometry
from scangeo.trajectory.readers import read_trajectory
from scangeo.trajectory.spline import OrientationSpline

from .test_block import SHIFT_ONLY, _pooled_rms, _simulate

NOISE_PX = 0.3
PIXELS = 800


def look_angle_table(pixels: int = PIXELS) -> np.ndarray:
    """``pixel, along_deg, across_deg``: +-20.5 deg across (slightly nonlinear), a smile of 0.05 deg
    (about a line at the edges)."""
    u = (np.arange(pixels) - (pixels - 1) / 2) / ((pixels - 1) / 2)
    across = 20.0 * u + 0.5 * u**3
    along = 0.15 + 0.05 * u**2
    return np.column_stack([np.arange(pixels), along, across])


def true_geometry(root, project: Project, sid: str, boresight) -> StripGeometry:
    traj = read_trajectory(root / "truth" / f"trajectory_{sid}.csv", crs=project.crs).to_project(
        project.map_frame.frame
    )
    m = project.sensor.mounting
    return StripGeometry(
        project.sensor.model,
        OrientationSpline.from_trajectory(traj, project.knot_spacing),
        project.timing(sid),
        project.n_lines(sid),
        Mounting(m.lever_arm_B, boresight, m.time_offset),
        sid,
    )


def make_pushbroom(source, root, boresight_error_deg=(0.0, 0.0, 0.0), seed=5):
    """Copy of the simulated block ``source`` with a pushbroom sensor and rendered measurements."""
    shutil.copytree(source, root, ignore=shutil.ignore_patterns("results"))
    np.savetxt(
        root / "look_angles.csv",
        look_angle_table(),
        fmt=["%d", "%.6f", "%.6f"],
        delimiter=",",
        header="pixel,along_deg,across_deg",
        comments="",
    )
    text = (root / "project.toml").read_text()
    sensor = re.search(r"\[sensor\]\n(.*?)\n\n", text, re.S)
    keep = [
        ln
        for ln in sensor.group(1).splitlines()
        if ln.split("=")[0].strip() in ("line_rate_hz", "boresight_deg", "lever_arm_m")
    ]
    new = "\n".join(["[sensor]", 'kind = "pushbroom"', f"pixels = {PIXELS}", 'look_angles = "look_angles.csv"', *keep])
    (root / "project.toml").write_text(text[: sensor.start()] + new + "\n\n" + text[sensor.end() :])
    project = Project.load(root)
    bore = project.sensor.mounting.boresight + np.radians(boresight_error_deg)
    truth = np.genfromtxt(root / "truth" / "points.csv", delimiter=",", names=True, dtype=None, encoding="utf-8")
    p_P = np.column_stack([truth["x_P"], truth["y_P"], truth["z_P"]])
    rng = np.random.default_rng(seed)
    rows = ["point,strip,line,pixel,sigma_px"]
    for s in project.strips:
        line, pixel, status = true_geometry(root, project, s.id, bore).ground_to_image(p_P)
        inside = (
            ((status & ~16) == 0) & (pixel > 5) & (pixel < PIXELS - 6) & (line > 5) & (line < project.n_lines(s.id) - 6)
        )
        for k in np.flatnonzero(inside):
            dl, dp = rng.normal(0.0, NOISE_PX, 2)
            rows.append(f"{truth['point'][k]},{s.id},{line[k] + dl:.4f},{pixel[k] + dp:.4f},{NOISE_PX}")
    (root / "points.csv").write_text("\n".join(rows) + "\n")
    return root


@pytest.fixture(scope="module")
def simulated(tmp_path_factory):
    return _simulate(tmp_path_factory.mktemp("pb") / "small", SHIFT_ONLY)


@pytest.fixture(scope="module")
def pushbroom(simulated, tmp_path_factory):
    return make_pushbroom(simulated, tmp_path_factory.mktemp("pb") / "pushbroom")


def test_se_on_a_pushbroom_block_recovers_the_shifts_and_checks_reach_the_noise(pushbroom):
    project = Project.load(pushbroom)
    assert project.sensor.kind == "pushbroom"
    result = run_variant(pushbroom, Variant("SHIFT", "SE", attitude_degree=-1))
    err = json.loads((pushbroom / "truth" / "errors.json").read_text())
    stats = result.adjustment.statistics
    assert result.adjustment.solution.converged
    assert not result.adjustment.solution.regularisation
    assert len(result.block.models) == 2
    for m in result.block.models:
        (sid,) = m.strips
        shift = np.array(err["strips"][sid]["shift_m"])
        est, sigma = result.adjustment.parameters[m.key].values, stats.sigmas(m.key)
        assert np.all(np.abs(est + shift) < 3 * sigma), (sid, est, -shift, sigma)
        assert np.all(sigma[:2] < 0.5)
        assert np.linalg.norm(shift) > 1.0  # the injected shift is real (1-3 m)
    assert 0.7 < stats.sigma0 < 1.3
    # check points: with the true orientation their rms is the measurement noise alone
    bore = project.sensor.mounting.boresight
    noise = _pooled_rms(evaluate_checks(result.block, lambda s: true_geometry(pushbroom, project, s, bore)))
    adjusted = _pooled_rms(result.checks)
    assert int((result.checks.status == 0).sum()) >= 20
    assert 0.2 < noise < 0.4
    assert adjusted < 1.2 * noise, (adjusted, noise)
    # direct georeferencing is clearly worse
    dg = run_variant(pushbroom, "DG")
    assert _pooled_rms(dg.checks) > 1.5 * adjusted


def test_pushbroom_boresight_is_calibrated(simulated, tmp_path):
    error_deg = np.array([0.05, -0.04, 0.06])
    root = make_pushbroom(simulated, tmp_path / "bore", boresight_error_deg=error_deg, seed=6)
    result = run_variant(root, Variant("CAL", "SE", attitude_degree=-1, calibrate=("boresight",), dtm_heights=True))
    project = result.block.project
    true = project.sensor.mounting.boresight + np.radians(error_deg)
    est = result.adjustment.parameters[Boresight()].values
    sigma = result.adjustment.statistics.sigmas(Boresight())
    assert np.all(np.abs(est - true) < 3 * sigma), (np.degrees(est), error_deg, np.degrees(sigma))
    # roll and pitch of the boresight are nearly the strips' own shifts (their sigma is about 0.1 deg);
    # the heading turns the two opposite strips' swaths apart and is well determined
    assert sigma[2] < np.radians(0.05)
    assert not result.adjustment.solution.regularisation
    # the check points, projected with the adjusted orientation and boresight, reach the noise
    noise = _pooled_rms(evaluate_checks(result.block, lambda s: true_geometry(root, project, s, true)))
    assert _pooled_rms(result.checks) < 1.2 * noise, (_pooled_rms(result.checks), noise)


def test_whiskbroom_scan_errors_are_refused_for_a_pushbroom(pushbroom):
    with pytest.raises(AdjustmentError, match="index_error.*whiskbroom"):
        run_variant(pushbroom, Variant("IDX", "SE", calibrate=("index_error",)))
