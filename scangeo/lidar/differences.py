"""Strip differences: height differences of overlapping strips on a grid, and patch discrepancies.

For every grid cell that is planar (``patches.find_strip_patches``) in two or more strips, each pair
of strips gives ``dz`` = height of the first strip's plane minus the second's at the cell centre
(strips in project order). Before/after comparisons use the cells and pairs present in both states.
The rms of ``dz`` is the block's overlap discrepancy; on sloped cells (roofs) it also shows
planimetric errors (times the slope), as strip differences do.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from scangeo.lidar.patches import StripPatches, cell_centres


@dataclass
class Differences:
    """One row per (cell, strip pair)."""

    cell: np.ndarray
    a: np.ndarray
    b: np.ndarray
    dz: np.ndarray
    flat: np.ndarray
    size: float

    def key(self) -> np.ndarray:
        return np.array([f"{c}:{a}:{b}" for c, a, b in zip(self.cell, self.a, self.b)])

    def take(self, sel) -> Differences:
        return Differences(self.cell[sel], self.a[sel], self.b[sel], self.dz[sel], self.flat[sel], self.size)

    def rms(self, flat_only: bool = False) -> float:
        d = self.dz[self.flat] if flat_only else self.dz
        return float(np.sqrt(np.mean(d**2))) if d.size else float("nan")

    def per_pair(self) -> dict[str, dict]:
        """Per strip pair (sorted), its cells, rms and mean of ``dz``."""
        if not self.dz.size:
            return {}
        pairs, code = np.unique(np.stack([self.a.astype(str), self.b.astype(str)], axis=1), axis=0,
                                return_inverse=True)
        code = code.reshape(-1)
        order = np.argsort(code, kind="stable")  # each pair's rows in their order
        ends = np.cumsum(np.bincount(code, minlength=len(pairs)))
        out = {}
        for (a, b), stop, count in zip(pairs, ends, np.bincount(code, minlength=len(pairs))):
            d = self.dz[order[stop - count:stop]]
            out[f"{a}-{b}"] = {"cells": int(count), "rms": float(np.sqrt(np.mean(d**2))), "mean": float(np.mean(d))}
        return out


def _height(found: StripPatches, rows: np.ndarray, xy: np.ndarray) -> np.ndarray:
    p = found.planes
    n, c = p.normal[rows], p.centroid[rows]
    return c[:, 2] - (n[:, 0] * (xy[:, 0] - c[:, 0]) + n[:, 1] * (xy[:, 1] - c[:, 1])) / n[:, 2]


def strip_differences(
    found: dict[str, StripPatches], size: float, flat_deg: float = 8.0, max_angle_deg: float = 5.0, max_dz: float = 1.0
) -> Differences:
    """Differences of every pair of strips on every cell planar in both, with normals within
    ``max_angle_deg`` and ``|dz| <= max_dz`` (a cell where the strips see different surfaces, e.g. a
    roof and the ground beside it through an occlusion, is not a strip difference)."""
    strips = list(found)
    cells, a_, b_, dz, flat = [], [], [], [], []
    lookup = {s: dict(zip(found[s].cells.tolist(), range(found[s].cells.size))) for s in strips}
    for i, sa in enumerate(strips):
        for sb in strips[i + 1 :]:
            common = np.intersect1d(found[sa].cells, found[sb].cells)
            if not common.size:
                continue
            ra = np.array([lookup[sa][c] for c in common.tolist()])
            rb = np.array([lookup[sb][c] for c in common.tolist()])
            xy = cell_centres(common, size)
            d = _height(found[sa], ra, xy) - _height(found[sb], rb, xy)
            na, nb = found[sa].planes.normal[ra], found[sb].planes.normal[rb]
            ok = (np.einsum("ij,ij->i", na, nb) >= np.cos(np.radians(max_angle_deg))) & (np.abs(d) <= max_dz)
            cells.append(common[ok])
            a_.append(np.full(int(ok.sum()), sa, object))
            b_.append(np.full(int(ok.sum()), sb, object))
            dz.append(d[ok])
            flat.append((np.minimum(na[:, 2], nb[:, 2]) > np.cos(np.radians(flat_deg)))[ok])
    if not cells:
        e = np.zeros(0)
        return Differences(e.astype(np.int64), e.astype(object), e.astype(object), e, e.astype(bool), size)
    return Differences(
        np.concatenate(cells), np.concatenate(a_), np.concatenate(b_), np.concatenate(dz), np.concatenate(flat), size
    )


def _codes(*diffs: Differences) -> list[np.ndarray]:
    """One integer per row (cell, first strip, second strip), the same for the same row of any of ``diffs``."""
    pairs = [(d.a.astype(str), d.b.astype(str)) for d in diffs]
    strips = np.unique(np.concatenate([x for pair in pairs for x in pair]))
    cells = np.unique(np.concatenate([d.cell for d in diffs]))   # cell keys reach 2^62: numbered here
    n = max(strips.size, 1)
    return [(np.searchsorted(cells, d.cell).astype(np.int64) * n + np.searchsorted(strips, a)) * n
            + np.searchsorted(strips, b) for d, (a, b) in zip(diffs, pairs)]


def common_rows(before: Differences, after: Differences) -> tuple[Differences, Differences]:
    """The rows (cell and pair) present in both, in the same order: that of their keys' text
    (:meth:`Differences.key`), sorted once for the common rows (matched by integer codes: the keys' text
    compared and sorted five times over was 11 CPU s per variant on the montafon block)."""
    kb, ka = _codes(before, after)
    _, ib, ia = np.intersect1d(kb, ka, assume_unique=True, return_indices=True)
    order = np.argsort(before.take(ib).key())
    return before.take(ib[order]), after.take(ia[order])


def mosaic(diffs: Differences) -> tuple[np.ndarray, tuple[float, float], int, int]:
    """A raster (rows north first) of dz per cell (the first pair of a cell), its upper-left corner."""
    xy = cell_centres(diffs.cell, diffs.size)
    s = diffs.size
    x0, y1 = xy[:, 0].min() - s / 2, xy[:, 1].max() + s / 2
    col = np.round((xy[:, 0] - s / 2 - x0) / s).astype(int)
    row = np.round((y1 - xy[:, 1] - s / 2) / s).astype(int)
    grid = np.full((row.max() + 1, col.max() + 1), np.nan, np.float32)
    order = np.arange(diffs.dz.size)[::-1]  # the first pair wins
    grid[row[order], col[order]] = diffs.dz[order]
    return grid, (x0, y1), row.max() + 1, col.max() + 1
