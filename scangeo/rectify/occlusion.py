"""Occlusion: ground hidden from the sensor by steep terrain becomes nodata.

Two tests, both from the inverse map of the output grid:

1. **Fold**: where a slope faces away from the sensor more steeply than the ray, ground -> image
   reverses orientation (the Jacobian d(line, pixel)/d(row, col) changes sign). Such ground is
   seen from behind, i.e. never.
2. **Z-buffer** over the image: every output cell writes its range to the sensor into the image
   pixels its footprint covers (bounding box of the cell's image-space parallelogram), keeping the
   smallest; a cell is visible when its range is within a tolerance of the smallest range at its
   own pixel. The tolerance is the range change across two cells (plus 0.5 m), so neighbours on
   the same visible surface never hide each other; ground in the shadow of a ridge is farther by
   the distance to the ridge and is hidden.

The z-buffer covers the whole image (lines x pixels float32, 29 MB for a 10,000-line Daedalus
strip) and is filled from every tile before any tile is resampled, so occluders in a neighbouring
tile count.
"""
from __future__ import annotations

import numba
import numpy as np

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


def smaller_step(a: np.ndarray, axis: int) -> np.ndarray:
    """The smaller of |forward| and |backward| difference along ``axis``; NaN when neither exists.

    Across a discontinuity (a cliff edge) this is the step on the cell's own side.
    """
    fwd = np.abs(_shifted_difference(np.asarray(a, float), 1, axis))
    bwd = np.abs(_shifted_difference(np.asarray(a, float), -1, axis))
    return np.fmin(fwd, bwd)


def image_jacobian(line: np.ndarray, pixel: np.ndarray) -> tuple[np.ndarray, ...]:
    """d(line, pixel)/d(row, col) per cell: (dl_dr, dl_dc, dp_dr, dp_dc)."""
    return (
        finite_difference(line, 0),
        finite_difference(line, 1),
        finite_difference(pixel, 0),
        finite_difference(pixel, 1),
    )


def footprint_half_extents(line: np.ndarray, pixel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Half extents (lines, pixels) of the box around a cell's footprint in the image.

    From the smaller one-sided steps, so a cell on a cliff edge does not reach across the cliff.
    """
    half_l = 0.5 * (np.nan_to_num(smaller_step(line, 0)) + np.nan_to_num(smaller_step(line, 1)))
    half_p = 0.5 * (np.nan_to_num(smaller_step(pixel, 0)) + np.nan_to_num(smaller_step(pixel, 1)))
    return half_l, half_p


def range_tolerance(rng: np.ndarray) -> np.ndarray:
    """Range tolerance per cell, metres: the range change across two cells plus 0.5 m.

    From the smaller one-sided steps: a cell beside a cliff is compared with its own surface.
    """
    dr = np.nan_to_num(smaller_step(rng, 0), nan=0.0, posinf=0.0)
    dc = np.nan_to_num(smaller_step(rng, 1), nan=0.0, posinf=0.0)
    return (2.0 * (dr + dc) + RANGE_TOLERANCE_M).astype(np.float32)


@numba.njit(cache=True)
def _splat(line, pixel, rng, half_l, half_p, zbuf):
    lines, pixels = zbuf.shape
    n = line.size
    for i in range(n):
        l, p, r = line[i], pixel[i], rng[i]
        if not (np.isfinite(l) and np.isfinite(p) and np.isfinite(r)):
            continue
        hl = min(half_l[i], MAX_HALF_EXTENT) if np.isfinite(half_l[i]) else 0.5
        hp = min(half_p[i], MAX_HALF_EXTENT) if np.isfinite(half_p[i]) else 0.5
        # the cell's own pixel, and every pixel whose centre lies inside the footprint box
        a0 = max(min(int(np.ceil(l - hl)), int(np.floor(l + 0.5))), 0)
        a1 = min(max(int(np.floor(l + hl)), int(np.floor(l + 0.5))), lines - 1)
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
        l, p = line[i], pixel[i]
        if np.isfinite(l) and np.isfinite(p):
            a = int(np.floor(l + 0.5))
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
    line = np.asarray(line, float)
    pixel = np.asarray(pixel, float)
    reversed_all = np.ones(line.shape, bool)
    counted = np.zeros(line.shape, bool)
    for sr in (1, -1):
        for sc in (1, -1):
            dl_r, dp_r = _shifted_difference(line, sr, 0), _shifted_difference(pixel, sr, 0)
            dl_c, dp_c = _shifted_difference(line, sc, 1), _shifted_difference(pixel, sc, 1)
            det = (dl_r * dp_c - dl_c * dp_r) * (sr * sc)
            ok = np.isfinite(det)
            with np.errstate(invalid="ignore"):
                reversed_all &= ~ok | (det * orientation < 0)
            counted |= ok
    return reversed_all & counted


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
