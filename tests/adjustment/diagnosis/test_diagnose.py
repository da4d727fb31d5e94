"""scangeo diagnose on simulated blocks: the problem strip and its breaks found without the truth."""
from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from scangeo.adjustment.diagnosis.diagnose import diagnose
from scangeo.adjustment.results import run_variant
from scangeo.adjustment.variants import StripModels, Variant, read_variants
from scangeo.cli import main
from scangeo.simulate.block import simulate
from scangeo.simulate.config import load_preset


def test_the_problem_strip_and_its_breaks_are_found(problem_small):
    truth = json.loads((problem_small / "truth" / "errors.json").read_text())
    d = diagnose(problem_small)
    assert d.problem_strips == [truth["problem_strip"]]
    found = [b for b in d.breaks if b.strip == truth["problem_strip"]]
    assert len(found) == len(truth["breaks_lines"])
    for b, line in zip(found, truth["breaks_lines"]):
        assert abs(b.line - line) <= 30 and b.low <= line <= b.high, (b, line)
        assert b.method == "S model" and b.bic_line is not None  # placed by adjusting the split model
        assert b.p_value is not None and b.p_value < 1e-3 and b.f_statistic > 3  # and needed by it (F test)
    assert d.fit.bic < d.null.bic
    # the series the report plots: every tie point of strip 02 in both of its overlaps
    s02 = next(s for s in d.series if s.strip == "02")
    assert 70 <= s02.tie_line.size <= 80 and np.all(np.diff(s02.tie_line) >= 0)


def test_diagnose_command_writes_variants_for_the_problem_strip(problem_small, tmp_path, capsys):
    root = tmp_path / "p"
    shutil.copytree(problem_small, root, ignore=shutil.ignore_patterns("truth"))  # the truth is not needed
    assert main(["diagnose", str(root), "--no-progress", "--no-refine"]) == 0  # the BIC's lines (faster)
    out = capsys.readouterr().out
    assert "strip 02: PROBLEM STRIP, breaks at line" in out and "strip 01: good" in out
    v = read_variants(root / "variants.toml")
    d = json.loads((root / "results" / "diagnosis.json").read_text())
    # the attribution is clear: the drift on a neighbour instead is far worse; shared with strip 03 (a richer
    # model) comes close, as models with searched breaks do in noise, but does not fit better
    [a] = d["attribution"]
    assert not d["ambiguous"] and a["runner_up"]["delta_bic"] > 10 and a["richer"]["kind"] == "shared"
    assert "attribution of strip 02: runner-up" in out and "clear" in out
    assert list(v) == ["DG", "BE", "SE", "SE_DTM", "P2", "P4", "S2", "S4"]
    breaks = v["S4"].strip_models("02").breaks_lines
    assert len(breaks) == 2 and abs(breaks[0] - 200) <= 30 and abs(breaks[1] - 400) <= 30
    assert d["problem_strips"] == ["02"] and len(d["series"]) == 3
    assert [b["method"] for b in d["breaks"]] == ["BIC", "BIC"] and d["breaks"][0]["bic_line"] is None
    # an existing variants file is kept unless --overwrite; the library's error in the command line's words
    assert main(["diagnose", str(root), "--no-progress"]) == 1
    assert "variants.toml exists: replace it (--overwrite) or write no variants (--no-write-variants)" in \
        capsys.readouterr().err


@pytest.fixture(scope="module")
def quiet_small(tmp_path_factory):
    root = tmp_path_factory.mktemp("quiet") / "small"
    simulate(root, load_preset("small", {"output": {"images": False, "truth_ortho": False},
                                         "flight": {"strips": 3}, "points": {"tie_per_overlap": 40}}))
    return root


def test_no_break_on_a_block_without_a_problem_strip(quiet_small):
    d = diagnose(quiet_small)
    assert d.problem_strips == [] and d.breaks == []


def test_a_polynomial_on_a_strip_without_control_completes_with_a_regularisation_note(problem_small):
    # every control point becomes a check point and the polynomial of strip 02 has no prior (sigma inf)
    v = Variant("P-free", "P", roles=(("E*", "check"), ("H*", "check")), coefficient_sigma_m=float("inf"),
                strips=(StripModels("02", position_degree=4),), snooping=False, max_iterations=50)
    result = run_variant(problem_small, v)
    assert result.adjustment.solution.converged and np.isfinite(result.adjustment.statistics.sigma0)
    assert result.adjustment.solution.regularisation, "expected unknowns regularised on the fly"
    assert any("strip 02 has no control point" in n for n in result.notes)


def test_a_platform_diagnosis_finds_the_drift_of_the_flight_line(problem_small, tmp_path):
    """Two sensors on every flight line (the second one the first again, without control): the error
    functions belong to the flight line, so the diagnosis names one strip per flight line (its first)
    and finds the problem flight line's breaks as the one-sensor project's diagnosis does."""
    from tests.session_projects import as_platform

    root = tmp_path / "platform"
    shutil.copytree(problem_small, root)
    as_platform(root, second="copy")
    truth = json.loads((problem_small / "truth" / "errors.json").read_text())
    d = diagnose(root, refine=None)
    assert d.strips == ["01", "02", "03"]          # one per flight line: the units
    assert d.problem_strips == [truth["problem_strip"]]
    found = [b.line for b in d.breaks if b.strip == truth["problem_strip"]]
    assert len(found) == len(truth["breaks_lines"])
    assert all(abs(b - line) <= 30 for b, line in zip(found, truth["breaks_lines"]))
