"""A georeferenced regular grid (affine transform + array) with bilinear sampling.

Shared by the DTM and the geoid raster. Pixel centres are at integer (col, row) positions in array
index space, i.e. ``(col + 0.5, row + 0.5)`` in rasterio's corner-based affine convention.
"""
from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np
from affine import Affine

from scangeo.threading_layer import choose_threading_layer


@dataclass(frozen=True)
class RasterGrid:
    """A single-band raster in memory.

    Parameters
    ----------
    values : (rows, cols) float64 array; NaN where the source had nodata.
    transform : affine transform from (col, row) corner coordinates to map (x, y).
    crs : the raster's CRS (anything pyproj accepts), or None.
    """

    values: np.ndarray
    transform: Affine
    crs: object = None

    @property
    def shape(self) -> tuple[int, int]:
        return (int(self.values.shape[0]), int(self.values.shape[1]))

    def map_to_index(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Fractional (col, row) of map points, pixel centres at integers."""
        inv = ~self.transform
        col = inv.a * x + inv.b * y + inv.c - 0.5
        row = inv.d * x + inv.e * y + inv.f - 0.5
        return col, row

    def index_to_map(self, col: np.ndarray, row: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Map (x, y) of fractional (col, row) indices, pixel centres at integers."""
        t = self.transform
        c = np.asarray(col, dtype=float) + 0.5
        r = np.asarray(row, dtype=float) + 0.5
        return t.a * c + t.b * r + t.c, t.d * c + t.e * r + t.f

    def sample_lattice(self, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
        """Bilinear values on the lattice of map points ``(xs[j], ys[i])``: a (len(ys), len(xs))
        array, the same as ``sample(*np.meshgrid(xs, ys))`` but compiled and parallel (about 50
        times faster on the 7.6 M cells of a 10,000-line strip's output grid)."""
        xs = np.ascontiguousarray(xs, dtype=float).ravel()
        ys = np.ascontiguousarray(ys, dtype=float).ravel()
        inv = ~self.transform
        out = np.empty((ys.size, xs.size))
        values = self.values if self.values.dtype == np.float64 else self.values.astype(np.float64)
        choose_threading_layer()
        _lattice_kernel(np.ascontiguousarray(values), inv.a, inv.b, inv.c, inv.d, inv.e, inv.f, xs, ys, out)
        return out

    def bounds(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) of the pixel centres' hull."""
        rows, cols = self.shape
        xs, ys = self.index_to_map(np.array([0, cols - 1, 0, cols - 1]), np.array([0, 0, rows - 1, rows - 1]))
        return float(xs.min()), float(ys.min()), float(xs.max()), float(ys.max())

    def sample(self, x: np.ndarray, y: np.ndarray, gradient: bool = False):
        """Bilinear value (and map-space gradient) at map points.

        Points outside the hull of pixel centres, or whose four neighbours include nodata, give NaN.

        Returns
        -------
        value : array like ``x``; with ``gradient=True`` also ``(dvalue/dx, dvalue/dy)`` in value
        units per map unit.
        """
        x = np.asarray(x, dtype=float)
        y = np.asarray(y, dtype=float)
        col, row = self.map_to_index(x, y)
        rows, cols = self.shape
        inside = (col >= 0) & (col <= cols - 1) & (row >= 0) & (row <= rows - 1)
        c0 = np.clip(np.floor(np.where(inside, col, 0)), 0, max(cols - 2, 0)).astype(np.intp)
        r0 = np.clip(np.floor(np.where(inside, row, 0)), 0, max(rows - 2, 0)).astype(np.intp)
        fc = np.where(inside, col - c0, 0.0)
        fr = np.where(inside, row - r0, 0.0)
        c1 = np.minimum(c0 + 1, cols - 1)
        r1 = np.minimum(r0 + 1, rows - 1)
        v = self.values
        v00, v01, v10, v11 = v[r0, c0], v[r0, c1], v[r1, c0], v[r1, c1]
        top = v00 + fc * (v01 - v00)
        bottom = v10 + fc * (v11 - v10)
        value = np.where(inside, top + fr * (bottom - top), np.nan)
        if not gradient:
            return value
        dv_dcol = (v01 - v00) * (1 - fr) + (v11 - v10) * fr
        dv_drow = (v10 - v00) * (1 - fc) + (v11 - v01) * fc
        inv = ~self.transform
        # d(col)/dx = inv.a, d(col)/dy = inv.b, d(row)/dx = inv.d, d(row)/dy = inv.e
        gx = np.where(inside, dv_dcol * inv.a + dv_drow * inv.d, np.nan)
        gy = np.where(inside, dv_dcol * inv.b + dv_drow * inv.e, np.nan)
        return value, (gx, gy)


@numba.njit(parallel=True, cache=True)
def _lattice_kernel(v, ia, ib, ic, id_, ie, if_, xs, ys, out):
    """``RasterGrid.sample`` (value only) on the lattice ``xs`` x ``ys``, row by row."""
    rows, cols = v.shape
    for i in numba.prange(ys.size):
        y = ys[i]
        for j in range(xs.size):
            x = xs[j]
            col = ia * x + ib * y + ic - 0.5
            row = id_ * x + ie * y + if_ - 0.5
            if not (col >= 0 and col <= cols - 1 and row >= 0 and row <= rows - 1):
                out[i, j] = np.nan
                continue
            c0 = min(max(int(np.floor(col)), 0), max(cols - 2, 0))
            r0 = min(max(int(np.floor(row)), 0), max(rows - 2, 0))
            fc = col - c0
            fr = row - r0
            c1 = min(c0 + 1, cols - 1)
            r1 = min(r0 + 1, rows - 1)
            top = v[r0, c0] + fc * (v[r0, c1] - v[r0, c0])
            bottom = v[r1, c0] + fc * (v[r1, c1] - v[r1, c0])
            out[i, j] = top + fr * (bottom - top)
