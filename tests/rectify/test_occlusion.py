"""When the terrain cannot hide ground (every slope below every ray's elevation) the fold test and
the z-buffer are skipped: the bound's parts against brute force, and the same orthoimage."""
import copy

import numpy as np
import pytest
from affine import Affine

from scangeo.dtm import DTM
from scangeo.grid import RasterGrid
from scangeo.rectify import occlusion
from scangeo.rectify.options import RectifyOptions
from scangeo.rectify.strip import rectify_strip_array
from scangeo.rectify.strip_run import strip_grid
from scangeo.sensors import Whiskbroom
from tests.rectify.test_refined_map import X0, Y0, geometry, hilly_dtm
from tests.session_projects import write_strip_image


@pytest.fixture(scope="module")
def strip():
    return geometry(Whiskbroom())


def test_the_largest_view_zenith_is_at_the_ends_of_the_scan_lines(strip):
    g = strip
    lines = np.repeat(np.arange(0, g.lines, 3, dtype=float), g.pixels)
    pixels = np.tile(np.arange(g.pixels, dtype=float), lines.size // g.pixels)
    origin, direction = g.core.rays(lines, pixels)
    every_ray = float(np.arccos(-direction[:, 2]).max())
    bound = g.largest_view_zenith()
    # roll 2 deg and pitch 0.6 deg on a 42.9 deg scan; the vertical's tilt is under 0.02 deg here
    assert every_ray <= bound < every_ray + np.radians(0.02)
    assert np.radians(23.0) < bound < np.radians(25.0)


def test_the_steepest_slope_bounds_the_dtm_surface():
    dtm = hilly_dtm()
    bounds = (X0 - 1000.0, Y0 - 1000.0, X0 + 1000.0, Y0 + 1000.0)
    x, y = np.meshgrid(np.linspace(X0 - 1000, X0 + 1000, 801), np.linspace(Y0 - 1000, Y0 + 1000, 801))
    gx = 150 / 700 * np.cos(x / 700.0) * np.cos(y / 900.0) + 40 / 230 * np.cos((x + 2 * y) / 230.0)
    gy = -150 / 900 * np.sin(x / 700.0) * np.sin(y / 900.0) + 80 / 230 * np.cos((x + 2 * y) / 230.0)
    true = float(np.hypot(gx, gy).max())
    bound = occlusion.steepest_slope(dtm, bounds, 10.0)
    assert true * 0.99 <= bound <= true * np.sqrt(2)


def test_steep_terrain_could_hide_gentle_terrain_cannot(strip):
    g = copy.copy(strip)
    bounds = strip_grid(g, RectifyOptions(resolution=6.0)).bounds
    assert not occlusion.could_hide(g, bounds)  # slopes up to about 25 deg, rays within 24 deg
    v = g.dtm.grid.values.copy()
    v[1000:, :] += 30.0  # a 30 m step between two 5 m posts: a slope of 6
    g.dtm = DTM(RasterGrid(v, g.dtm.grid.transform, g.dtm.grid.crs), g.dtm.map_frame, "step")
    assert occlusion.could_hide(g, bounds)
    flat = DTM(RasterGrid(np.full((50, 50), 400.0), Affine(5.0, 0, X0, 0, -5.0, Y0), g.dtm.grid.crs),
               g.dtm.map_frame, "far away")
    assert occlusion.steepest_slope(flat, bounds, 10.0) == 0.0  # the bounds miss it: nothing to hide


def test_skipping_the_tests_gives_the_same_orthoimage(strip, tmp_path, monkeypatch):
    g = strip
    write_strip_image(tmp_path / "img.tif", g.lines, g.pixels, bands=2, dtype="uint16")
    opts = RectifyOptions(resolution=6.0, bounds=(X0 - 600.0, Y0 - 900.0, X0 + 600.0, Y0 - 300.0))
    skipped = rectify_strip_array(g, tmp_path / "img.tif", opts)
    monkeypatch.setattr(occlusion, "could_hide", lambda *a: True)
    tested = rectify_strip_array(g, tmp_path / "img.tif", opts)
    # the z-buffer hides a few cells at the grid's edge (one-sided footprints) that nothing can hide
    assert skipped.hidden_cells == 0 and tested.hidden_cells < 10
    assert skipped.valid_cells == tested.valid_cells + tested.hidden_cells > 20_000
    shown = tested.values[0] != tested.nodata
    assert np.array_equal(skipped.values[:, shown], tested.values[:, shown])
    assert (skipped.values[0] != skipped.nodata).sum() - shown.sum() == tested.hidden_cells
