"""Check points at an over-scanned swath edge: scored at the sighting nearest their measurement.

The tiny project's strip 1 yaws +-2 deg at 1 Hz (12.6 deg/s at most): the swath's edges, 364 m either
side of the track, then run backwards at times, faster than the 50 m/s flight (0.22 rad/s x 364 m = 80
m/s), so a ground point near an edge is seen by two or three scans; the nadir never is. A check point
measured at its own scan (where its image shows it) has, with the true orientation, a residual of
zero; the first sighting in time is up to five lines away.
"""
from __future__ import annotations

import csv

import numpy as np
import pyproj
import pytest

from scangeo.adjustment.results import run_variant
from scangeo.io.project import Project
from scangeo.sensors.kernels import MULTIPLE, OK
from tests.conftest import make_tiny_project

YAW_DEG, YAW_HZ = 2.0, 1.0


@pytest.fixture(scope="module")
def overscanned(tmp_path_factory):
    """The tiny project with a yawing strip 1, and image positions at its edges whose ground point the
    strip sees again more than a line away: (root, geometry, line, pixel, ground points p_P)."""
    info = make_tiny_project(tmp_path_factory.mktemp("overscan") / "tiny")
    t = info.t_start + np.arange(3001) / 50.0
    lon, lat = pyproj.Transformer.from_crs(info.crs, "EPSG:4326", always_xy=True).transform(
        np.full_like(t, info.easting("1")), info.northing("1", t))
    zero = np.zeros_like(t)
    heading = YAW_DEG * np.sin(2 * np.pi * YAW_HZ * (t - info.t_start))
    np.savetxt(info.root / "nav" / "1.csv", np.column_stack([t, lat, lon, zero + info.flight_h, zero, zero, heading]),
               delimiter=",", header="time,lat,lon,h,roll,pitch,heading", comments="",
               fmt=["%.3f", "%.11f", "%.11f", "%.3f", "%g", "%g", "%.6f"])
    project = Project.load(info.root)
    geometry = project.geometry("1")
    line = np.repeat(np.arange(20.0, 380.0, 7.0), 4)
    pixel = np.tile([0.0, 2.0, 98.0, 100.0], len(line) // 4)
    p_P, status = geometry.image_to_ground(line, pixel, project.dtm)
    assert (status == OK).all()
    first, _, seen = geometry.ground_to_image(p_P)
    again = ((seen & MULTIPLE) != 0) & (np.abs(first - line) > 1.0)
    assert again.sum() >= 20, again.sum()
    return info.root, project, geometry, line[again], pixel[again], p_P[again]


def test_the_geometry_returns_the_sighting_nearest_the_measurement(overscanned):
    _, project, geometry, line, pixel, p_P = overscanned
    first, first_pixel, _ = geometry.ground_to_image(p_P)
    assert np.abs(first - line).min() > 1.0 and np.abs(first - line).max() > 3.0  # scans away
    back, _ = geometry.image_to_ground(first, first_pixel, project.dtm)
    assert np.abs(back - p_P).max() < 1e-3  # the first sighting is a true sighting of the same point
    near_line, near_pixel, status = geometry.nearest_sighting(p_P, line, pixel)
    assert ((status & ~MULTIPLE) == OK).all() and ((status & MULTIPLE) != 0).all()
    assert np.abs(near_line - line).max() < 1e-4 and np.abs(near_pixel - pixel).max() < 1e-4
    # a point seen once keeps ground_to_image's answer
    nadir, _ = geometry.image_to_ground(np.array([100.0, 200.0]), np.array([50.0, 50.0]), project.dtm)
    assert np.array_equal(np.column_stack(geometry.nearest_sighting(nadir, [90.0, 210.0], [40.0, 60.0])),
                          np.column_stack(geometry.ground_to_image(nadir)))


def test_check_points_at_the_over_scanned_edge_are_scored_at_their_own_scan(overscanned):
    """Direct georeferencing of the true GPS/IMU: every check-point residual is zero (to the solver's
    1e-6 lines); under the first-sighting rule they were 1-5 lines along track."""
    root, project, geometry, line, pixel, p_P = overscanned
    # and four control points at the nadir (seen once), so that the block has image measurements
    c_line, c_pixel = np.array([50.0, 150.0, 250.0, 350.0]), np.full(4, 50.0)
    c_P, _ = geometry.image_to_ground(c_line, c_pixel, project.dtm)
    ids = [f"C{k:02d}" for k in range(len(line))] + [f"G{k}" for k in range(4)]
    roles = ["check"] * len(line) + ["control"] * 4
    x, y, h = project.map_frame.project_to_map(np.vstack([p_P, c_P]))
    with open(root / "ground.csv", "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(["point", "x", "y", "z", "sigma_xy", "sigma_z", "role"])
        w.writerows([i, f"{a:.6f}", f"{b:.6f}", f"{c:.6f}", 0.1, 0.1, r] for i, a, b, c, r in zip(ids, x, y, h, roles))
    with open(root / "points.csv", "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(["point", "strip", "line", "pixel"])
        w.writerows([i, "1", f"{a:.6f}", f"{b:.6f}"] for i, a, b in zip(ids, [*line, *c_line], [*pixel, *c_pixel]))
    result = run_variant(root, "DG")
    checks = result.checks
    assert sorted(checks.point) == ids[:len(line)] and (checks.status == 0).all()
    assert np.abs(checks.line).max() < 1e-3 and np.abs(checks.pixel).max() < 1e-3
    # the first sighting of the same points with the same orientation: lines away
    first, _, _ = result.geometry("1").ground_to_image(p_P)
    assert np.abs(first - line).min() > 1.0
