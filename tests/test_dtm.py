"""DTM sampling: bilinear heights and slopes, nodata and coverage, reading and warping rasters."""
import numpy as np
import pytest
import rasterio
from affine import Affine

from scangeo.dtm import DTM, INSIDE, NODATA, OUTSIDE
from scangeo.errors import DTMError
from scangeo.frames import MapFrame
from scangeo.grid import RasterGrid
from scangeo.localmap import LocalPolynomialMap

from .conftest import shared_file

X0, Y0 = 500000.0, 5300000.0


def plane_dtm(mf, nodata_at=None):
    rows, cols, cell = 200, 300, 10.0
    t = Affine(cell, 0, X0 - 1500, 0, -cell, Y0 + 1000)
    c, r = np.meshgrid(np.arange(cols), np.arange(rows))
    x, y = t * (c + 0.5, r + 0.5)
    z = 300.0 + 0.05 * (x - X0) - 0.02 * (y - Y0)
    if nodata_at is not None:
        z[nodata_at] = np.nan
    return DTM(RasterGrid(z, t, mf.crs), mf, "plane")


def test_bilinear_is_exact_on_a_plane_and_slope_is_its_gradient():
    mf = MapFrame.centred_on("EPSG:32633", X0, Y0, 0.0)
    dtm = plane_dtm(mf)
    rng = np.random.default_rng(0)
    x = X0 + rng.uniform(-1400, 1400, 500)
    y = Y0 + rng.uniform(-900, 900, 500)
    assert np.allclose(dtm.height_at_map(x, y), 300 + 0.05 * (x - X0) - 0.02 * (y - Y0), atol=1e-9)
    gx, gy = dtm.slope_at_map(x, y)
    assert np.allclose(gx, 0.05) and np.allclose(gy, -0.02)


def test_nodata_and_outside_give_nan_with_a_reason():
    mf = MapFrame.centred_on("EPSG:32633", X0, Y0, 0.0)
    dtm = plane_dtm(mf, nodata_at=(slice(100, 110), slice(150, 160)))
    x = np.array([X0, X0 + 5000, X0 + 50])  # inside, outside, in the hole (col 155, row 100..)
    y = np.array([Y0 + 200, Y0, Y0 - 45])
    h = dtm.height_at_map(x, y)
    assert np.isfinite(h[0]) and np.isnan(h[1]) and np.isnan(h[2])
    assert list(dtm.reason_at_map(x, y)) == [INSIDE, OUTSIDE, NODATA]


def test_height_condition_gradient_matches_finite_differences():
    mf = MapFrame.centred_on("EPSG:32633", X0, Y0, 0.0)
    dtm = plane_dtm(mf)
    p = mf.map_to_project(np.array([X0 + 300, X0 - 700]), np.array([Y0 + 100, Y0 - 300]), np.array([320.0, 250.0]))
    r, grad = dtm.height_condition(p)
    for k in range(3):
        d = np.zeros(3)
        d[k] = 0.5
        num = (dtm.height_condition(p + d)[0] - dtm.height_condition(p - d)[0]) / 1.0
        assert np.allclose(grad[:, k], num, atol=1e-6)
    # near the origin P is ENU: d(H - DTM)/dz ~ 1, d/dx ~ -0.05, d/dy ~ +0.02
    assert grad[0] == pytest.approx([-0.05, 0.02, 1.0], abs=2e-3)


def test_local_polynomial_reproduces_the_exact_conversion_below_tolerance():
    mf = MapFrame.centred_on("EPSG:31256", 0.0, 340000.0, 0.0)
    box = np.array([[-15000, 15000], [-20000, 20000], [-100, 4000.0]])

    def exact(p):
        return np.column_stack(mf.project_to_map(p))

    local = LocalPolynomialMap.fit(exact, box)
    assert local.max_error < 2e-4
    rng = np.random.default_rng(4)
    pts = np.column_stack([rng.uniform(*box[0], 3000), rng.uniform(*box[1], 3000), rng.uniform(*box[2], 3000)])
    assert np.abs(local(pts) - exact(pts)).max() < 2e-4


def test_srtm_is_read_and_warped_into_the_map_crs():
    path = shared_file("dtm/N44E005.hgt")
    mf = MapFrame.centred_on("EPSG:32631", 680000.0, 4894000.0, 0.0)
    dtm = DTM.open(path, mf)
    # Mont Ventoux summit (44.1739 N, 5.2789 E): 1,909 m; SRTM 3" gives about 1,900 m
    x, y = mf.geodetic_to_map_2d(np.radians([44.1739]), np.radians([5.2789]))
    assert dtm.height_at_map(x, y)[0] == pytest.approx(1905, abs=20)
    with rasterio.open(path) as src:
        raw = src.read(1).astype(float)
    assert dtm.h_max == pytest.approx(raw.max(), abs=30)


def test_unreadable_dtm_is_a_clear_error(tmp_path):
    bad = tmp_path / "dtm.tif"
    bad.write_text("not a raster")
    mf = MapFrame.centred_on("EPSG:32633", X0, Y0, 0.0)
    with pytest.raises(DTMError, match="dtm.tif"):
        DTM.open(bad, mf)
