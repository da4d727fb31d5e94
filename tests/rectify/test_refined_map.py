"""The refined inverse map (Newton at every cell from interpolated starts) against the bracketed
ground -> image of the geometry core, cell by cell, on turbulent strips over hilly terrain."""
import numpy as np
import pytest
from affine import Affine

from scangeo.dtm import DTM
from scangeo.errors import ScangeoError
from scangeo.frames import Geoid, MapFrame
from scangeo.grid import RasterGrid
from scangeo.rectify.core_geometry import CoreStripGeometry
from scangeo.rectify.inverse_map import InverseMapOptions, TileGrid
from scangeo.rectify.options import RectifyOptions
from scangeo.rectify.refined_map import _project_points, build_refined_map
from scangeo.sensors import Pushbroom, StripGeometry, Whiskbroom
from scangeo.sensors.kernels import NO_CONVERGENCE, OK
from scangeo.timing import LineTiming
from scangeo.trajectory import OrientationSpline

CRS = "EPSG:32633"
X0, Y0 = 500000.0, 5300000.0


def hilly_dtm(geoid: Geoid | None = None) -> DTM:
    """Hills of +-150 m with slopes up to about 25 deg, 5 m cells, a 10 km square."""
    mf = MapFrame.centred_on(CRS, X0, Y0, 0.0, geoid)
    cell, n = 5.0, 2000
    x = X0 - 5000 + cell * (np.arange(n) + 0.5)
    y = Y0 + 5000 - cell * (np.arange(n) + 0.5)
    X, Y = np.meshgrid(x, y)
    H = 400 + 150 * np.sin(X / 700.0) * np.cos(Y / 900.0) + 40 * np.sin((X + 2 * Y) / 230.0)
    grid = RasterGrid(H, Affine(cell, 0, X0 - 5000, 0, -cell, Y0 + 5000), mf.crs)
    return DTM(grid, mf, "hills")


def turbulent_spline(pitch_amp_deg=0.6, period=5.0, duration=60.0, heading_deg=0.0) -> OrientationSpline:
    """At 60 m/s on ``heading_deg`` (0: north) through the origin's neighbourhood, 2,300 m above it,
    with roll, pitch and heading oscillations."""
    t = np.linspace(0.0, duration, int(duration * 50) + 1)
    w = 2 * np.pi / period
    along, across = -1800.0 + 60.0 * t, 15 * np.sin(0.3 * t)
    h = np.radians(heading_deg)
    v = np.column_stack([
        along * np.sin(h) + across * np.cos(h), along * np.cos(h) - across * np.sin(h),
        2700.0 + 8 * np.sin(0.5 * t),
        np.radians(2.0) * np.sin(w * t + 0.3), np.radians(pitch_amp_deg) * np.sin(1.3 * w * t),
        h + np.radians(0.8) * np.sin(0.7 * w * t + 1.0),
    ])
    return OrientationSpline.fit(t, v, 0.1)


SENSORS = {
    "whiskbroom": Whiskbroom(),
    "pushbroom-table": Pushbroom(pixels=600, along=np.radians(0.2) * np.linspace(-1, 1, 600) ** 2,
                                 across=np.radians(np.linspace(-20, 20, 600))),
    "pushbroom-pinhole": Pushbroom(pixels=800, focal_length=0.05, pitch=20e-6, k1=-20.0, line_offset=2e-4),
}


def geometry(sensor, spline=None, dtm=None, lines=1200) -> CoreStripGeometry:
    core = StripGeometry(sensor, spline or turbulent_spline(), LineTiming(1.0, 25.0), lines)
    return CoreStripGeometry(core, dtm or hilly_dtm())


def tile(g: CoreStripGeometry, rows=200, cols=900, res=6.0, y_top=Y0 + 400.0):
    x0 = X0 - 0.5 * cols * res
    x = x0 + np.arange(cols) * res
    y = y_top - np.arange(rows) * res
    X, Y = np.meshgrid(x, y)
    return TileGrid(x0, y_top, res), X, Y, g.height_on_lattice(x, y)


@pytest.mark.parametrize("name", list(SENSORS))
def test_every_cell_equals_the_bracketed_solution(name):
    g = geometry(SENSORS[name])
    assert g.monotonic
    grid, X, Y, H = tile(g)
    line, pixel, stats = build_refined_map(g, grid, H, InverseMapOptions())
    el, ep = g.ground_to_image(X, Y, H)
    el, ep = el.reshape(X.shape), ep.reshape(X.shape)
    seen = np.isfinite(el)
    assert 0.1 * H.size < seen.sum() < H.size  # the tile reaches beyond the swath on both sides
    assert np.array_equal(seen, np.isfinite(line))
    assert np.abs(line[seen] - el[seen]).max() < 1e-4
    assert np.abs(pixel[seen] - ep[seen]).max() < 1e-4
    # the lattice of starts is one cell in 16 (24 m apart on these 6 m cells); Newton needs two or
    # three evaluations per cell here, a few cells go to the bracketed search
    assert stats.refined_cells == H.size
    assert stats.exact_points < 0.1 * H.size and stats.exact_cells < 0.02 * H.size
    assert 1.0 <= stats.newton_evaluations / stats.refined_cells < 3.0
    assert stats.validated == 256 and stats.max_error_px < 1e-4


def test_a_flight_oblique_to_the_grid_is_refined_alike():
    # heading 40 deg: the cells' lines and pixels change along both grid axes
    g = geometry(Whiskbroom(), spline=turbulent_spline(heading_deg=40.0))
    grid, X, Y, H = tile(g, rows=300, cols=600)
    line, pixel, stats = build_refined_map(g, grid, H, InverseMapOptions())
    el, ep = (a.reshape(X.shape) for a in g.ground_to_image(X, Y, H))
    seen = np.isfinite(el)
    assert seen.sum() > 0.2 * H.size and np.array_equal(seen, np.isfinite(line))
    assert np.abs(line[seen] - el[seen]).max() < 1e-4 and np.abs(pixel[seen] - ep[seen]).max() < 1e-4
    assert stats.newton_evaluations / stats.refined_cells < 3.0


def test_project_points_are_affine_in_height_to_a_millimetre():
    # a geoid raster with a tilt and a bump, so that the undulation varies across the tile
    lon, lat = np.meshgrid(np.linspace(14.0, 16.0, 41), np.linspace(46.8, 48.8, 41))
    N = 45.0 + 2.0 * (lon - 15.0) + 1.5 * np.exp(-((lon - 15.0) ** 2 + (lat - 47.8) ** 2) * 20)
    geoid = Geoid(grid=RasterGrid(N[::-1], Affine(0.05, 0, 13.975, 0, -0.05, 48.825), "EPSG:4326"))
    g = geometry(Whiskbroom(), dtm=hilly_dtm(geoid))
    grid, X, Y, H = tile(g, rows=90, cols=130, res=7.0)
    S = 4
    nr, nc = (89 + S - 1) // S + 1, (129 + S - 1) // S + 1
    xs, ys = grid.x0 + np.arange(nc) * S * grid.res, grid.y0 - np.arange(nr) * S * grid.res
    XL, YL = np.meshgrid(xs, ys)
    idx = np.flatnonzero(np.isfinite(H))
    rows, cols = np.divmod(idx, H.shape[1])
    fast = _project_points(g, XL, YL, S, H, idx)
    if idx.size == H.size:  # every cell: the same points without the index
        assert np.array_equal(_project_points(g, XL, YL, S, H, None), fast)
    exact = g.map_frame.map_to_project(X[rows, cols], Y[rows, cols], H[rows, cols])
    # 0.22 mm measured: the geoid raster is bilinear, its kinks fall between lattice nodes
    assert np.abs(fast - exact).max() < 1e-3


def test_over_scanning_strip_is_solved_by_the_bracketed_search():
    # pitch +-4 deg at a 4 s period: the scan line runs backwards over the ground at times
    g = geometry(Whiskbroom(), spline=turbulent_spline(pitch_amp_deg=4.0, period=4.0))
    assert not g.monotonic
    grid, X, Y, H = tile(g, rows=120, cols=300)
    line, pixel, stats = build_refined_map(g, grid, H, InverseMapOptions())
    el, ep = g.ground_to_image(X, Y, H)
    assert np.array_equal(line.ravel(), el, equal_nan=True) and np.array_equal(pixel.ravel(), ep, equal_nan=True)
    assert stats.refined_cells == 0 and stats.exact_cells == H.size
    with pytest.raises(ScangeoError, match="over-scans"):
        g.ground_to_image_near(X[:1, 0], Y[:1, 0], H[:1, 0], [0.0], [0.0])


def test_cells_that_do_not_converge_go_to_the_bracketed_search():
    # Newton on the spline (pushbrooms; whiskbrooms interpolate their conditions and converge in the
    # guess's interval, tests/sensors/test_parallel_kernel.py)
    g = geometry(SENSORS["pushbroom-pinhole"])
    grid, X, Y, H = tile(g, rows=100, cols=500)
    opts = InverseMapOptions(max_iter=1, tol_line=1e-6)  # one evaluation is never enough at 1e-6 lines
    line, pixel, stats = build_refined_map(g, grid, H, opts)
    el, ep = g.ground_to_image(X, Y, H)
    seen = np.isfinite(el.reshape(X.shape))
    assert stats.exact_cells > 0.5 * seen.sum()
    assert np.abs(line[seen] - el.reshape(X.shape)[seen]).max() < 1e-4


def test_newton_from_far_guesses_never_returns_a_wrong_answer():
    g = geometry(SENSORS["pushbroom-table"])
    grid, X, Y, H = tile(g, rows=60, cols=560)
    el, ep = g.ground_to_image(X, Y, H)
    rng = np.random.default_rng(5)
    for spread in (3.0, 40.0, 300.0):
        l0 = el + rng.normal(0, spread, el.size)
        p0 = ep + rng.normal(0, spread, el.size)
        line, pixel, status, steps = g.ground_to_image_near(X, Y, H, l0, p0)
        ok = status == OK
        assert np.abs(line[ok] - el[ok]).max() < 1e-4 and np.abs(pixel[ok] - ep[ok]).max() < 1e-4
        if spread == 3.0:
            assert ok.sum() == np.isfinite(l0).sum()
        assert np.all(np.isin(status[~ok], [NO_CONVERGENCE, 1, 2, 3]))


def _rectify(tmp_path, g):
    import cv2
    import rasterio

    from scangeo.rectify.strip import rectify_strip

    image = tmp_path / "strip.tif"
    if not image.exists():
        base = np.random.default_rng(2).integers(100, 3000, size=(76, 180)).astype(np.float32)
        data = cv2.resize(base, (g.pixels, g.lines), interpolation=cv2.INTER_CUBIC).astype(np.uint16)
        with rasterio.open(image, "w", driver="GTiff", width=g.pixels, height=g.lines, count=1, dtype="uint16") as dst:
            dst.write(data, 1)
    opts = RectifyOptions(resolution=2.5, layers=("image_line", "image_pixel"))
    r = rectify_strip(g, image, tmp_path / "ortho.tif", opts)
    with rasterio.open(r.layers_path) as src:
        return r, src.read(), r.grid


@pytest.fixture(scope="module")
def steep_turbulent():
    return geometry(Whiskbroom(), lines=300)


def test_rectified_strip_holds_the_exact_solution_at_every_cell(tmp_path, steep_turbulent):
    g = steep_turbulent
    r, layers, grid = _rectify(tmp_path, g)
    assert r.inverse_map_method == "refine" and r.stats.refined_cells > 0 and r.stats.max_error_px < 1e-4
    x, y = grid.x_of_col(np.arange(grid.width)), grid.y_of_row(np.arange(grid.height))
    X, Y = np.meshgrid(x, y)
    el, ep = g.ground_to_image(X, Y, g.height_on_lattice(x, y))
    el, ep = el.reshape(X.shape), ep.reshape(X.shape)
    valid = np.isfinite(layers[0])
    assert valid.sum() > 100_000
    assert np.abs(layers[0][valid] - el[valid]).max() < 1e-3 and np.abs(layers[1][valid] - ep[valid]).max() < 1e-3


@pytest.mark.parametrize("kw, match", [
    ({"max_error_px": 0}, "max_error_px"), ({"coarse_step": 0}, "coarse_step"), ({"tol_line": 0.2}, "tol_line"),
    ({"max_iter": 0}, "max_iter"),
])
def test_bad_options_name_the_key(kw, match):
    with pytest.raises(ScangeoError, match=match):
        InverseMapOptions(**kw)
    with pytest.raises(ScangeoError, match="inverse_map_method"):  # the lattice method's option is gone
        RectifyOptions.from_dict({"inverse_map_method": "lattice"})
