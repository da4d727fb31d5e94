"""Builders of small strips for the sensor tests."""
from __future__ import annotations

import numpy as np
from affine import Affine

from scangeo.dtm import DTM
from scangeo.frames import MapFrame
from scangeo.grid import RasterGrid
from scangeo.sensors import StripGeometry, Whiskbroom
from scangeo.timing import LineTiming
from scangeo.trajectory import OrientationSpline

CRS = "EPSG:32633"
X0, Y0 = 500000.0, 5300000.0


def flat_world(height: float = 100.0, size: int = 400, cell: float = 25.0):
    """A map frame centred on (X0, Y0) and a flat DTM at ``height`` (orthometric = ellipsoidal)."""
    mf = MapFrame.centred_on(CRS, X0, Y0, 0.0)
    half = size * cell / 2
    grid = RasterGrid(np.full((size, size), height), Affine(cell, 0, X0 - half, 0, -cell, Y0 + half), mf.crs)
    return mf, DTM(grid, mf, "flat")


def level_spline(z: float = 2300.0, speed: float = 60.0, roll: float = 0.0, pitch: float = 0.0,
                 heading: float = 0.0, duration: float = 40.0, y_start: float = -2000.0) -> OrientationSpline:
    """A straight, level flight north through the origin of P (angles in radians)."""
    t = np.linspace(0.0, duration, int(duration * 50) + 1)
    v = np.column_stack([np.zeros_like(t), y_start + speed * t, np.full_like(t, z),
                         np.full_like(t, roll), np.full_like(t, pitch), np.full_like(t, heading)])
    return OrientationSpline.fit(t, v, 0.2)


def level_strip(sensor=None, n_lines: int = 500, **kw) -> StripGeometry:
    return StripGeometry(sensor or Whiskbroom(), level_spline(**kw), LineTiming(1.0, 25.0), n_lines)
