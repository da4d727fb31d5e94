"""Every image measurement reprojects from its true ground point through the true trajectory."""
from __future__ import annotations

import csv
import json

import numpy as np

from scangeo.io.project import Project
from scangeo.sensors import Mounting, StripGeometry
from scangeo.trajectory import OrientationSpline, read_trajectory_csv


def _rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def _true_geometry(root, project, strip_id):
    """The strip's geometry rebuilt from truth/ files only (true trajectory, true boresight)."""
    info = json.loads((root / "truth" / "errors.json").read_text())
    stream = read_trajectory_csv(root / "truth" / f"trajectory_{strip_id}.csv")
    spline = OrientationSpline.from_trajectory(stream.to_project(project.map_frame.frame), 1.0 / stream.rate_hz)
    mounting = Mounting(project.sensor.mounting.lever_arm_B, np.radians(info["true_boresight_deg"]))
    return StripGeometry(project.sensor.model, spline, project.timing(strip_id), project.n_lines(strip_id), mounting)


def test_measurements_reproject_within_noise_and_blunders_are_the_flagged_ones(small_block):
    root = small_block.root
    project = Project.load(root)
    truth = {r["point"]: r for r in _rows(root / "truth" / "points.csv")}
    meas = _rows(root / "truth" / "measurements.csv")
    given = {(r["point"], r["strip"]): r for r in _rows(root / "points.csv")}
    assert len(given) == len(meas) > 50
    residuals, flagged = [], []
    for strip in project.strips:
        mine = [r for r in meas if r["strip"] == strip.id]
        p_P = np.array([[float(truth[r["point"]][k]) for k in ("x_P", "y_P", "z_P")] for r in mine])
        line, pixel, status = _true_geometry(root, project, strip.id).ground_to_image(p_P)
        assert np.all(status == 0)
        # the truth files reproduce the true image coordinates
        np.testing.assert_allclose(line, [float(r["line_true"]) for r in mine], atol=2e-3)
        np.testing.assert_allclose(pixel, [float(r["pixel_true"]) for r in mine], atol=2e-3)
        for r, lt, pt in zip(mine, line, pixel):
            m = given[(r["point"], strip.id)]
            residuals.append((float(m["line"]) - lt, float(m["pixel"]) - pt))
            flagged.append(r["blunder"] == "1")
    residuals = np.array(residuals)
    flagged = np.array(flagged)
    size = np.hypot(residuals[:, 0], residuals[:, 1])
    assert flagged.sum() == 6
    assert np.all(size[flagged] >= 10.0 - 0.01)  # blunders are 10-40 px
    good = residuals[~flagged]
    assert np.all(np.abs(good) < 5 * 0.3)  # nothing but noise elsewhere
    rms = np.sqrt(np.mean(good**2))
    assert 0.24 < rms < 0.36, rms  # the injected 0.3 px


def test_ground_file_roles_and_sigmas(small_block):
    root = small_block.root
    ground = _rows(root / "ground.csv")
    truth = {r["point"]: r for r in _rows(root / "truth" / "points.csv")}
    roles = {r["role"] for r in ground}
    assert roles == {"control", "check", "height"}
    assert not any(r["point"].startswith("T") for r in ground)  # tie points have no ground coordinates
    for r in ground:
        t = truth[r["point"]]
        d = np.array([float(r[k]) - float(t[k]) for k in "xyz"])
        assert np.all(np.abs(d[:2]) <= 5 * float(r["sigma_xy"]))
        assert abs(d[2]) <= 5 * float(r["sigma_z"])
    # control in bands at both ends of the block
    ys = np.array([float(r["y"]) for r in ground if r["role"] == "control"])
    y_all = np.array([float(t["y"]) for t in truth.values()])
    span = y_all.max() - y_all.min()
    assert np.sum(ys < y_all.min() + 0.25 * span) >= 3 and np.sum(ys > y_all.max() - 0.25 * span) >= 3


def test_recent_strips_hold_only_the_last_tables_and_rebuilt_tables_give_the_same_answers(vienna_geometry):
    """Point placement keeps the ground -> image tables of the last two strips used (memory of
    large blocks); a strip whose tables were released answers bit-identically after the rebuild."""
    from scangeo.simulate.points import RecentStrips

    geometries = [s.geometry for s in vienna_geometry.strips]
    assert not any("_whiskbroom_tables" in vars(g) for g in geometries)  # released by simulate
    p_P = vienna_geometry.points.p_P
    first = geometries[0].ground_to_image(p_P)
    recent = RecentStrips(geometries, keep=2)
    for k in (0, 1, 2, 1):
        recent[k].ground_to_image(p_P)
    held = [k for k, g in enumerate(geometries) if "_whiskbroom_tables" in vars(g)]
    assert held == [1, 2]
    again = recent[0].ground_to_image(p_P)
    for a, b in zip(first, again):
        np.testing.assert_array_equal(a, b)
    assert np.count_nonzero(first[2] == 0) > 100  # the points are seen: the comparison is not vacuous
    recent.release()
    assert not any("_whiskbroom_tables" in vars(g) for g in geometries)
