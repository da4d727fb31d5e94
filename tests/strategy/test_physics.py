"""The physics of the reference case (DESIGN section 7) on the vienna2000 block, end to end.

``scangeo compare`` on a simulated vienna2000 block without a variants file: the diagnosis finds the
problem strip and its breaks (the truth is not read to build the variants), the default variants of the
paper's set-up run, a 2-fold cross-validation recommends one; the figures asserted are those of the
comparison table (check points), the true error against truth/ and the diagnosis. Two seeds (five at
half and full length), and five seeds of a block without a problem strip (``small``, three strips). By default
(CI) the block is reduced to a quarter of its length (every line-based key of the preset scaled: lines,
breaks, excursions, control and break bands; the same points and errors); ``SCANGEO_SCALE=half`` and
``SCANGEO_SCALE=full`` run half and the full length (docs/reports.md has the figures of each).
"""
from __future__ import annotations

import json
import math
import os
import tomllib

import pytest

from scangeo.adjustment.diagnosis.diagnose import diagnose
from scangeo.simulate.block import simulate
from scangeo.simulate.config import load_preset, preset_path
from scangeo.strategy.comparison import compare_project

SCALE = os.environ.get("SCANGEO_SCALE", "").lower()
FACTOR = {"full": 1.0, "half": 0.5}.get(SCALE, 0.25)
#: two seeds at the reduced size (CI: the suite's time budget; seed 3 cost as much as 1 and 2 together), five
#: at half and full length (the issue's acceptance runs)
SEEDS = (1, 2) if FACTOR < 0.5 else (1, 2, 3, 4, 5)
CORRECTED = ("P2", "P4", "S2", "S4")

pytestmark = pytest.mark.scale


def reduced_overrides(preset: str, factor: float) -> dict:
    """Overrides that shorten a preset's strips by ``factor``, scaling every line-based key with them."""
    data = tomllib.loads(preset_path(preset).read_text())
    lines = round(data["flight"]["lines"] * factor)
    errors = data.get("gpsimu_errors", {})
    strips = []
    for s in errors.get("strip", []):
        s = dict(s)
        if "excursion_lines" in s:
            s["excursion_lines"] = [min(float(round(v * factor)), lines - 1.0) for v in s["excursion_lines"]]
        strips.append(s)
    points = data.get("points", {})
    return {"flight": {"lines": lines},
            "gpsimu_errors": {"breaks_lines": [float(round(b * factor)) for b in errors.get("breaks_lines", [])],
                              "strip": strips},
            "points": {k: points[k] * factor for k in ("control_band_lines", "break_band_lines") if k in points}}


@pytest.fixture(scope="module", params=SEEDS, ids=[f"seed{s}" for s in SEEDS])
def vienna(request, tmp_path_factory):
    over = {"output": {"images": False, "truth_ortho": False}, "seed": request.param}
    if FACTOR != 1.0:
        over.update(reduced_overrides("vienna2000", FACTOR))
    root = tmp_path_factory.mktemp(f"physics{request.param}") / "vienna2000"
    simulate(root, load_preset("vienna2000", over))
    comparison = compare_project(root, folds=2)
    truth = json.loads((root / "truth" / "errors.json").read_text())
    diagnosis = json.loads((root / "results" / "diagnosis.json").read_text())
    problem = str(truth["problem_strip"])
    good = [s for s in comparison.strips if s != problem]
    return comparison, problem, good, truth, diagnosis, request.param


def _check(c, name, strip, key):
    return c.variant(name).strips[strip]["check"][f"rms_{key}_px"]


def _true(c, name, strip, key):
    return c.variant(name).strips[strip]["true"][f"rms_{key}_px"]


def pooled_true(v) -> float:
    """rms of the true error over every strip, along and across together (pixels)."""
    tot = n = 0.0
    for e in v.strips.values():
        t = e["true"]
        tot += t["n"] * (t["rms_along_px"] ** 2 + t["rms_across_px"] ** 2)
        n += 2 * t["n"]
    return math.sqrt(tot / n)


def test_the_diagnosis_finds_the_problem_strip(vienna):
    c, problem, good, truth, d, _ = vienna
    assert d["problem_strips"] == [problem]  # found, and no good strip flagged
    assert all(v.error is None and v.converged for v in c.variants)


def test_each_injected_break_lies_in_the_95_percent_interval_of_a_found_one(vienna):
    # the diagnosis's own statement of its precision, held to: a found break per injected one, whose 95 %
    # interval holds it (the intervals' coverage measured: 37 of 40 breaks over 20 seeds, docs/adjustment.md)
    # and spans at most a tenth of the strip (seeds 1 and 2 at quarter length: 108-146 of 1750 lines, the
    # injected lines 9-46 lines from the found ones)
    _, problem, _, truth, d, _ = vienna
    found = [b for b in d["breaks"] if b["strip"] == problem]
    lines = round(tomllib.loads(preset_path("vienna2000").read_text())["flight"]["lines"] * FACTOR)
    assert len(found) == len(truth["breaks_lines"]), (found, truth["breaks_lines"])
    for line in truth["breaks_lines"]:
        b = min(found, key=lambda b: abs(b["line"] - line))
        assert b["low"] <= line <= b["high"], (line, b)
        assert b["high"] - b["low"] <= 0.1 * lines, (b, lines)


def test_direct_georeferencing_is_several_pixels_off(vienna):
    c = vienna[0]
    for sid in c.strips:
        along, across = _check(c, "DG", sid, "along"), _check(c, "DG", sid, "across")
        assert ((along**2 + across**2) / 2) ** 0.5 > 2.0, (sid, along, across)


def test_strip_models_good_strips_below_a_pixel_problem_strip_worse_across(vienna):
    c, problem, good = vienna[:3]
    for sid in good:
        assert _check(c, "SE", sid, "along") < 1.0 and _check(c, "SE", sid, "across") < 1.0
    worst_good = max(_check(c, "SE", s, "across") for s in good)
    assert _check(c, "SE", problem, "across") > max(1.0, 3.0 * worst_good)


@pytest.mark.parametrize("name", CORRECTED)
def test_corrections_halve_the_problem_strips_across_track_error(vienna, name):
    c, problem = vienna[:2]
    assert c.check_percent(c.variant(name), problem, "across") <= 50.0
    # the true error of the orientation says the same, without the check points' noise
    assert _true(c, name, problem, "across") <= 0.5 * _true(c, "SE", problem, "across")


@pytest.mark.parametrize("name", CORRECTED)
def test_good_strips_stay_as_they_were(vienna, name):
    """No good strip worse than SE by more than 15 % or 0.1 px (the larger of the two), check points and truth."""
    c, _, good = vienna[:3]
    worse = [(value.__name__, sid, key, value(c, name, sid, key), value(c, "SE", sid, key))
             for sid in good for key in ("along", "across") for value in (_check, _true)
             if value(c, name, sid, key) > max(1.15 * value(c, "SE", sid, key), value(c, "SE", sid, key) + 0.1)]
    assert not worse, worse


@pytest.mark.parametrize("name", CORRECTED)
def test_sigma0_on_identical_observations_improves_by_a_quarter(vienna, name):
    c = vienna[0]
    assert c.sigma0_identical_percent(c.variant(name)) <= 75.0


def test_the_recommended_variant_is_near_the_best(vienna):
    c = vienna[0]
    adjusted = [v for v in c.variants if v.strategy != "DG"]
    best = min(pooled_true(v) for v in adjusted)
    assert c.recommended is not None
    assert pooled_true(c.variant(c.recommended)) <= 1.15 * best, (c.recommended, c.crossvalidation)


def test_no_breaks_on_a_block_without_a_problem_strip(tmp_path):
    """No break proposed on at least 4 of 5 seeds of a block without a problem strip (``small``, 3 strips)."""
    proposed = {}
    for seed in (1, 2, 3, 4, 5):
        root = tmp_path / f"quiet{seed}"
        simulate(root, load_preset("small", {"output": {"images": False, "truth_ortho": False}, "seed": seed,
                                             "flight": {"strips": 3}, "points": {"tie_per_overlap": 40}}))
        proposed[seed] = [(b.strip, round(b.line)) for b in diagnose(root).breaks]
    assert sum(not b for b in proposed.values()) >= 4, proposed
