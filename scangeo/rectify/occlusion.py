"""Occlusion: ground hidden from the sensor by steep terrain becomes nodata.

Two tests, both from the inverse map of the output grid:

1. **Fold**: where a slope faces away from the sensor more steeply than the ray, ground -> image
   reverses orientation (the Jacobian d(line, pixel)/d(row, col) changes sign). Such ground is
   seen from behind, i.e. never.
2. **Z-buffer** over the image: every output cell writes its range to the sensor into the image
   pixels its footprint covers (bounding box of the cell's image-space parallelogram), keeping the
   smallest; a cell is visible when its range is within a tolerance of the smallest range at its
   own pixel. The tolerance is the range change across two cells, or across two image pixels where a
   pixel spans several cells (plus 0.5 m), so neighbours on the same visible surface never hide each
   other; ground in the shadow of a ridge is farther by the distance to the ridge and is hidden.

The z-buffer covers the whole image (lines x pixels float32, 29 MB for a 10,000-line Daedalus
strip) and is filled from every tile before any tile is resampled, so occluders in a neighbouring
tile count.

Both tests are skipped for a strip whose terrain cannot hide anything (:func:`could_hide`): ground
is hidden or folded only where the terrain rises towards the sensor more steeply than the ray,
so when the DTM's steepest slope over the output grid is below the ray's elevation at the strip's
largest view zenith angle (plus a margin), every cell is visible; on the benchmark strip of
docs/performance.md (slopes up to 52 degrees, view zenith up to about 25) that saves the fold test,
the z-buffer and the visibility test, about 0.35 CPU s of 7.
"""
from __future__ import annotations

import math
from typing import Protocol, runtime_checkable

import numba
import numpy as np

from scangeo.dtm import DTM
from scangeo.rectify.geometry import MapStripGeometry
from scangeo.threading_layer import choose_threading_layer

#: margin added to the strip's largest view zenith angle before comparing it with the terrain's
#: slope (:func:`could_hide`), radians: covers the rays between the sampled ones, the earth's
#: curvature across the strip and the tilt of the map's vertical (about 0.1 degree each)
ZENITH_MARGIN = np.radians(2.0)
#: largest half-extent of a cell footprint in image pixels that is splatted (guards degenerate maps)
MAX_HALF_EXTENT = 16.0
#: constant part of the range tolerance, metres
RANGE_TOLERANCE_M = 0.5


def finite_difference(a: np.ndarray, axis: int) -> np.ndarray:
    """Central difference along ``axis`` (per cell), one-sided where a neighbour is NaN or absent."""
    fwd = _shifted_difference(np.asarray(a, float), 1, axis)
    bwd = -_shifted_difference(np.asarray(a, float), -1, axis)
    both = np.isfinite(fwd) & np.isfinite(bwd)
    return np.where(both, 0.5 * (fwd + bwd), np.where(np.isfinite(fwd), fwd, bwd))


def image_jacobian(line: np.ndarray, pixel: np.ndarray) -> tuple[np.ndarray, ...]:
    """d(line, pixel)/d(row, col) per cell: (dl_dr, dl_dc, dp_dr, dp_dc)."""
    return (
        finite_difference(line, 0),
        finite_difference(line, 1),
        finite_difference(pixel, 0),
        finite_difference(pixel, 1),
    )


@numba.njit(inline="always", cache=True)
def _abs_or_inf(d):
    return abs(d) if np.isfinite(d) else np.inf


@numba.njit(parallel=True, cache=True)
def _step_sum(a, out):
    """Per cell: the smaller one-sided step along rows plus that along columns,
    a missing or non-finite step counting 0."""
    R, C = a.shape
    for i in numba.prange(R):
        for j in range(C):
            v = a[i, j]
            best_r = np.inf
            if i > 0:
                best_r = min(best_r, _abs_or_inf(a[i - 1, j] - v))
            if i < R - 1:
                best_r = min(best_r, _abs_or_inf(a[i + 1, j] - v))
            best_c = np.inf
            if j > 0:
                best_c = min(best_c, _abs_or_inf(a[i, j - 1] - v))
            if j < C - 1:
                best_c = min(best_c, _abs_or_inf(a[i, j + 1] - v))
            total = 0.0
            if np.isfinite(best_r):
                total += best_r
            if np.isfinite(best_c):
                total += best_c
            out[i, j] = total


def _steps(a: np.ndarray) -> np.ndarray:
    out = np.empty(np.shape(a))
    choose_threading_layer()
    _step_sum(np.ascontiguousarray(a, dtype=np.float64), out)
    return out


def footprint_half_extents(line: np.ndarray, pixel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Half extents (lines, pixels) of the box around a cell's footprint in the image.

    From the smaller one-sided steps, so a cell on a cliff edge does not reach across the cliff.
    """
    return 0.5 * _steps(line), 0.5 * _steps(pixel)


def range_tolerance(rng: np.ndarray, line: np.ndarray | None = None, pixel: np.ndarray | None = None) -> np.ndarray:
    """Range tolerance per cell, metres: the range change across two cells, or across two image pixels
    where a pixel spans more than a cell (given ``line`` and ``pixel``), plus 0.5 m.

    From the smaller one-sided steps: a cell beside a cliff is compared with its own surface. The
    z-buffer keeps the smallest range of all the cells in a pixel; where cells are smaller than the
    pixels (an output finer than the image: the coarser sensor of a platform on the finest sensor's
    grid), the cells of one pixel on a slope differ in range by the pixel's range change, which the
    tolerance must cover or visible ground is hidden. The number of cells a pixel spans is
    ``1 / min(line step, pixel step)`` per cell (at most :data:`MAX_HALF_EXTENT`; at least 1).
    """
    steps = 2.0 * _steps(rng)
    if line is not None and pixel is not None:
        image_step = np.minimum(_steps(line), _steps(pixel))
        with np.errstate(divide="ignore", invalid="ignore"):
            per_pixel = np.where(image_step > 0, 1.0 / image_step, 1.0)
        steps = steps * np.clip(per_pixel, 1.0, MAX_HALF_EXTENT)
    return (steps + RANGE_TOLERANCE_M).astype(np.float32)


@numba.njit(cache=True)
def _splat(line, pixel, rng, half_l, half_p, zbuf):
    lines, pixels = zbuf.shape
    n = line.size
    for i in range(n):
        ln, p, r = line[i], pixel[i], rng[i]
        if not (np.isfinite(ln) and np.isfinite(p) and np.isfinite(r)):
            continue
        hl = min(half_l[i], MAX_HALF_EXTENT) if np.isfinite(half_l[i]) else 0.5
        hp = min(half_p[i], MAX_HALF_EXTENT) if np.isfinite(half_p[i]) else 0.5
        # the cell's own pixel, and every pixel whose centre lies inside the footprint box
        a0 = max(min(int(np.ceil(ln - hl)), int(np.floor(ln + 0.5))), 0)
        a1 = min(max(int(np.floor(ln + hl)), int(np.floor(ln + 0.5))), lines - 1)
        b0 = max(min(int(np.ceil(p - hp)), int(np.floor(p + 0.5))), 0)
        b1 = min(max(int(np.floor(p + hp)), int(np.floor(p + 0.5))), pixels - 1)
        for a in range(a0, a1 + 1):
            for b in range(b0, b1 + 1):
                if r < zbuf[a, b]:
                    zbuf[a, b] = r


@numba.njit(cache=True)
def _lookup(line, pixel, zbuf, out):
    lines, pixels = zbuf.shape
    for i in range(line.size):
        ln, p = line[i], pixel[i]
        if np.isfinite(ln) and np.isfinite(p):
            a = int(np.floor(ln + 0.5))
            b = int(np.floor(p + 0.5))
            if 0 <= a < lines and 0 <= b < pixels:
                out[i] = zbuf[a, b]


class ZBuffer:
    """Smallest range to the sensor seen at every image pixel (metres, float32)."""

    def __init__(self, lines: int, pixels: int) -> None:
        self.values = np.full((lines, pixels), np.inf, dtype=np.float32)

    def add(self, line: np.ndarray, pixel: np.ndarray, rng: np.ndarray) -> None:
        """Splat the cells of a tile (ranges of cells hidden by a fold are inf: they do not count)."""
        half_l, half_p = footprint_half_extents(line, pixel)
        _splat(
            np.ascontiguousarray(line, dtype=np.float64).ravel(),
            np.ascontiguousarray(pixel, dtype=np.float64).ravel(),
            np.ascontiguousarray(rng, dtype=np.float64).ravel(),
            np.ascontiguousarray(half_l, dtype=np.float64).ravel(),
            np.ascontiguousarray(half_p, dtype=np.float64).ravel(),
            self.values,
        )

    def nearest(self, line: np.ndarray, pixel: np.ndarray) -> np.ndarray:
        """Smallest range at the pixels of (line, pixel); inf outside the image."""
        out = np.full(np.size(line), np.inf, dtype=np.float32)
        _lookup(
            np.ascontiguousarray(line, dtype=np.float64).ravel(),
            np.ascontiguousarray(pixel, dtype=np.float64).ravel(),
            self.values,
            out,
        )
        return out.reshape(np.shape(line))


def folded(line: np.ndarray, pixel: np.ndarray, orientation: float) -> np.ndarray:
    """Cells all of whose grid triangles map to the image with reversed orientation.

    The four triangles around a cell (cell, a neighbour in the row, a neighbour in the column) are
    tested; a cell on the edge of a cliff keeps its normal triangles on the cliff-top side and is
    not folded. Triangles with a missing corner do not count; a cell with none is not folded.
    """
    out = np.empty(np.shape(line), dtype=np.bool_)
    choose_threading_layer()
    _folded(np.ascontiguousarray(line, dtype=np.float64), np.ascontiguousarray(pixel, dtype=np.float64),
            float(orientation), out)
    return out


@numba.njit(parallel=True, cache=True)
def _folded(line, pixel, orientation, out):
    R, C = line.shape
    for i in numba.prange(R):
        for j in range(C):
            reversed_all = True
            counted = False
            for sr in (1, -1):
                for sc in (1, -1):
                    if not (0 <= i + sr < R and 0 <= j + sc < C):
                        continue
                    dl_r = line[i + sr, j] - line[i, j]
                    dp_r = pixel[i + sr, j] - pixel[i, j]
                    dl_c = line[i, j + sc] - line[i, j]
                    dp_c = pixel[i, j + sc] - pixel[i, j]
                    det = (dl_r * dp_c - dl_c * dp_r) * (sr * sc)
                    if np.isfinite(det):
                        counted = True
                        if not det * orientation < 0:
                            reversed_all = False
            out[i, j] = reversed_all and counted


def _shifted_difference(a: np.ndarray, step: int, axis: int) -> np.ndarray:
    """``a[i + step] - a[i]`` along ``axis`` (NaN where the neighbour is absent)."""
    out = np.full(a.shape, np.nan)
    src = [slice(None)] * a.ndim
    dst = [slice(None)] * a.ndim
    if step > 0:
        src[axis], dst[axis] = slice(step, None), slice(None, -step)
    else:
        src[axis], dst[axis] = slice(None, step), slice(-step, None)
    out[tuple(dst)] = a[tuple(src)] - a[tuple(dst)]
    return out


def visible(rng: np.ndarray, tolerance: np.ndarray, nearest: np.ndarray) -> np.ndarray:
    """Cells whose range is within ``tolerance`` of the nearest range at their pixel."""
    with np.errstate(invalid="ignore"):
        return rng <= nearest + tolerance



@numba.njit(cache=True)
def _largest_steps(v, r0, r1, c0, c1):  # pragma: no cover - compiled
    """Largest absolute difference of neighbours along rows and along columns in v[r0:r1, c0:c1]
    (pairs with a NaN left out)."""
    dx = 0.0
    dy = 0.0
    for i in range(r0, r1):
        for j in range(c0, c1):
            a = v[i, j]
            if j + 1 < c1:
                d = abs(v[i, j + 1] - a)
                if d > dx:  # False for NaN
                    dx = d
            if i + 1 < r1:
                d = abs(v[i + 1, j] - a)
                if d > dy:
                    dy = d
    return dx, dy


def steepest_slope(dtm: DTM, bounds: tuple[float, float, float, float], margin: float) -> float:
    """Tangent of the steepest slope of the DTM's bilinear surface within ``bounds`` (map units,
    widened by ``margin``): inside a DTM cell the gradient is a weighted mean of the cell's edge
    differences, so it is bounded by the largest difference along rows and along columns."""
    v, t = dtm.grid.values, dtm.grid.transform
    xmin, ymin, xmax, ymax = bounds
    cols, rows = dtm.grid.map_to_index(np.array([xmin - margin, xmax + margin]),
                                       np.array([ymax + margin, ymin - margin]))
    c0, c1 = max(int(np.floor(cols.min())) - 1, 0), min(int(np.ceil(cols.max())) + 2, v.shape[1])
    r0, r1 = max(int(np.floor(rows.min())) - 1, 0), min(int(np.ceil(rows.max())) + 2, v.shape[0])
    if r1 <= r0 or c1 <= c0:
        return 0.0
    dx, dy = _largest_steps(np.asarray(v, dtype=np.float64), r0, r1, c0, c1)
    return float(np.hypot(dx / abs(t.a), dy / abs(t.e)))


@runtime_checkable
class ViewedFromAbove(Protocol):
    """A strip geometry that knows its DTM and the largest view zenith angle of its rays
    (:class:`scangeo.rectify.core_geometry.CoreStripGeometry`)."""

    dtm: DTM

    def largest_view_zenith(self) -> float:
        """The largest angle between a ray and the local vertical over the strip, radians."""
        ...


def could_hide(geometry: MapStripGeometry, bounds: tuple[float, float, float, float]) -> bool:
    """Whether terrain within ``bounds`` could hide ground from the strip's sensor (or fold it):
    False only when the geometry has a DTM whose steepest slope there is below the elevation of
    every ray (the largest view zenith angle plus :data:`ZENITH_MARGIN`); True when that cannot be
    shown."""
    if not isinstance(geometry, ViewedFromAbove):
        return True
    zenith = geometry.largest_view_zenith() + ZENITH_MARGIN
    if not zenith < np.pi / 2:
        return True
    return steepest_slope(geometry.dtm, bounds, 2 * geometry.dtm.cell_size()) * math.tan(zenith) >= 1.0
