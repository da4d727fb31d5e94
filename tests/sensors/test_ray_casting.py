"""Ray casting: first intersection in front of a wall, no skipping through thin ridges, reasons."""
import numpy as np
from affine import Affine

from scangeo.dtm import DTM
from scangeo.grid import RasterGrid
from scangeo.sensors import cast_rays
from scangeo.sensors.kernels import LEAVES_DTM, NODATA, OK, UPWARD

from .helpers import X0, Y0, flat_world


def ridge_dtm(mf, height=100.0, ridge=900.0, ridge_col=230, nodata=False):
    cell = 5.0
    size = 400
    v = np.full((size, size), height)
    v[:, ridge_col] = ridge  # a one-cell-wide ridge running north-south, 800 m high
    if nodata:
        v[:, 150:160] = np.nan  # x = -250 .. -200 m
    return DTM(RasterGrid(v, Affine(cell, 0, X0 - 1000, 0, -cell, Y0 + 1000), mf.crs), mf, "ridge")


def test_oblique_rays_stop_at_a_thin_ridge_instead_of_passing_through():
    mf, _ = flat_world()
    dtm = ridge_dtm(mf)
    # the ridge's pixel centres lie at x = X0 - 1000 + 5 * 230 + 2.5 = X0 + 152.5 (map) ~ P x 152.5
    n = 200
    o = np.column_stack([np.full(n, -500.0), np.linspace(-500, 500, n), np.full(n, 1000.0)])
    d = np.column_stack([np.full(n, 0.8), np.zeros(n), np.full(n, -0.6)])  # 53 deg off nadir, eastwards
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    g, status = cast_rays(o, d, dtm)
    assert (status == OK).all()
    # without the ridge the rays would meet the plain (z ~ 100) at x = -500 + 900 / 0.75 = 700
    x_ridge = mf.map_to_project(np.array([X0 + 152.5]), np.array([Y0]), np.array([0.0]))[0, 0]
    assert np.all(np.abs(g[:, 0] - x_ridge) < 5.0)
    assert np.all(g[:, 2] > 400)


def test_reasons_for_rays_without_an_answer():
    mf, _ = flat_world()
    dtm = ridge_dtm(mf, ridge=100.0, nodata=True)
    o = np.array([[0.0, 0.0, 1000.0], [0.0, 0.0, 1000.0], [-225.0, 0.0, 1000.0], [-450.0, 0.0, 500.0],
                  [0.0, 0.0, 1000.0]])
    d = np.array([[0.0, 0.0, 1.0],        # upwards
                  [0.0, 0.99, -0.14],      # leaves the DTM sideways before meeting it
                  [0.0, 0.0, -1.0],        # straight down into the nodata strip
                  [0.9, 0.0, -0.43],       # high over the nodata strip, then down to valid ground
                  [0.0, 0.0, -1.0]])       # straight down: ok
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    g, status = cast_rays(o, d, dtm)
    assert list(status) == [UPWARD, LEAVES_DTM, NODATA, OK, OK]
    assert np.isnan(g[:3]).all() and np.isfinite(g[3:]).all()
    assert g[3, 0] > 300  # beyond the hole: -450 + 400 * 0.9 / 0.43 ~ 387 m
