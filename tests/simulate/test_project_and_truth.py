"""The generated project reads back cleanly, and its truth files agree with each other and the images."""
from __future__ import annotations

import csv
import json
import warnings

import numpy as np
import rasterio

from scangeo.io.project import Project
from scangeo.simulate.scene import N_BANDS
from scangeo.trajectory import read_trajectory_csv


def test_project_reads_back_without_warnings(small_block):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        project = Project.load(small_block.root)
        assert [s.id for s in project.strips] == ["01", "02"]
        for s in project.strips:
            assert project.n_lines(s.id) == 600
            stream = project.stream(s.id)
            assert abs(stream.rate_hz - 50.0) < 1e-6
            assert stream.time[0] < project.timing(s.id).first_line_time
        dtm = project.dtm
        assert project.crs == "EPSG:32633"
    # the project frame is the simulator's: same origin
    frame = project.map_frame.frame
    assert abs(frame.lat0 - small_block.map_frame.frame.lat0) < 1e-12
    # the DTM is the true terrain plus an error of about 1.5 m
    with rasterio.open(small_block.root / "truth" / "dtm_error.tif") as src:
        err = src.read(1)
    assert 0.8 < err.std() < 2.2
    assert dtm.h_min > 100.0 and dtm.h_max < 450.0


def test_images_are_lines_by_pixels_by_bands(small_block):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)
        with rasterio.open(small_block.root / "images" / "01.tif") as src:
            assert (src.height, src.width, src.count) == (600, 716, N_BANDS)
            assert src.dtypes[0] == "uint16"
            assert "ch7_nir" in src.descriptions[6]
            data = src.read()
    assert (data > 0).mean() > 0.99  # every pixel sees the ground
    assert data[6].std() > 300  # structured scene (NIR DN: reflectance * 1e4)


def test_truth_orthoimage_agrees_with_rendered_images(small_block):
    """The ground point of image pixel (l, p) has the same band values in the truth orthoimage."""
    rng = np.random.default_rng(3)
    strip = small_block.strips[0]
    lines = rng.uniform(5, 595, 400).round()
    pixels = rng.uniform(5, 710, 400).round()
    from scangeo.dtm import DTM

    true_dtm = DTM(small_block.terrain.true, small_block.map_frame)
    ground, status = strip.geometry.image_to_ground(lines, pixels, true_dtm)
    assert np.all(status == 0)
    x, y, _ = small_block.map_frame.project_to_map(ground)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)
        with rasterio.open(small_block.root / "images" / "01.tif") as src:
            image = src.read()
    with rasterio.open(small_block.root / "truth" / "ortho.tif") as src:
        ortho = src.read().astype(float)
        rows, cols = rasterio.transform.rowcol(src.transform, x, y)
    rows, cols = np.asarray(rows), np.asarray(cols)
    values = image[:, lines.astype(int), pixels.astype(int)].astype(float)
    within = []
    for b in (2, 6, 10):
        lo = np.min([ortho[b, rows + dr, cols + dc] for dr in (-1, 0, 1) for dc in (-1, 0, 1)], axis=0)
        hi = np.max([ortho[b, rows + dr, cols + dc] for dr in (-1, 0, 1) for dc in (-1, 0, 1)], axis=0)
        noise = 4 * 10.0  # the fixture's sensor noise is 10 DN
        within.append((values[b] >= lo - noise) & (values[b] <= hi + noise))
        corr = np.corrcoef(values[b], ortho[b, rows, cols])[0, 1]
        assert corr > 0.9, (b, corr)
    assert np.mean(within) > 0.97
    # and a shift of 3 cells breaks the agreement: the test can fail
    shifted = np.corrcoef(values[6], ortho[6, rows + 3, cols + 3])[0, 1]
    assert shifted < np.corrcoef(values[6], ortho[6, rows, cols])[0, 1] - 0.1


def test_recorded_errors_are_measured_minus_true(small_block):
    root = small_block.root
    frame = small_block.map_frame.frame
    for s in ("01", "02"):
        measured = read_trajectory_csv(root / "nav" / f"{s}.csv")
        true = read_trajectory_csv(root / "truth" / f"trajectory_{s}.csv")
        data = np.genfromtxt(root / "truth" / f"errors_{s}.csv", delimiter=",", names=True)
        np.testing.assert_allclose(measured.time, data["time"])
        d_P = frame.geodetic_to_project(measured.lat, measured.lon, measured.h) - frame.geodetic_to_project(
            true.lat, true.lon, true.h)
        for k, c in enumerate("xyz"):
            np.testing.assert_allclose(d_P[:, k], data[f"total_{c}_m"], atol=2e-3)
        np.testing.assert_allclose(np.degrees(measured.roll - true.roll), data["total_roll_deg"], atol=2e-6)
        np.testing.assert_allclose(np.degrees(measured.heading - true.heading), data["total_heading_deg"], atol=2e-6)
        shift = np.array(json.loads((root / "truth" / "errors.json").read_text())["strips"][s]["shift_m"])
        assert 1.0 <= np.linalg.norm(shift) <= 3.0
        np.testing.assert_allclose(data["shift_x_m"], shift[0], atol=1e-5)
        strip_info = json.loads((root / "truth" / "errors.json").read_text())["strips"][s]
        t0 = small_block.plan.strips[int(s) - 1].first_line_time
        inside = (data["time"] >= t0) & (data["time"] <= t0 + 599 / 25.0)
        np.testing.assert_allclose(strip_info["mean_position_error_m"][2], data["total_z_m"][inside].mean(), atol=1e-4)


def test_deterministic_per_seed(tmp_path):
    from scangeo.simulate.block import simulate
    from scangeo.simulate.config import load_preset

    config = load_preset("small", {"output": {"images": False, "truth_ortho": False}, "flight": {"lines": 200}})
    a = simulate(tmp_path / "a", config, seed=5)
    b = simulate(tmp_path / "b", config, seed=5)
    c = simulate(tmp_path / "c", config, seed=6)
    for name in ("points.csv", "ground.csv", "nav/01.csv", "truth/errors_02.csv"):
        assert (a.root / name).read_bytes() == (b.root / name).read_bytes(), name
        assert (a.root / name).read_bytes() != (c.root / name).read_bytes(), name
    with open(a.root / "points.csv") as f:
        assert next(csv.reader(f)) == ["point", "strip", "line", "pixel", "sigma_px"]


def test_envi_images_write_and_read_back(tmp_path):
    from scangeo.simulate.render import write_image

    image = (np.arange(30 * 16 * N_BANDS) % 4000).reshape(30, 16, N_BANDS).astype(np.uint16)
    write_image(tmp_path / "01.bsq", image, "ENVI")
    names = {p.name for p in tmp_path.iterdir()}
    assert {"01.bsq", "01.hdr"} <= names and not any("partial" in n for n in names)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)
        with rasterio.open(tmp_path / "01.bsq") as src:
            back = np.moveaxis(src.read(), 0, -1)
            assert src.descriptions[10].startswith("ch11_thermal")
    np.testing.assert_array_equal(back, image)
