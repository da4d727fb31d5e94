"""A simulated strip rectified with its true orientation reproduces the truth orthoimage.

The simulator renders the strip through the geometry core from the true trajectory, the true
boresight and the true terrain, and writes the truth orthoimage on the 2.5 m grid and the true
image position of every point. Here the truth is handed to rectification as the result of a
variant ``TRUTH`` (results/TRUTH/orientation.json written here, as another tool would: the true
trajectory and the true boresight) with the true terrain as DTM.

Two measures: check points (the true ground points, looked up in the product's inverse-map layers
``image_line``/``image_pixel`` and compared with their true image positions), and the shift of the
whole orthoimage against the truth orthoimage by least squares (Lucas-Kanade). Per-window image
shifts are printed, not asserted: the simulated scene has detail finer than the pixels and both
the image and the truth orthoimage point-sample it, so aliasing moves 64-cell windows by a few
tenths of a pixel in either direction while the geometry is exact (the analytic band-limited
texture of test_strip.py shows windows agreeing to 0.01 px).
"""
import csv
import dataclasses
import json
import warnings

import cv2
import numpy as np
import pytest
import rasterio
from rasterio.windows import from_bounds

from scangeo.io.project import Project
from scangeo.orientation.file import direct_orientation, load_adjusted_geometry, write_orientation
from scangeo.rectify.batch import grid_of, rectify_project
from scangeo.rectify.core_geometry import CoreStripGeometry
from scangeo.rectify.gdal_route import corner_geolocation, warp_with_geolocation
from scangeo.rectify.options import RectifyOptions
from scangeo.sensors import Mounting
from scangeo.trajectory import OrientationSpline
from scangeo.trajectory.readers import read_trajectory
from tests.conftest import shared_file


def simulate_truth_project(root, terrain):
    from scangeo.simulate.block import simulate
    from scangeo.simulate.config import load_preset

    over = {"flight": {"strips": 1, "lines": 250}, "terrain": terrain}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        simulate(root, load_preset("small", over))
    errors = json.loads((root / "truth" / "errors.json").read_text())
    toml = (root / "project.toml").read_text().replace('dtm = "dtm.tif"', 'dtm = "truth/terrain.tif"')
    (root / "project.toml").write_text(toml)
    project = Project.load(root)
    res = root / "results" / "TRUTH"
    res.mkdir(parents=True)
    truth = read_trajectory(root / "truth" / "trajectory_01.csv", crs=project.trajectory_crs or project.crs)
    spline = OrientationSpline.from_trajectory(truth.to_project(project.map_frame.frame), project.knot_spacing)
    doc = direct_orientation(project)
    (sid, setup), = doc.sensors.items()
    m = setup.mounting
    true = Mounting(m.lever_arm_B, np.radians(errors["true_boresight_deg"]), m.time_offset)
    doc = dataclasses.replace(
        doc, variant="TRUTH", adjusted=True, sigma0=1.0,
        sensors={sid: dataclasses.replace(setup, mounting=true)},
        strips={"01": dataclasses.replace(doc.strips["01"], spline=spline)})
    write_orientation(doc, res / "orientation.json")
    return root


@pytest.fixture(scope="module", params=["flat", "srtm"])
def truth_project(request, tmp_path_factory):
    root = tmp_path_factory.mktemp(f"truth_{request.param}") / "p"
    if request.param == "flat":
        terrain = {"kind": "urban"}
    else:
        terrain = {"kind": "file", "file": str(shared_file("dtm/N44E005.hgt"))}
    return simulate_truth_project(root, terrain)


def on_truth_grid(ortho_path, truth_path, band):
    """The orthoimage band and the truth band on the orthoimage's grid (same alignment)."""
    with rasterio.open(ortho_path) as o, rasterio.open(truth_path) as t:
        win = from_bounds(*o.bounds, transform=t.transform).round_offsets().round_lengths()
        a = o.read(band).astype(float)
        b = t.read(band, window=win, boundless=True, fill_value=0).astype(float)
        valid = (a != o.nodata) & (b > 0)
    return a, b, valid


def shifts(a, b, valid, window=64, blur=1.0):
    """(global (dx, dy), per-window (n, 2)) least-squares shift of ``a`` against ``b``, in cells."""
    filled = np.where(valid, a, b)
    a = cv2.GaussianBlur(filled, (0, 0), blur)
    b = cv2.GaussianBlur(b, (0, 0), blur)
    m = cv2.erode(valid.astype(np.uint8), np.ones((9, 9), np.uint8)).astype(bool)
    gy, gx = np.gradient(b)
    r = a - b

    def solve(mask):
        G = np.stack([gx[mask], gy[mask]], 1)
        return np.linalg.solve(G.T @ G, G.T @ r[mask])

    per = []
    for r0 in range(0, a.shape[0] - window + 1, window):
        for c0 in range(0, a.shape[1] - window + 1, window):
            mm = np.zeros_like(m)
            mm[r0:r0 + window, c0:c0 + window] = True
            mm &= m
            if mm.sum() > 0.8 * window * window:
                per.append(solve(mm))
    return solve(m), np.array(per)


@pytest.fixture(scope="module")
def rectified(truth_project):
    options = RectifyOptions(resolution=2.5, resampling="cubic", layers=("image_line", "image_pixel"))
    result = rectify_project(truth_project, "TRUTH", options=options)
    return truth_project, result


def check_point_residuals(root):
    """(line, pixel) residuals of the true points: product's inverse map minus true image position."""
    points = {r["point"]: r for r in csv.DictReader(open(root / "truth" / "points.csv"))}
    meas = [r for r in csv.DictReader(open(root / "truth" / "measurements.csv")) if r["strip"] == "01"]
    x = np.array([float(points[m["point"]]["x"]) for m in meas])
    y = np.array([float(points[m["point"]]["y"]) for m in meas])
    true = np.array([[float(m["line_true"]), float(m["pixel_true"])] for m in meas])
    with rasterio.open(root / "results/TRUTH/ortho/01.layers.tif") as lay:
        grid = grid_of(root / "results/TRUTH/ortho/01.tif")
        layers = lay.read().astype(float)
        names = lay.tags()["layers"].split()
    from scangeo.grid import RasterGrid

    got = np.stack([RasterGrid(layers[names.index(n)], grid.transform).sample(x, y)
                    for n in ("image_line", "image_pixel")], 1)
    ok = np.isfinite(got).all(1)
    return got[ok] - true[ok]


def test_check_points_sit_where_the_true_geometry_puts_them(rectified):
    root, result = rectified
    s = result.strips["01"]
    assert s["status"] == "done" and s["inverse_map_max_error_px"] <= 0.05
    d = check_point_residuals(root)
    print(f"{len(d)} check points: mean {d.mean(0)} rms {np.sqrt((d ** 2).mean(0))} (line, pixel)")
    assert len(d) >= 10
    assert np.all(np.abs(d.mean(0)) < 0.05)
    assert np.all(np.sqrt((d ** 2).mean(0)) < 0.1)


def test_true_orientation_reproduces_the_truth_orthoimage(rectified):
    root, result = rectified
    for band in (3, 7):
        a, b, valid = on_truth_grid(root / "results/TRUTH/ortho/01.tif", root / "truth/ortho.tif", band)
        assert valid.sum() > 0.8 * 250 * 700
        mean, per = shifts(a, b, valid)
        print(f"band {band}: mean shift {mean} px, 64-cell windows: rms {np.sqrt((per ** 2).mean(0))} px")
        # aliasing of the point-sampled scene leaves a few hundredths of a pixel even over the strip
        assert np.all(np.abs(mean) < 0.1)
        # the values: the rectified DNs are the truth's up to interpolation of sharp edges
        assert np.median(np.abs(a - b)[valid]) < 0.1 * b[valid].std()


def test_the_gdal_route_on_the_same_grid_agrees_geometrically(rectified):
    """rasterio reproject with geolocation arrays (pixel corners) vs scangeo, same grid and input."""
    root, result = rectified
    project = Project.load(root)
    geometry = CoreStripGeometry(load_adjusted_geometry(project, "TRUTH", "01"), project.dtm)
    x, y = corner_geolocation(geometry)
    ours_path = root / "results/TRUTH/ortho/01.tif"
    grid = grid_of(ours_path)
    with warnings.catch_warnings(), rasterio.open(project.strip("01").image) as src:
        warnings.simplefilter("ignore")
        image = src.read([3])
    gdal = warp_with_geolocation(image, x, y, grid, "bilinear")[0].astype(float)
    with rasterio.open(ours_path) as o:
        ours = o.read(3).astype(float)
    valid = (gdal != 0) & (ours != 0)
    mean, per = shifts(gdal, ours, valid)
    rms = np.sqrt((per ** 2).mean(0))
    print(f"GDAL route minus scangeo: mean shift {mean} px, window rms {rms} px")
    assert valid.sum() > 0.8 * 250 * 700
    # GDAL's geolocation transformer agrees to a fraction of a pixel (it interpolates the IGM)
    assert np.all(np.abs(mean) < 0.1) and np.all(rms < 0.2)
    # with pixel-centre arrays the half-pixel shift of the wrong convention shows up
    xc, yc = (0.5 * (v[:-1, :-1] + v[1:, 1:]) for v in (x, y))
    shifted = warp_with_geolocation(image[:, :-1, :-1], xc, yc, grid, "bilinear")[0].astype(float)
    v2 = (shifted != 0) & (ours != 0)
    mean2, _ = shifts(shifted, ours, v2)
    assert np.hypot(*mean2) > 0.3
