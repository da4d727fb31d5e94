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
    a = np.moveaxis(np.asarray(a, dtype=float), axis, 0)
    fwd = np.full(a.shape, np.nan)
    bwd = np.full(a.shape, np.nan)
    fwd[:-1] = a[1:] - a[:-1]
    bwd[1:] = a[1:] - a[:-1]
    both = np.isfinite(fwd) & np.isfinite(bwd)
    d = np.where(both, 0.5 * (fwd + bwd), np.where(np.isfinite(fwd), fwd, bwd))
    return np.moveaxis(d, 0, axis)


def image_jacobian(line: np.ndarray, pixel: np.ndarray) -> tuple[np.ndarray, ...]:
    """d(line, pixel)/d(row, col) per cell: (dl_dr, dl_dc, dp_dr, dp_dc)."""
    return (
        finite_difference(line, 0),
        finite_difference(line, 1),
        finite_difference(pixel, 0),
        finite_difference(pixel, 1),
    )


def range_tolerance(rng: np.ndarray) -> np.ndarray:
    """Range tolerance per cell, metres: the range change across two cells plus 0.5 m."""
    dr = np.abs(finite_difference(rng, 0))
    dc = np.abs(finite_difference(rng, 1))
    tol = 2.0 * (np.nan_to_num(dr, nan=0.0) + np.nan_to_num(dc, nan=0.0)) + RANGE_TOLERANCE_M
    return tol.astype(np.float32)


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
        a0 = max(int(np.floor(l - hl + 0.5)), 0)
        a1 = min(int(np.floor(l + hl + 0.5)), lines - 1)
        b0 = max(int(np.floor(p - hp + 0.5)), 0)
        b1 = min(int(np.floor(p + hp + 0.5)), pixels - 1)
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

    def add(self, line: np.ndarray, pixel: np.ndarray, rng: np.ndarray, jacobian: tuple[np.ndarray, ...]) -> None:
        """Splat the cells of a tile (ranges of hidden-by-fold cells may be inf: they do not count)."""
        dl_dr, dl_dc, dp_dr, dp_dc = jacobian
        half_l = 0.5 * (np.abs(dl_dr) + np.abs(dl_dc))
        half_p = 0.5 * (np.abs(dp_dr) + np.abs(dp_dc))
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


def folded(jacobian: tuple[np.ndarray, ...], orientation: float) -> np.ndarray:
    """Cells whose ground -> image Jacobian has the opposite sign of the strip's ``orientation``."""
    dl_dr, dl_dc, dp_dr, dp_dc = jacobian
    det = dl_dr * dp_dc - dl_dc * dp_dr
    with np.errstate(invalid="ignore"):
        return det * orientation < 0


def visible(rng: np.ndarray, tolerance: np.ndarray, nearest: np.ndarray) -> np.ndarray:
    """Cells whose range is within ``tolerance`` of the nearest range at their pixel."""
    with np.errstate(invalid="ignore"):
        return rng <= nearest + tolerance
