"""set_aside: which measurements the cleaning's rejected.csv leaves out (hand-made cases)."""
from __future__ import annotations

import numpy as np

from scangeo.io.points import GroundPoints, ImagePoints
from scangeo.io.rejected import RejectedMeasurement, rejected_path, set_aside, write_rejected


def _points(rows):
    point, strip, line, pixel = zip(*rows)
    n = len(rows)
    return ImagePoints(np.array(point), np.array(strip), np.array(line, float), np.array(pixel, float),
                       np.ones(n), np.arange(n) + 2)


def _ground(rows):
    point, xyz = zip(*rows)
    n = len(rows)
    return GroundPoints(np.array(point), np.array(xyz, float), np.full(n, 0.05), np.full(n, 0.05),
                        np.array(["control"] * n), np.arange(n) + 2)


def test_set_aside_leaves_out_rejected_and_undetermined_points(tmp_path):
    points = _points([("T1", "01", 10, 20), ("T1", "02", 11, 21),      # tie: one ray rejected -> both go
                      ("C1", "01", 30, 40),                             # control: coordinates rejected -> ray goes
                      ("C2", "01", 50, 60), ("C2", "02", 51, 61),       # control: coordinates rejected, 2 rays stay
                      ("C3", "01", 70, 80),                             # untouched
                      ("T2", "01", 90, 99), ("T2", "02", 91, 98)])      # rejected ray was corrected since: kept
    ground = _ground([("C1", (1.0, 2.0, 3.0)), ("C2", (4.0, 5.0, 6.0)), ("C3", (7.0, 8.0, 9.0))])
    rejected_path(tmp_path).parent.mkdir(parents=True)
    write_rejected(rejected_path(tmp_path), [
        RejectedMeasurement("image", "T1", "02", 11, 21),
        RejectedMeasurement("ground", "C1", xyz=(1.0, 2.0, 3.0)),
        RejectedMeasurement("ground", "C2", xyz=(4.0, 5.0, 6.0)),
        RejectedMeasurement("image", "T2", "01", 90.5, 99),
    ])
    kept_points, kept_ground, n = set_aside(tmp_path, points, ground)
    assert list(zip(kept_points.point, kept_points.strip)) == [
        ("C2", "01"), ("C2", "02"), ("C3", "01"), ("T2", "01"), ("T2", "02")]
    assert list(kept_ground.point) == ["C3"]
    assert n == 3 + 2     # T1 both rays, C1's ray; C1 and C2 coordinates


def test_no_file_keeps_everything(tmp_path):
    points = _points([("T1", "01", 10, 20), ("T1", "02", 11, 21)])
    ground = _ground([("C1", (1.0, 2.0, 3.0))])
    assert set_aside(tmp_path, points, ground) == (points, ground, 0)
