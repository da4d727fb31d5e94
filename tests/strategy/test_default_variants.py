"""The default variants (scangeo/data/variants.toml) filled in for a project's problem strips."""
from __future__ import annotations

import shutil

import pytest

from scangeo.adjustment.variants import read_variants
from scangeo.errors import ArgumentError, ProjectFileError
from scangeo.strategy.default_variants import (
    DEFAULT_VARIANTS,
    ProblemStrip,
    ensure_variants_file,
    render_default_variants,
)


def test_data_file_holds_the_strategies_of_the_reference_case():
    text = DEFAULT_VARIANTS.read_text()
    assert '"@PROBLEM_STRIP@"' in text and '"@BREAKS_LINES@"' in text


def test_rendered_variants_follow_the_papers_set_up(tmp_path):
    path = tmp_path / "variants.toml"
    path.write_text(render_default_variants([ProblemStrip("07", (1234.0, 4321.5)), ProblemStrip("09", (99.0,))]))
    v = read_variants(path)
    assert list(v) == ["DG", "BE", "SE", "SE_DTM", "P2", "P4", "S2", "S4"]
    assert [v[n].strategy for n in v] == ["DG", "BE", "SE", "SE", "P", "P", "S", "S"]
    for name in ("P2", "P4"):
        for strip in ("07", "09"):
            m = v[name].strip_models(strip)
            assert m.position_degree == 4 and m.breaks_lines == ()
    for name in ("S2", "S4"):
        assert v[name].strip_models("07").breaks_lines == (1234.0, 4321.5)
        assert v[name].strip_models("09").breaks_lines == (99.0,)
        assert v[name].strip_models("09").position_degree == 2
    # other strips keep the strategy's degree 0 and no breaks
    assert v["S4"].strip_models("01").position_degree is None
    # 2 bands: break-band points stay check points; 4 bands: they become control
    for name in ("DG", "BE", "SE", "SE_DTM", "P2", "S2"):
        assert v[name].role_of("B003", "check") == "check"
    for name in ("P4", "S4"):
        assert v[name].role_of("B003", "check") == "control"
        assert v[name].role_of("K003", "check") == "check"
    # the paper: SE without DTM heights, P/S with them; SE_DTM for sigma0 on identical observations
    assert [n for n in v if v[n].dtm_height_at("T001")] == ["SE_DTM", "P2", "P4", "S2", "S4"]
    assert [n for n in v if v[n].snooping] == []


def test_without_problem_strips_there_are_no_p_or_s_variants(tmp_path):
    path = tmp_path / "variants.toml"
    text = render_default_variants([])
    assert "no problem strip" in text
    path.write_text(text)
    assert list(read_variants(path)) == ["DG", "BE", "SE", "SE_DTM"]


def test_problem_strip_from_the_command_line(problem_small, tmp_path):
    root = tmp_path / "p"
    shutil.copytree(problem_small, root)
    shutil.rmtree(root / "truth")
    with pytest.raises(ProjectFileError, match="strip '9' is not in"):
        ensure_variants_file(root, "9", (100.0,))
    with pytest.raises(ProjectFileError, match="break line 5000 is not inside strip 01"):
        ensure_variants_file(root, "01", (100.0, 5000.0))
    with pytest.raises(ArgumentError, match=r"^breaks_lines=\[100.0\]: needs the problem strip they belong to$"):
        ensure_variants_file(root, None, (100.0,))
    assert not (root / "variants.toml").exists()
    v = read_variants(ensure_variants_file(root, "01", (150.0, 300.0)))
    assert v["S4"].strip_models("01").breaks_lines == (150.0, 300.0)
    assert ensure_variants_file(root, "01", (150.0, 300.0)) == root / "variants.toml"  # the same again: kept
    # an existing file is kept as it is; a problem strip for it is not silently dropped
    (root / "variants.toml").write_text('[variants.MINE]\nstrategy = "SE"\n')
    assert list(read_variants(ensure_variants_file(root))) == ["MINE"]
    with pytest.raises(ArgumentError, match=r"variants.toml exists and holds other variants: problem_strip='01'"):
        ensure_variants_file(root, "01", (150.0, 300.0))


def test_every_plausible_attribution_gets_its_own_p_and_s_variants(tmp_path):
    path = tmp_path / "variants.toml"
    text = render_default_variants([ProblemStrip("03", (2403.0, 4888.0))],
                                   alternatives=[("02", [ProblemStrip("02", (2400.0, 4900.0))]),
                                                 ("02-03", [ProblemStrip("02", (2390.0,)),
                                                            ProblemStrip("03", (2403.0, 4888.0))])])
    path.write_text(text)
    v = read_variants(path)
    assert list(v) == ["DG", "BE", "SE", "SE_DTM", "P2", "P2-02", "P2-02-03", "P4", "P4-02", "P4-02-03", "S2",
                       "S2-02", "S2-02-03", "S4", "S4-02", "S4-02-03"]
    assert v["S4"].strip_models("03").breaks_lines == (2403.0, 4888.0) and v["S4"].strip_models("02").breaks_lines == ()
    assert v["S4-02"].strip_models("02").breaks_lines == (2400.0, 4900.0)
    assert v["S4-02"].strip_models("03").breaks_lines == ()
    assert v["S2-02-03"].strip_models("02").breaks_lines == (2390.0,)
    assert v["P4-02"].strip_models("02").position_degree == 4 and v["P4-02"].strip_models("03").position_degree is None
    # the same set-up otherwise: roles, DTM heights, the description says which attribution
    assert v["S4-02"].role_of("B003", "check") == "control" and v["S2-02"].role_of("B003", "check") == "check"
    assert v["S4-02"].dtm_height_at("T001") and "another attribution: strip 02" in v["S4-02"].description
    assert "# Variants NAME-02: the plausible other attribution strip 02 breaks at lines 2400, 4900" in text


def test_a_diagnosis_with_an_ambiguous_attribution_fills_in_both(tmp_path):
    from scangeo.adjustment.diagnosis.attribution import Attribution, AttributionCheck
    from scangeo.adjustment.diagnosis.diagnose import Diagnosis
    from scangeo.adjustment.diagnosis.patterns import BreakEstimate, Fit
    from scangeo.strategy.default_variants import attributions

    fit = Fit((), 0.0, 0.0, 0, {}, {})
    moved = Attribution("moved", "03", "02", {"02": (2400.0, 4900.0)}, 205.0, 7.0, placed=True)
    shared = Attribution("shared", "03", "02", {"02": (2390.0,), "03": (2403.0, 4888.0)}, 240.0, 42.0)
    d = Diagnosis("p", ["01", "02", "03"], {"01": 7000, "02": 7000, "03": 7000},
                  [BreakEstimate("03", 2403.0, 2300.0, 2500.0), BreakEstimate("03", 4888.0, 4700.0, 5000.0)],
                  fit, fit, 1.0, attribution=[AttributionCheck("03", moved, shared, [moved])])
    assert d.ambiguous and d.plausible() == [moved] and d.chosen_breaks() == {"03": (2403, 4888)}
    problems, alternatives = attributions(d, "test")
    assert [(p.strip, p.breaks_lines) for p in problems] == [("03", (2403, 4888))]
    assert [(label, [(p.strip, p.breaks_lines) for p in alt]) for label, alt in alternatives] == \
        [("02", [("02", (2400.0, 4900.0))])]
    # a clear attribution adds nothing
    d.attribution = [AttributionCheck("03", moved, shared, [])]
    assert attributions(d, "test")[1] == [] and not d.ambiguous
