"""The default variants (scangeo/data/variants.toml) filled in for a project."""
from __future__ import annotations

import json
import shutil

import pytest

from scangeo.adjustment.variants import read_variants
from scangeo.errors import ProjectFileError
from scangeo.reports.default_variants import (DEFAULT_VARIANTS, ProblemStrip, ensure_variants_file,
                                              problem_strip_from_truth, render_default_variants)


def test_data_file_holds_the_strategies_of_the_reference_case():
    text = DEFAULT_VARIANTS.read_text()
    assert '"@PROBLEM_STRIP@"' in text and '"@BREAKS_LINES@"' in text


def test_rendered_variants_read_back_with_the_project_facts(tmp_path):
    path = tmp_path / "variants.toml"
    path.write_text(render_default_variants(ProblemStrip("07", (1234.0, 4321.5))))
    v = read_variants(path)
    assert list(v) == ["DG", "BE", "SE", "P2", "P4", "S2", "S4"]
    assert [v[n].strategy for n in v] == ["DG", "BE", "SE", "P", "P", "S", "S"]
    for name in ("P2", "P4"):
        m = v[name].strip_models("07")
        assert m.position_degree == 4 and m.breaks_lines == ()
    for name in ("S2", "S4"):
        m = v[name].strip_models("07")
        assert m.position_degree == 2 and m.breaks_lines == (1234.0, 4321.5)
    # other strips keep the strategy's degree 0 and no breaks
    assert v["S4"].strip_models("01").position_degree is None
    # 2 bands: break-band points stay check points; 4 bands: they become control
    for name in ("DG", "BE", "SE", "P2", "S2"):
        assert v[name].role_of("B003", "check") == "check"
    for name in ("P4", "S4"):
        assert v[name].role_of("B003", "check") == "control"
        assert v[name].role_of("K003", "check") == "check"
    # the same observations in every adjusted variant: DTM heights at tie points, no automatic rejection
    assert [n for n in v if v[n].dtm_height_at("T001")] == ["BE", "SE", "P2", "P4", "S2", "S4"]
    assert [n for n in v if v[n].snooping] == []


def test_problem_strip_and_breaks_come_from_the_truth(problem_small, tmp_path):
    root = tmp_path / "p"
    shutil.copytree(problem_small, root)
    info = json.loads((root / "truth" / "errors.json").read_text())
    p = problem_strip_from_truth(root)
    assert p.strip == info["problem_strip"] and list(p.breaks_lines) == info["breaks_lines"]
    path = ensure_variants_file(root)
    v = read_variants(path)
    assert v["S2"].strip_models(p.strip).breaks_lines == tuple(info["breaks_lines"])
    assert v["P4"].strip_models(p.strip).position_degree == 4
    # an existing file is kept as it is
    path.write_text('[variants.MINE]\nstrategy = "SE"\n')
    assert list(read_variants(ensure_variants_file(root))) == ["MINE"]


def test_without_truth_the_problem_strip_must_be_named(problem_small, tmp_path):
    root = tmp_path / "p"
    shutil.copytree(problem_small, root)
    shutil.rmtree(root / "truth")
    with pytest.raises(ProjectFileError, match="--problem-strip"):
        ensure_variants_file(root)
    with pytest.raises(ProjectFileError, match="strip '9' is not in"):
        ensure_variants_file(root, "9", (100.0,))
    with pytest.raises(ProjectFileError, match="break line 5000 is not inside strip 01"):
        ensure_variants_file(root, "01", (100.0, 5000.0))
    with pytest.raises(ProjectFileError, match="need break lines"):
        ensure_variants_file(root, "01", ())
    assert not (root / "variants.toml").exists()
    v = read_variants(ensure_variants_file(root, "01", (150.0, 300.0)))
    assert v["S4"].strip_models("01").breaks_lines == (150.0, 300.0)
