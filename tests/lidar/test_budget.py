"""Height precision of area means: hand-computed budget, alpha from a covariance, the CLI."""
from __future__ import annotations

import math

import numpy as np
import pytest

from scangeo.errors import LidarError
from scangeo.lidar.budget import BudgetSigmas, alpha_from_covariance, area_mean_budget


def test_budget_hand_computed_example(run_lidar_json):
    # 100 points, 4 pieces, 2 strips, alpha 0.4; sigmas (cm): seasonal 3, daily 2, local 10, noise 5,
    # short 4, long 6, offset 5
    # contributions: 3, 2, 10/10 = 1, 5/10 = 0.5, 4/2 = 2, 6/sqrt(2) = 4.2426, 0.4*5 = 2
    # total = sqrt(9 + 4 + 1 + 0.25 + 4 + 18 + 4) = sqrt(40.25) = 6.3443
    out = run_lidar_json(["lidar", "budget", "--points", "100", "--pieces", "4", "--n-strips", "2",
                          "--alpha", "0.4", "--sigma-seasonal", "3", "--sigma-daily", "2", "--sigma-local", "10",
                          "--sigma-noise", "5", "--sigma-short", "4", "--sigma-long", "6", "--sigma-offset", "5"])
    assert set(out) == {"total_cm", "components"}
    assert out["total_cm"] == pytest.approx(math.sqrt(40.25), abs=1e-9)
    expected = {"seasonal": 3, "daily": 2, "local": 1, "noise": 0.5, "short": 2, "long": 6 / math.sqrt(2), "offset": 2}
    assert out["components"] == pytest.approx(expected, abs=1e-9)


def test_budget_defaults():
    r = area_mean_budget(400, 2, 2)
    d = BudgetSigmas()
    expected = math.sqrt(d.seasonal**2 + d.daily**2 + (d.local**2 + d.noise**2) / 400
                         + d.short**2 / 2 + d.long**2 / 2 + d.offset**2)
    assert r["total_cm"] == pytest.approx(expected)
    assert r["total_cm"] == pytest.approx(6.2518, abs=1e-4)


def test_alpha_from_offset_covariance(tmp_path, run_lidar_json):
    # two strips with offset variances 4 cm^2 and 2 cm^2, covariance 1 cm^2 (in m^2 in the file)
    C = np.array([[4.0, 1.0], [1.0, 2.0]]) * 1e-4
    path = tmp_path / "cov.txt"
    np.savetxt(path, C)
    # sigma of the mean offset = sqrt(4 + 2 + 2) / 2 = 1.4142 cm -> alpha = 1.4142 / 5
    assert alpha_from_covariance(path, 5.0) == pytest.approx(math.sqrt(8) / 2 / 5)
    out = run_lidar_json(["lidar", "budget", "--points", "1", "--pieces", "1", "--n-strips", "1",
                          "--offset-covariance", str(path), "--sigma-seasonal", "0", "--sigma-daily", "0",
                          "--sigma-local", "0", "--sigma-noise", "0", "--sigma-short", "0", "--sigma-long", "0"])
    assert out["components"]["offset"] == pytest.approx(math.sqrt(2), rel=1e-9)


def test_budget_rejects_bad_input(tmp_path):
    with pytest.raises(LidarError, match="--points"):
        area_mean_budget(0, 1, 1)
    bad = tmp_path / "bad.txt"
    bad.write_text("1 2 3\n4 5 6\n")
    with pytest.raises(Exception, match="square"):
        alpha_from_covariance(bad, 5.0)


def test_scenario_table_flying_twice_beats_denser_points(run_lidar_json):
    out = run_lidar_json(["lidar", "budget", "--points", "100", "--pieces", "1", "--n-strips", "1", "--scenarios"])
    rows = {r["name"]: r for r in out["scenarios"]}
    base, dense = rows["1 pt/m2, 4 control areas"], rows["4 pt/m2, 4 control areas"]
    twice = rows["flown twice, 2 pt/m2, 4 control areas"]
    more_control = rows["1 pt/m2, 12 control areas"]
    # point density hardly matters for an area mean: the per-point terms are already averaged away
    assert dense["total_cm"] == pytest.approx(base["total_cm"], abs=0.01)
    assert twice["total_cm"] < more_control["total_cm"] < base["total_cm"]
