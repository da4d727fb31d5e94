"""Height precision of area means: hand-computed budget, alpha from a covariance, the CLI (sigmas in metres,
contributions printed in cm, in m in the JSON), bad input named as Python and as the command line names it."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from scangeo.cli import main
from scangeo.errors import ArgumentError, InputFileError, OptionsError
from scangeo.lidar.budget import BudgetSigmas, alpha_from_covariance, area_mean_budget

DOCS = Path(__file__).resolve().parents[2] / "docs"


def test_budget_hand_computed_example(run_lidar_json):
    # 100 points, 4 pieces, 2 strips, alpha 0.4; sigmas (m): seasonal 0.03, daily 0.02, local 0.10, noise 0.05,
    # short 0.04, long 0.06, offset 0.05
    # contributions (cm): 3, 2, 10/10 = 1, 5/10 = 0.5, 4/2 = 2, 6/sqrt(2) = 4.2426, 0.4*5 = 2
    # total = sqrt(9 + 4 + 1 + 0.25 + 4 + 18 + 4) = sqrt(40.25) = 6.3443 cm; the JSON in metres
    out = run_lidar_json(["lidar", "budget", "--points", "100", "--pieces", "4", "--strip-count", "2",
                          "--alpha", "0.4", "--sigma-seasonal", "0.03", "--sigma-daily", "0.02", "--sigma-local",
                          "0.10", "--sigma-noise", "0.05", "--sigma-short", "0.04", "--sigma-long", "0.06",
                          "--sigma-offset", "0.05"])
    assert set(out) == {"total_m", "components_m"}
    assert out["total_m"] == pytest.approx(math.sqrt(40.25) / 100, abs=1e-11)
    expected = {"seasonal": 3, "daily": 2, "local": 1, "noise": 0.5, "short": 2, "long": 6 / math.sqrt(2), "offset": 2}
    assert out["components_m"] == pytest.approx({k: v / 100 for k, v in expected.items()}, abs=1e-11)


def test_budget_defaults():
    r = area_mean_budget(400, 2, 2)
    d = BudgetSigmas()
    assert (d.seasonal, d.daily, d.local, d.noise, d.short, d.long, d.offset) == (0.02, 0.01, 0.05, 0.03, 0.03,
                                                                                   0.03, 0.05)
    expected = math.sqrt(d.seasonal**2 + d.daily**2 + (d.local**2 + d.noise**2) / 400
                         + d.short**2 / 2 + d.long**2 / 2 + d.offset**2)
    assert r["total_m"] == pytest.approx(expected)
    assert r["total_m"] == pytest.approx(0.062518, abs=1e-6)  # docs/lidar.md: 6.252 cm


def test_alpha_from_offset_covariance(tmp_path, run_lidar_json):
    # two strips with offset variances 4 cm^2 and 2 cm^2, covariance 1 cm^2 (in m^2 in the file)
    C = np.array([[4.0, 1.0], [1.0, 2.0]]) * 1e-4
    path = tmp_path / "cov.txt"
    np.savetxt(path, C)
    # sigma of the mean offset = sqrt(4 + 2 + 2) / 2 = 1.4142 cm -> alpha = 1.4142 / 5
    assert alpha_from_covariance(path, 0.05) == pytest.approx(math.sqrt(8) / 2 / 5)
    out = run_lidar_json(["lidar", "budget", "--points", "1", "--pieces", "1", "--strip-count", "1",
                          "--offset-covariance", str(path), "--sigma-seasonal", "0", "--sigma-daily", "0",
                          "--sigma-local", "0", "--sigma-noise", "0", "--sigma-short", "0", "--sigma-long", "0"])
    assert out["components_m"]["offset"] == pytest.approx(math.sqrt(2) / 100, rel=1e-9)


def test_budget_rejects_bad_input(tmp_path):
    with pytest.raises(ArgumentError, match=r"^points=0: expected 1 or more$"):
        area_mean_budget(0, 1, 1)
    with pytest.raises(ArgumentError, match=r"^n_strips=0: expected 1 or more$"):
        area_mean_budget(1, 1, 0)
    with pytest.raises(ArgumentError, match=r"^alpha=-0.5: expected a number >= 0$"):
        area_mean_budget(1, 1, 1, alpha=-0.5)
    with pytest.raises(OptionsError, match=r"^BudgetSigmas.noise: expected a number >= 0 \(m\), found -0.01$"):
        BudgetSigmas(noise=-0.01)
    bad = tmp_path / "bad.txt"
    bad.write_text("1 2 3\n4 5 6\n")
    with pytest.raises(InputFileError, match="square"):
        alpha_from_covariance(bad, 0.05)
    good = tmp_path / "cov.txt"
    good.write_text("1e-4 0\n0 1e-4\n")
    with pytest.raises(ArgumentError, match=r"^sigma_offset=0.0: expected a number > 0"):
        alpha_from_covariance(good, 0.0)


@pytest.mark.parametrize(("argv", "message"), [
    (["--points", "10", "--pieces", "1", "--strip-count", "1", "--sigma-noise", "-0.01"],
     "--sigma-noise -0.01: expected a number >= 0 (m), found -0.01"),
    (["--points", "10", "--pieces", "1", "--strip-count", "1", "--alpha", "-1"], "--alpha -1: expected a number >= 0"),
    (["--points", "10", "--pieces", "1", "--strip-count", "0"], "--strip-count 0: expected 1 or more"),
    (["--points", "0", "--pieces", "1", "--strip-count", "1"], "--points 0: expected 1 or more"),
])
def test_cli_errors_name_the_flag(argv, message, capsys):
    assert main(["lidar", "budget", *argv]) == 1
    assert capsys.readouterr().err == f"scangeo lidar: error: {message}\n"


def test_cli_sigma_offset_with_a_covariance_names_the_flag(tmp_path, capsys):
    cov = tmp_path / "cov.txt"
    cov.write_text("1e-4 0\n0 1e-4\n")
    assert main(["lidar", "budget", "--points", "1", "--pieces", "1", "--strip-count", "1", "--offset-covariance",
                 str(cov), "--sigma-offset", "0"]) == 1
    assert "--sigma-offset 0: expected a number > 0" in capsys.readouterr().err


def test_the_count_of_strips_is_strip_count(capsys):
    """``--strips`` means strip ids across the command line; a number of strips is ``--strip-count``."""
    with pytest.raises(SystemExit) as exit_:
        main(["lidar", "budget", "--points", "1", "--pieces", "1", "--n-strips", "1"])
    assert exit_.value.code == 2 and "the following arguments are required: --strip-count" in capsys.readouterr().err


def test_centimetres_given_as_before_are_metres_now(run_lidar_json):
    """A sigma of "5" is 5 m: the offset contribution is 5 m, 500 cm (a command line written for cm shows it)."""
    out = run_lidar_json(["lidar", "budget", "--points", "1", "--pieces", "1", "--strip-count", "1",
                          "--sigma-offset", "5"])
    assert out["components_m"]["offset"] == pytest.approx(5.0)


def test_scenario_table_flying_twice_beats_denser_points(run_lidar_json):
    out = run_lidar_json(["lidar", "budget", "--points", "100", "--pieces", "1", "--strip-count", "1", "--scenarios"])
    rows = {r["name"]: r for r in out["scenarios"]}
    base, dense = rows["1 pt/m2, 4 control areas"], rows["4 pt/m2, 4 control areas"]
    twice = rows["flown twice, 2 pt/m2, 4 control areas"]
    more_control = rows["1 pt/m2, 12 control areas"]
    # point density hardly matters for an area mean: the per-point terms are already averaged away
    assert dense["total_m"] == pytest.approx(base["total_m"], abs=1e-4)
    assert twice["total_m"] < more_control["total_m"] < base["total_m"]
    # docs/lidar.md's table: alpha from the 21-strip design, totals in cm
    assert [round(rows[n]["alpha"], 3) for n in rows] == [0.345, 0.345, 0.217, 0.244]
    assert twice["n_strips"] == 2 and base["n_strips"] == 1


def test_the_docs_defaults_table_is_generated_from_the_sigmas():
    from scangeo.io.schema_docs import BLOCK
    from scangeo.io.schema_docs import main as schema_docs

    lidar_md = DOCS / "lidar.md"
    assert "scangeo.lidar.budget.BudgetSigmas" in [m.group("name") for m in BLOCK.finditer(lidar_md.read_text())]
    assert schema_docs([str(lidar_md), "--check"]) == 0, "run: python -m scangeo.io.schema_docs docs/lidar.md"


def test_network_json_is_in_metres_and_the_printed_table_in_cm(run_lidar_json, capsys):
    """The same precisions, printed in cm (docs/lidar.md's figures) and in the JSON in metres."""
    out = run_lidar_json(["lidar", "network"])
    assert set(out) == {"offset_sigma_m"}
    corners = out["offset_sigma_m"]["21 strips, no cross strips, 4 corner controls"]
    assert len(corners) == 21 and 0.018 < min(corners) < max(corners) < 0.022  # 1.84 - 2.12 cm
    assert main(["lidar", "network"]) == 0
    printed = capsys.readouterr().out.splitlines()
    assert printed[0] == "21 strips, no cross strips, 4 corner controls: mean 2.02 cm, max 2.12 cm"
    assert [float(v) for v in printed[1].split()] == pytest.approx([100 * v for v in corners], abs=0.005)
