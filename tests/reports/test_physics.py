"""The physics of the reference case (DESIGN section 7, issue 5) on the vienna2000 block, end to end.

``scangeo compare`` with the default variants on a simulated vienna2000 block: the figures asserted
are those of the comparison table (check points) and of the true error against truth/. By default
the block is reduced to half its length (every line-based key of the preset halved: lines, breaks,
excursions, control and break bands; the same points and errors); ``SCANGEO_SCALE=full`` runs the
preset as it is (about 3 times longer).
"""
from __future__ import annotations

import os
import tomllib

import pytest

from scangeo.reports.comparison import compare_project
from scangeo.simulate.block import simulate
from scangeo.simulate.config import load_preset, preset_path

FULL = os.environ.get("SCANGEO_SCALE", "").lower() == "full"
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


@pytest.fixture(scope="module")
def vienna(tmp_path_factory):
    over = {"output": {"images": False, "truth_ortho": False}}
    if not FULL:
        over.update(reduced_overrides("vienna2000", 0.5))
    root = tmp_path_factory.mktemp("physics") / "vienna2000"
    simulate(root, load_preset("vienna2000", over))
    comparison = compare_project(root)
    info = tomllib.loads((root / "variants.toml").read_text())
    problem = info["variants"]["S2"]["strip"][0]["id"]
    good = [s for s in comparison.strips if s != problem]
    return comparison, problem, good


def _check(c, name, strip, key):
    return c.variant(name).strips[strip]["check"][f"rms_{key}_px"]


def test_the_problem_strip_is_the_simulated_one(vienna):
    c, problem, good = vienna
    assert problem == c.strips[1] and len(good) == 2  # the middle strip of three
    assert all(v.error is None and v.converged for v in c.variants)


def test_direct_georeferencing_is_several_pixels_off(vienna):
    c, _, _ = vienna
    for sid in c.strips:
        along, across = _check(c, "DG", sid, "along"), _check(c, "DG", sid, "across")
        assert ((along**2 + across**2) / 2) ** 0.5 > 2.0, (sid, along, across)


def test_strip_models_good_strips_below_a_pixel_problem_strip_worse_across(vienna):
    c, problem, good = vienna
    for sid in good:
        assert _check(c, "SE", sid, "along") < 1.0 and _check(c, "SE", sid, "across") < 1.0
    worst_good = max(_check(c, "SE", s, "across") for s in good)
    assert _check(c, "SE", problem, "across") > max(1.0, 3.0 * worst_good)


@pytest.mark.parametrize("name", CORRECTED)
def test_corrections_halve_the_problem_strips_across_track_error(vienna, name):
    c, problem, _ = vienna
    assert c.check_percent(c.variant(name), problem, "across") <= 50.0
    # the true error of the orientation says the same, without the check points' noise
    def true(v):
        return c.variant(v).strips[problem]["true"]["rms_across_px"]
    assert true(name) <= 0.5 * true("SE")


@pytest.mark.xfail(
    strict=True,
    reason=(
        "measured with the default variants (the same observations in every variant: DTM heights at the tie points, "
        "no automatic rejection; docs/reports.md, 'A fair comparison'), preset of commit abdf7c2: SE, without the "
        "problem strip's correction, is pulled by the DTM heights the excursions contradict, so its good strip 03 "
        "worsens (across 0.33 -> 0.47 px half size, 0.38 -> 0.45 px full size, along 0.31 -> 0.41 px); P/S keep strip 03 at 0.32-0.37 px, "
        "which is 69-77 % of SE (along 92-93 % half size, 69-73 % full size); strip 01 across 84-91 % resp. 81-88 %"
    ),
)
@pytest.mark.parametrize("name", CORRECTED)
def test_good_strips_stay_as_they_were(vienna, name):
    c, _, good = vienna
    for sid in good:
        for key in ("along", "across"):
            assert abs(c.check_percent(c.variant(name), sid, key) - 100.0) < 15.0, (sid, key)


@pytest.mark.parametrize("name", CORRECTED)
def test_sigma0_improves_by_a_quarter(vienna, name):
    c, _, _ = vienna
    assert c.sigma0_percent(c.variant(name)) <= 75.0
