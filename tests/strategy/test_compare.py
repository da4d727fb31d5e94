"""`scangeo compare`: every variant adjusted, the table against the reference, the true error."""
from __future__ import annotations

import csv
import json
import shutil

import numpy as np
import pytest

from scangeo.cli import main
from scangeo.errors import ProjectFileError
from scangeo.io.project import Project
from scangeo.reports.tables import CSV_FIELDS, read_comparison
from scangeo.strategy.comparison import compare_project
from scangeo.truth.true_error import Truth


def test_table_holds_each_variants_own_figures(compared_small):
    root, c, _ = compared_small
    assert [v.name for v in c.variants] == ["DG", "BE", "SE", "SE_DTM", "P2", "P4", "S2", "S4"]
    for v in c.variants:
        assert v.error is None
        report = json.loads((root / "results" / v.name / "report.json").read_text())
        assert v.sigma0 == pytest.approx(report["sigma0"], rel=1e-12)
        assert v.accounting == report["accounting"]
        for sid in c.strips:
            mine, theirs = v.strips[sid]["check"], report["strips"][sid]["check"]
            assert mine["n"] == theirs["n"]
            if theirs["n"]:
                assert mine["rms_along_px"] == pytest.approx(theirs["rms_along_lines"], rel=1e-12)
                assert mine["rms_across_px"] == pytest.approx(theirs["rms_across_px"], rel=1e-12)
        assert v.max_degree == (None if v.strategy == "DG" else max(
            max(m["position_degree"], m["attitude_degree"]) for m in report["models"]))
    # the 4-band variants turn the break-band points from check into control points
    se, p4 = c.variant("SE"), c.variant("P4")
    n_b = sum(1 for line in open(root / "ground.csv") if line.startswith("B"))
    assert n_b > 0 and p4.control["XYZ"] == se.control["XYZ"] + n_b
    assert sum(p4.strips[s]["check"]["n"] for s in c.strips) < sum(se.strips[s]["check"]["n"] for s in c.strips)
    # the paper's set-up: SE and BE without DTM heights, P/S with them; SE_DTM has P2's observations; no rejection
    dtm = c.variant("SE_DTM")
    assert se.dtm_heights == 0 and c.variant("BE").dtm_heights == 0 and c.variant("DG").dtm_heights == 0
    assert dtm.dtm_heights > 0
    assert all(c.variant(n).dtm_heights == dtm.dtm_heights and c.variant(n).rejected == 0
               for n in ("P2", "P4", "S2", "S4"))
    assert c.variant("P2").accounting["observations"] == dtm.accounting["observations"]
    assert dtm.accounting["observations"] == se.accounting["observations"] + dtm.dtm_heights


def test_percentages_of_the_reference(compared_small):
    _, c, _ = compared_small
    se = c.variant("SE")
    assert c.sigma0_percent(se) == pytest.approx(100.0)
    for v in c.variants:
        assert c.sigma0_percent(v) == pytest.approx(100.0 * v.sigma0 / se.sigma0)
        for sid in c.strips:
            for key in ("along", "across"):
                expected = 100.0 * v.strips[sid]["check"][f"rms_{key}_px"] / se.strips[sid]["check"][f"rms_{key}_px"]
                assert c.check_percent(v, sid, key) == pytest.approx(expected)


def test_files_read_back(compared_small):
    root, c, _ = compared_small
    again = read_comparison(root / "results")
    assert again.as_dict() == json.loads(json.dumps(c.as_dict()))
    assert again.best == c.best and again.best not in (None, "SE")
    # the recommendation: a correction of the problem strip, by 2-fold cross-validation and the check points
    assert again.recommended == c.recommended and c.recommended in ("P2", "P4", "S2", "S4")
    cv = c.crossvalidation
    assert cv["folds"] == 2 and cv["rms_px"][c.recommended] < cv["rms_px"]["SE"]
    # DG, GPS/IMU as measured with nothing fitted, is the baseline: the problem strip's drift makes it the worst
    assert cv["rms_px"]["DG"] == max(cv["rms_px"].values()) > 2 * cv["rms_px"][c.recommended]
    ev = cv["evidence"]
    assert ev["recommended"] == c.recommended and ev["margin"].startswith(f"{c.recommended}, ")
    assert ev["rms_px"][c.recommended]["check"] == pytest.approx(c.variant(c.recommended).check_pooled_rms())
    assert not ev["contradicts_checks"] and ev["independent_check"]["folds"] == 2
    md = (root / "results" / "comparison.md").read_text()
    assert "## Recommendation" in md and "margin: " in md
    rows = list(csv.DictReader(open(root / "results" / "comparison.csv")))
    assert list(rows[0]) == CSV_FIELDS
    assert len(rows) == len(c.variants) * len(c.strips)
    row = next(r for r in rows if r["variant"] == "S4" and r["strip"] == c.strips[1])
    assert float(row["check_rms_across_px"]) == pytest.approx(
        c.variant("S4").strips[c.strips[1]]["check"]["rms_across_px"], rel=1e-5
    )
    assert float(row["true_rms_ground_m"]) > 0
    md = (root / "results" / "comparison.md").read_text()
    for v in c.variants:
        assert f"| {v.name} | {v.strategy} |" in md
    assert "## True error (simulated project)" in md


def test_true_error_known_answers(problem_small):
    project = Project.load(problem_small)
    truth = Truth.load(project)
    for sid, g in truth.geometries.items():
        e = truth.error(sid, g)  # the truth against itself
        assert e.n > 0.9 * truth.lines * truth.pixels
        assert e.rms_along_px < 1e-4 and e.rms_across_px < 1e-4 and e.max_ground_m < 1e-4
        # the true trajectory moved 4 m east: every ground point moves by 4 m (up to the terrain's slopes)
        coef = g.spline.coef.copy()
        coef[:, 0] += 4.0
        shifted = project.geometry(sid, spline=g.spline.with_coef(coef), mounting=g.mounting)
        e = truth.error(sid, shifted)
        assert e.rms_ground_m == pytest.approx(4.0, abs=0.3)
        assert e.rms_along_px < 0.1 and 1.0 < e.rms_across_px < 2.5  # ~2.3-2.6 m pixels across track


def test_truth_is_absent_for_a_real_project(tiny_project):
    assert Truth.load(Project.load(tiny_project.root)) is None


def test_a_failing_variant_is_reported_not_raised(problem_small, tmp_path):
    root = tmp_path / "p"
    shutil.copytree(problem_small, root)
    variants = tmp_path / "mine.toml"
    variants.write_text(
        '[variants.SE]\nstrategy = "SE"\n[variants.BAD]\nstrategy = "S"\n'
        '[[variants.BAD.strip]]\nid = "01"\nbreaks_lines = [100000.0]\n'
    )
    c = compare_project(root, variants, names=["SE", "BAD"])
    assert c.variant("SE").error is None
    assert "variant BAD, strip 01: breaks must lie inside" in c.variant("BAD").error
    assert c.best is None  # nothing but the reference succeeded
    with pytest.raises(ProjectFileError, match="no variant 'NOPE'"):
        compare_project(root, variants, names=["NOPE"])
    with pytest.raises(ProjectFileError, match="no such variants file"):
        compare_project(root, tmp_path / "missing.toml")


def test_compare_command_on_a_project_without_truth(problem_small, tmp_path, capsys):
    # a real project has no truth/: the tables and the report leave the true error out
    root = tmp_path / "p"
    shutil.copytree(problem_small, root)
    shutil.rmtree(root / "truth")
    # the problem strip and breaks given (the diagnosis behind a compare without them: compared_small, physics)
    assert main(["compare", str(root), "--only", "DG", "SE", "S2", "--problem-strip", "02", "--breaks-lines", "200",
                 "400", "--folds", "2", "--no-report", "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert "reference SE; best (lowest check-point rms): S2" in out
    assert (root / "variants.toml").exists() and (root / "results" / "comparison.json").exists()
    assert not (root / "results" / "report.html").exists()
    c = read_comparison(root / "results")
    assert [v.name for v in c.variants] == ["DG", "SE", "S2"]
    assert np.isfinite(c.variant("S2").sigma0)
    assert not c.truth and all("true" not in e for v in c.variants for e in v.strips.values())
    assert "True error" not in (root / "results" / "comparison.md").read_text()
    assert main(["report", str(root), "--no-geopackage", "--no-progress"]) == 0  # the GeoPackage: tests/reports
    assert (root / "results" / "report.html").exists() and not (root / "results" / "residuals.gpkg").exists()
    text = (root / "results" / "report.html").read_text()
    assert 'id="fig-height-02"' in text and 'id="true-error-table"' not in text


def test_correlated_shift_and_tilt_are_flagged(compared_small):
    _, c, _ = compared_small
    pairs = c.variant("SE").correlations
    assert pairs and all(abs(p["r"]) > 0.95 for p in pairs)
    # with control in two bands at the strip ends, an across-track shift and a roll of a strip move the footprint
    # alike (the strips fly north-south: x is across track)
    assert {(p["a"], p["b"]) for p in pairs} & {("x0", "roll0"), ("y0", "pitch0")}
    assert "move the footprint alike" in pairs[0]["note"]
