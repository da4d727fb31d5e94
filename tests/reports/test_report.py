"""`scangeo report`: the HTML report (rendered by headless Chromium) and the GeoPackage (read by sqlite3)."""
from __future__ import annotations

import csv
import sqlite3
import struct

import numpy as np
import pytest

from scangeo.io.project import Project
from scangeo.reports.residual_vectors import check_vectors, ground_jacobian
from tests.reports.browser import browser, check_layout


def test_ground_jacobian_of_a_level_flight(tiny_project):
    """Strip 1 of the tiny project flies north at 50 m/s, 10 lines/s, 1000 m above flat ground."""
    t = tiny_project
    project = Project.load(t.root)
    J = ground_jacobian(project.geometry("1"), project.dtm, np.array([120.0, 250.0]), np.full(2, (t.pixels - 1) / 2))
    step = np.radians(t.fov_deg) / t.pixels
    k0 = 0.9996  # UTM scale on the central meridian: map metres per ground metre across track
    np.testing.assert_allclose(J[:, 1, 0], t.speed / t.line_rate, rtol=1e-6)   # north per line
    np.testing.assert_allclose(J[:, 0, 1], t.height_above_ground * step * k0, rtol=1e-4)  # east per pixel
    np.testing.assert_allclose(J[:, 0, 0], 0.0, atol=1e-6)
    # the mirror's per-pixel time offset: one pixel later by step / (2 pi line rate) seconds
    np.testing.assert_allclose(J[:, 1, 1], t.speed * step / (2 * np.pi * t.line_rate), rtol=1e-3)


def _check_rows(path):
    rows = {}
    for r in csv.DictReader(open(path)):
        if r["group"] == "check points":
            rows.setdefault((r["id"], r["strip"]), {})[r["component"]] = r
    return rows


def _gpkg_point(blob: bytes) -> tuple[int, float, float]:
    """srs_id, x, y of a GeoPackage point geometry blob (header, optional envelope, WKB)."""
    assert blob[:2] == b"GP"
    flags = blob[3]
    order = "<" if flags & 1 else ">"
    srs_id = struct.unpack(order + "i", blob[4:8])[0]
    envelope = {0: 0, 1: 32, 2: 48, 3: 48, 4: 64}[(flags >> 1) & 7]
    wkb = blob[8 + envelope:]
    o = "<" if wkb[0] == 1 else ">"
    kind, x, y = struct.unpack(o + "Idd", wkb[1:21])
    assert kind == 1
    return srs_id, x, y


def test_geopackage_holds_every_check_point_with_its_residuals(compared_small):
    root, c, files = compared_small
    project = Project.load(root)
    epsg = int(project.crs.split(":")[1])
    ground = {r["point"]: r for r in csv.DictReader(open(root / "ground.csv"))}
    con = sqlite3.connect(files.geopackage)
    layers = dict(con.execute("select table_name, srs_id from gpkg_contents").fetchall())
    assert set(layers) == {f"{k}_{v.name}" for v in c.variants for k in ("check", "vectors")}
    assert set(layers.values()) == {epsg}
    org = con.execute("select organization, organization_coordsys_id, definition from gpkg_spatial_ref_sys "
                      "where srs_id = ?", (epsg,)).fetchone()
    assert org[0].upper() == "EPSG" and org[1] == epsg and "UTM zone 33N" in org[2]
    geom_type = dict(con.execute("select table_name, geometry_type_name from gpkg_geometry_columns").fetchall())
    for v in c.variants:
        layer = f"check_{v.name}"
        assert geom_type[layer] == "POINT" and geom_type[f"vectors_{v.name}"] == "LINESTRING"
        expected = _check_rows(root / "results" / v.name / "residuals.csv")
        cols = [d[1] for d in con.execute(f'pragma table_info("{layer}")')]
        features = con.execute(f'select * from "{layer}"').fetchall()
        assert len(features) == len(expected) == sum(v.strips[s]["check"]["n"] for s in c.strips)
        seen, ratios = set(), []
        for f in features:
            a = dict(zip(cols, f))
            key = (a["point"], a["strip"])
            seen.add(key)
            srs, x, y = _gpkg_point(a["geom"])
            assert srs == epsg
            assert x == pytest.approx(float(ground[a["point"]]["x"]), abs=1e-6)
            assert y == pytest.approx(float(ground[a["point"]]["y"]), abs=1e-6)
            assert a["residual_line"] == pytest.approx(float(expected[key]["line"]["residual"]), rel=1e-5)
            assert a["residual_pixel"] == pytest.approx(float(expected[key]["pixel"]["residual"]), rel=1e-5)
            assert a["ground_error_m"] == pytest.approx(np.hypot(a["dx_m"], a["dy_m"]))
            ratios.append(a["ground_error_m"] / np.hypot(a["residual_line"], a["residual_pixel"]))
            assert a["flagged"] == int(any(r["flagged"] == "1" for r in expected[key].values()))
        assert seen == set(expected)
        # pixels are ~2.5 m on the ground (attitude rates stretch single lines): metres per pixel of residual
        assert 2.0 < np.median(ratios) < 3.2


def test_residual_vectors_of_a_variant(compared_small):
    root, c, _ = compared_small
    v = check_vectors(Project.load(root), "SE")
    assert len(v) == sum(c.variant("SE").strips[s]["check"]["n"] for s in c.strips)
    for sid in c.strips:
        s = v.of_strip(sid)
        rms = c.variant("SE").strips[sid]["check"]
        assert np.sqrt(np.mean(s.d_pixel**2)) == pytest.approx(rms["rms_across_px"], rel=1e-4)
        assert np.sqrt(np.mean(s.d_line**2)) == pytest.approx(rms["rms_along_px"], rel=1e-4)


@pytest.mark.browser
def test_report_opens_in_a_browser(compared_small, tmp_path):
    root, c, files = compared_small
    with browser(tmp_path / "chromium-profile") as driver:
        driver.get(files.html.resolve().as_uri())
        images = driver.execute_script(
            "return Array.from(document.images).map(i => [i.id || i.alt, i.complete, i.naturalWidth, i.naturalHeight])")
        table_rows = driver.execute_script(
            "return Array.from(document.querySelectorAll('#comparison-table tbody tr'))"
            ".map(r => r.cells[0].textContent)")
        sections = driver.execute_script(
            "return Array.from(document.querySelectorAll('section h2')).map(h => h.textContent)"
        )
        figure_ids = driver.execute_script("return Array.from(document.querySelectorAll('figure')).map(f => f.id)")
        height = driver.execute_script("return document.body.scrollHeight")
        driver.set_window_size(1300, min(int(height) + 50, 12000))
        shot = tmp_path / "report.png"
        assert driver.save_screenshot(str(shot))
        # nothing wider than the page at 800 and 1400 px: every table fits or scrolls in its own box
        for width in (800, 1400):
            check_layout(driver, files.html, width, tmp_path / f"report-{width}.png")
    assert table_rows == [v.name for v in c.variants]
    assert len(images) == files.figures
    assert all(complete and w > 0 and h > 0 for _, complete, w, h in images), images
    # the table, the rms chart; per strip residual vectors, corrections, GPS/IMU; the problem strip's
    # height corrections; the map of the tracks
    n = len(c.strips)
    # the reliability maps of the reference and the best variant, per strip
    reliability_figures = [f"fig-rel-{v}-{s}" for v in dict.fromkeys([c.reference, c.best]) if v for s in c.strips]
    assert sorted(figure_ids) == sorted(
        ["fig-rms", "fig-tracks", "fig-height-02", "fig-diagnosis"]
        + [f"fig-{k}-{s}" for k in ("vectors", "corr", "gpsimu") for s in c.strips]
        + reliability_figures
    )
    assert len(figure_ids) == 4 + 3 * n + len(reliability_figures)
    assert sections == [
        "Comparison of strategies",
        "Diagnosis and recommendation",
        "Quicklook",
        "Residual vectors at the check points",
        "Correction functions",
        "GPS/IMU data",
        "Unknowns, observations and conditions",
        "Regularisation and blunders",
        "Reliability",
        "Files",
    ]
    from PIL import Image

    with Image.open(shot) as im:
        assert im.size[0] >= 1200 and im.size[1] > 3000
        assert len(im.convert("L").getcolors(maxcolors=256 * 256) or range(1000)) > 50  # not a blank page


def test_html_is_self_contained(compared_small):
    _, c, files = compared_small
    text = files.html.read_text()
    assert "http://" not in text and "https://" not in text and "<script" not in text
    assert text.count("data:image/png;base64,") == files.figures
    assert 'id="true-error-table"' in text and 'id="accounting-table"' in text
    # the diagnosis: the proposed breaks, the misclosure plot, the attribution, the cross-validation and the
    # correlated pairs
    for part in ('id="breaks-table"', 'id="fig-diagnosis"', 'id="attribution-table"', 'id="crossvalidation-table"',
                 'id="correlations-table"'):
        assert part in text, part
    # the recommendation with its margin in each evidence and the check points' independent measure
    assert f"Recommended: {c.recommended} (" in text and "margin: " in text and "in cross-validation" in text
    assert "measure" in text and "check-point rms px" in text
    for v in c.variants:
        assert f"<h3>{v.name}</h3>" in text


def test_corrections_follow_the_injected_gps_error_and_each_orientation_is_read_once(compared_small, monkeypatch):
    from scangeo.reports import corrections, report

    root, c, _ = compared_small
    project = Project.load(root)
    reads = []
    real = corrections.read_orientation_file
    monkeypatch.setattr(corrections, "read_orientation_file", lambda path: reads.append(path) or real(path))
    section = report._corrections_section(project, c)
    adjusted = [v.name for v in c.variants if v.error is None and v.strategy != "DG"]
    # one read per variant for every strip's figure (it was one per variant and strip: quadratic in strips)
    assert len(reads) == len(adjusted) == len(set(reads))
    assert sum('class="report-figure"' in p for p in section.parts) == len(c.strips) + 1  # + the problem strip's
    # the S variant's height correction on the problem strip undoes the injected GPS height error
    orientations = corrections.written_orientations(project, adjusted)
    problem = corrections.problem_strips(project, orientations)
    assert problem == ["02"]
    s_name = next(v.name for v in c.variants if v.strategy == "S" and v.error is None)
    series = corrections.correction_series(project, {s_name: orientations[s_name]}, "02")[s_name]
    truth = corrections.true_gps_error(project, "02")
    err_z = np.interp(series.time, truth.time, truth.values[:, 2])
    assert np.std(err_z) > 3.0  # metres of excursion
    assert np.sqrt(np.mean((series.values[:, 2] + err_z) ** 2)) < 0.2 * np.std(err_z)
    assert corrections.breaks_of(project, {s_name: orientations[s_name]}, "02")  # the split's breaks
