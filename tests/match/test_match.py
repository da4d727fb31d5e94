"""``scangeo match`` on simulated blocks with known truth (tests/match/conftest.py).

Tie measurements are checked against the truth: the true ground point of the master measurement,
seen through the true orientation of the other strip (scangeo.truth.matches).
"""
from __future__ import annotations

import csv

import numpy as np
import pytest

from scangeo.cli import main
from scangeo.errors import OptionsError
from scangeo.match import MatchOptions, match_project
from scangeo.truth.matches import match_errors
from tests.session_projects import copy_project


def _rows(path):
    with open(path, newline="") as f:
        return list(csv.reader(f))


@pytest.mark.parametrize("block", ["landcover_block", "texture_block"])
def test_ties_agree_with_the_truth(block, request, tmp_path):
    root = copy_project(request.getfixturevalue(block), tmp_path / "p", truth=True)
    result = match_project(root)
    overlap = result.report["overlaps"]["01-02"]
    errors = match_errors(root)
    print(block, overlap["points"], errors.tie_rms(), errors.share_within(1.0))
    assert overlap["points"] >= 40
    assert errors.tie_rms() <= 0.2
    assert errors.share_within(1.0) >= 0.95
    # spread: points in at least 80 % of the overlap's cells
    per_cell = np.array(overlap["points_per_cell"])
    assert (per_cell > 0).mean() >= 0.8
    # the precision from the matches' own consistency is of the size of the true error (both in pixels)
    precision = overlap["consistency"]["02"]["precision_cells"]
    assert 0.5 < precision / errors.tie_rms() < 3.0
    sigmas = np.array([float(r[4]) for r in _rows(root / "points.csv")[1:] if r[0].startswith("MT_")])
    assert 0.5 < np.sqrt(2.0 * np.mean(sigmas**2)) / errors.tie_rms() < 3.0


def test_rerun_replaces_only_matched_rows(landcover_block, tmp_path):
    root = copy_project(landcover_block, tmp_path / "p")
    before = _rows(root / "points.csv")
    ground_before = _rows(root / "ground.csv")
    match_project(root, references=[landcover_block / "truth" / "ortho.tif"])
    first = _rows(root / "points.csv")
    assert first[:len(before)] == before  # the simulator's rows, untouched
    matched = [r for r in first[len(before):]]
    assert matched and all(r[0].startswith(("MT_", "MC_")) for r in matched)
    match_project(root, options=MatchOptions(per_overlap=20))  # ties again, control kept
    second = _rows(root / "points.csv")
    assert second[:len(before)] == before
    assert [r for r in second if r[0].startswith("MC_")] == [r for r in first if r[0].startswith("MC_")]
    ties = {r[0] for r in second if r[0].startswith("MT_")}
    assert 0 < len(ties) < len({r[0] for r in first if r[0].startswith("MT_")})
    ground = _rows(root / "ground.csv")
    assert ground[:len(ground_before)] == ground_before
    roles = [r[6] for r in ground if r[0].startswith("MC_")]
    assert roles.count("check") == pytest.approx(0.3 * len(roles), abs=2)
    # the report's section: a map of the points and a row per overlap and strip
    from scangeo.reports.matching import match_section

    section = match_section(root)
    assert section is not None and section.title == "Matched points"
    html = "\n".join(section.parts)
    assert html.count('class="report-figure"') == 1 and "01-02" in html and "01@ortho.tif" in html
    points = _rows(root / "results" / "match_points.csv")
    assert points[0] == ["point", "kind", "x", "y", "strips"] and len(points) - 1 == len(ties) + len(roles)


def test_control_from_a_reference_in_another_crs_and_resolution(landcover_block, tmp_path):
    import rasterio
    from rasterio.warp import Resampling, calculate_default_transform, reproject

    root = copy_project(landcover_block, tmp_path / "p", truth=True)
    ref = tmp_path / "reference_3857.tif"
    with rasterio.open(landcover_block / "truth" / "ortho.tif") as src:
        # Web Mercator at 48 deg: 1.5 m map units are 1.0 m on the ground (finer than the 2.5 m strips)
        t, w, h = calculate_default_transform(src.crs, "EPSG:3857", src.width, src.height, *src.bounds,
                                              resolution=1.5)
        with rasterio.open(ref, "w", driver="GTiff", width=w, height=h, count=3, dtype=src.dtypes[0],
                           crs="EPSG:3857", transform=t) as dst:
            for b in (1, 2, 3):
                out = np.zeros((h, w), src.dtypes[0])
                reproject(rasterio.band(src, b), out, dst_transform=t, dst_crs="EPSG:3857",
                          resampling=Resampling.cubic)
                dst.write(out, b)
    result = match_project(root, references=[ref], options=MatchOptions(control_per_strip=20))
    s = result.report["summary"]
    assert s["control_points"] + s["check_points"] >= 25
    errors = match_errors(root)
    # x, y of a control point against the true ground position of its measurement: under 0.5 pixel
    rms = np.sqrt(np.mean(errors.control_errors_m**2, axis=0))
    assert (rms < 1.25).all()
    assert np.abs(errors.control_errors_m.mean(axis=0)).max() < 0.4  # no half-pixel shift


def test_partial_reference_featureless_overlap_and_lonely_strip(landcover_block, tmp_path, capsys):
    import rasterio
    from rasterio.windows import Window

    root = copy_project(landcover_block, tmp_path / "p")
    # a reference covering only the western third of the block
    part = tmp_path / "west.tif"
    with rasterio.open(landcover_block / "truth" / "ortho.tif") as src:
        win = Window(0, 0, src.width // 3, src.height)
        profile = src.profile | {"width": win.width, "height": win.height,
                                 "transform": src.window_transform(win)}
        with rasterio.open(part, "w", **profile) as dst:
            dst.write(src.read(window=win))
    # strip 02 over water: a constant image
    with rasterio.open(root / "images" / "02.tif", "r+") as img:
        img.write(np.full((img.count, img.height, img.width), 600, img.dtypes[0]))
    assert main(["match", str(root), "--reference", str(part), "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert "overlap 01-02: 0 tie points" in out and "no texture in strip 02" in out
    assert "control 01@west.tif:" in out
    assert "control 02@west.tif: the reference does not cover this strip" in out or \
        "control 02@west.tif: 0 control" in out
    # a project of one strip: no overlap, reported; control still measured
    toml = (root / "project.toml").read_text()
    (root / "project.toml").write_text(toml[:toml.index('[[strips]]\nid = "02"')])
    assert main(["match", str(root), "--reference", str(landcover_block / "truth" / "ortho.tif"),
                 "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert "strip 01: overlaps no other strip" in out
    assert "control 01@ortho.tif:" in out


def test_bad_settings_name_the_key(tmp_path, landcover_block, capsys):
    cfg = tmp_path / "match.toml"
    cfg.write_text("[match]\ntemplate_size = 21\n")
    assert main(["match", str(landcover_block), "--config", str(cfg)]) == 1
    assert "template_size" in capsys.readouterr().err
    with pytest.raises(OptionsError, match=r"x.toml \[match.template_px\]: expected an integer >= 7, odd"):
        MatchOptions.from_dict({"template_px": 20}, "x.toml")


def test_an_adjusted_variant_predicts_better(landcover_block, tmp_path):
    root = copy_project(landcover_block, tmp_path / "p", truth=True)
    (root / "variants.toml").write_text('[variants.SE]\nstrategy = "SE"\nsnooping = false\n', encoding="utf-8")
    assert main(["adjust", str(root), "--variant", "SE", "--no-progress"]) == 0
    dg = match_project(root, write=False).report["overlaps"]["01-02"]
    se = match_project(root, "SE").report["overlaps"]["01-02"]
    # the adjusted orientation puts the other strip's point nearer its prediction than DG does
    assert se["consistency"]["02"]["median_shift_cells"] < 0.5 * dg["consistency"]["02"]["median_shift_cells"]
    assert se["points"] >= 40
    assert match_errors(root).tie_rms() <= 0.2
