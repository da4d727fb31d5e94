"""Pass 2 of the patch search: the candidates of every strip seed the search for homologous patches.

Every strip is read again in time order. Each *seed* (a pass-1 candidate of any strip, its own
included, so that all members of a patch are fitted on the same footprint) whose box lies in the
strip's extent collects the strip's returns inside its box; a seed is closed once the strip has
moved on (no return added for longer than the strip needs to cross a box), its plane fitted with
data snooping and accepted as the strip's member of the seed's patch when it meets the patch
criteria and is *compatible* with the seed: normals within ``max_angle_deg`` and the centroid
within ``max_offset`` of the seed's plane. Only the returns of open seeds are held.

:func:`members` then keeps the seeds with members in two or more strips (a patch without a
partner ties nothing); :func:`scangeo.lidar.patches.homologous` thins them as it thins grid cells:
per ``thin_cell`` square, one patch per exposition class (flat, or sloped towards one of eight
directions), the one in most strips and then the most precise. Patches of different exposition tie
the strips in all three coordinates, as points do.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numba
import numpy as np

from scangeo.lidar.patches import PatchOptions, StripPatches
from scangeo.lidar.plane_kernel import fit_planes
from scangeo.lidar.planes import Planes
from scangeo.lidar.rowbuffer import Candidates, accepted, concat_planes


@dataclass
class Seeds:
    """All strips' candidates: box (centre, axes, half), plane (centroid, normal), owner strip and index."""

    centre: np.ndarray
    axes: np.ndarray
    half: np.ndarray
    centroid: np.ndarray
    normal: np.ndarray
    sigma: np.ndarray
    count: np.ndarray
    owner: np.ndarray  # (m,) strip index in ``strips``
    strips: list[str]

    @classmethod
    def of(cls, found: dict[str, Candidates]) -> Seeds:
        strips = list(found)
        c = list(found.values())
        cat = np.concatenate
        return cls(
            cat([f.centre for f in c]) if c else np.zeros((0, 2)),
            cat([f.axes for f in c]) if c else np.zeros((0, 2, 2)),
            cat([f.half for f in c]) if c else np.zeros((0, 2)),
            cat([f.planes.centroid for f in c]) if c else np.zeros((0, 3)),
            cat([f.planes.normal for f in c]) if c else np.zeros((0, 3)),
            cat([f.planes.sigma for f in c]) if c else np.zeros(0),
            cat([f.planes.count for f in c]) if c else np.zeros(0),
            cat([np.full(f.size, i) for i, f in enumerate(c)]) if c else np.zeros(0, int),
            strips,
        )

    @property
    def size(self) -> int:
        return int(self.centre.shape[0])

    def inside(self, bounds: tuple[float, float, float, float]) -> np.ndarray:
        """Indices of the seeds whose box reaches into ``bounds`` (x0, y0, x1, y1)."""
        r = np.linalg.norm(self.half, axis=1)
        x0, y0, x1, y1 = bounds
        c = self.centre
        return np.flatnonzero((c[:, 0] + r >= x0) & (c[:, 0] - r <= x1) & (c[:, 1] + r >= y0) & (c[:, 1] - r <= y1))


class SeedIndex:
    """Which seeds' boxes contain a point: every seed is registered in the cells of a grid (half a
    box wide, wider when the strip's extent would need more than ``MAX_CELLS``) that its
    axis-aligned bounding rectangle touches; a point looks in its own cell only (a dense table)."""

    MAX_CELLS = 4_000_000

    def __init__(self, seeds: Seeds, rows: np.ndarray) -> None:
        self.rows = rows
        self.centre, self.axes, self.half = seeds.centre[rows], seeds.axes[rows], seeds.half[rows]
        bbox = np.abs(self.axes[:, 0, :]) * self.half[:, [0]] + np.abs(self.axes[:, 1, :]) * self.half[:, [1]]
        self.reach = float(np.max(np.linalg.norm(bbox, axis=1))) if rows.size else 0.0
        if rows.size == 0:
            self.cell, self.origin, self.shape = 1.0, np.zeros(2), (1, 1)
            self.start, self.owner = np.zeros(2, np.int64), np.zeros(0, np.int64)
            return
        lo_xy, hi_xy = (self.centre - bbox).min(axis=0), (self.centre + bbox).max(axis=0)
        extent = np.maximum(hi_xy - lo_xy, 1e-6)
        self.cell = max(float(np.median(bbox)), float(np.sqrt(extent[0] * extent[1] / self.MAX_CELLS)), 1e-6)
        self.origin = lo_xy
        lo = np.floor((self.centre - bbox - lo_xy) / self.cell).astype(np.int64)
        hi = np.floor((self.centre + bbox - lo_xy) / self.cell).astype(np.int64)
        self.shape = (int(hi[:, 0].max()) + 1, int(hi[:, 1].max()) + 1)
        nx, ny = hi[:, 0] - lo[:, 0] + 1, hi[:, 1] - lo[:, 1] + 1
        owner = np.repeat(np.arange(rows.size), nx * ny)
        k = np.arange(owner.size) - np.repeat(np.cumsum(nx * ny) - nx * ny, nx * ny)
        key = (lo[owner, 0] + k % nx[owner]) * self.shape[1] + (lo[owner, 1] + k // nx[owner])
        order = np.argsort(key, kind="stable")
        self.owner = owner[order]
        self.start = np.r_[0, np.cumsum(np.bincount(key, minlength=self.shape[0] * self.shape[1]))]

    def lookup(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Pairs (point index, local seed index) of every point inside a seed's box."""
        return _pairs(np.ascontiguousarray(xy, float), self.origin[0], self.origin[1], self.cell,
                      self.shape[0], self.shape[1], self.start, self.owner, self.centre, self.axes, self.half)


@numba.njit(cache=True)
def _pairs(xy, x0, y0, cell, nx, ny, start, owner, centre, axes, half):
    """(point, seed) for every point and every seed of its cell whose box holds it (two passes: count, fill)."""
    out_p = np.empty(0, np.int64)
    out_s = np.empty(0, np.int64)
    for fill in range(2):
        n = 0
        for i in range(xy.shape[0]):
            ix = int(np.floor((xy[i, 0] - x0) / cell))
            iy = int(np.floor((xy[i, 1] - y0) / cell))
            if ix < 0 or iy < 0 or ix >= nx or iy >= ny:
                continue
            c = ix * ny + iy
            for j in range(start[c], start[c + 1]):
                s = owner[j]
                dx, dy = xy[i, 0] - centre[s, 0], xy[i, 1] - centre[s, 1]
                if abs(dx * axes[s, 0, 0] + dy * axes[s, 0, 1]) > half[s, 0]:
                    continue
                if abs(dx * axes[s, 1, 0] + dy * axes[s, 1, 1]) > half[s, 1]:
                    continue
                if fill == 1:
                    out_p[n] = i
                    out_s[n] = s
                n += 1
        if fill == 0:
            out_p = np.empty(n, np.int64)
            out_s = np.empty(n, np.int64)
    return out_p, out_s


@dataclass
class SeedFits:
    """One strip's members: the seed (index into :class:`Seeds`) and the strip's plane over its box."""

    strip: str
    seed: np.ndarray
    planes: Planes


def fit_seeds(
    strip: str,
    chunks: Iterable[tuple[np.ndarray, np.ndarray, np.ndarray]],
    seeds: Seeds,
    rows: np.ndarray,
    options: PatchOptions,
    prior_sigma: float,
    speed: float,
) -> SeedFits:
    """Pass 2 of one strip: the strip's plane in every seed box of ``rows`` it covers, compatible ones."""
    index = SeedIndex(seeds, rows)
    m = rows.size
    crossing = 2.0 * index.reach / max(speed, 1.0) + 1.0  # s: a strip passes a box within this time
    buf_xyz, buf_t, buf_seed = np.zeros((0, 3)), np.zeros(0), np.zeros(0, np.int64)
    last = np.full(m, -np.inf)
    closed = np.zeros(m, bool)
    parts_seed, parts_planes = [], []

    def close(which: np.ndarray) -> None:
        nonlocal buf_xyz, buf_t, buf_seed
        sel = which[buf_seed]
        if not sel.any():
            return
        ids = np.flatnonzero(which & np.isfinite(last))
        remap = np.zeros(m, np.int64)
        remap[ids] = np.arange(ids.size)
        g = remap[buf_seed[sel]]
        planes = fit_planes(buf_xyz[sel], g, ids.size, prior_sigma, buf_t[sel], options.critical_value)
        ok = accepted(planes, options) & _compatible(planes, seeds, rows[ids], options)
        parts_seed.append(rows[ids[ok]])
        parts_planes.append(planes.take(ok))
        closed[ids] = True
        buf_xyz, buf_t, buf_seed = buf_xyz[~sel], buf_t[~sel], buf_seed[~sel]

    for xyz, t, _ in chunks:
        point, seed = index.lookup(xyz[:, :2])
        keep = ~closed[seed]
        point, seed = point[keep], seed[keep]
        buf_xyz = np.concatenate([buf_xyz, xyz[point]])
        buf_t = np.concatenate([buf_t, t[point]])
        buf_seed = np.concatenate([buf_seed, seed])
        np.maximum.at(last, seed, t[point])
        done = np.isfinite(last) & ~closed & (last < t[-1] - crossing)
        close(done)
    close(np.isfinite(last) & ~closed)
    if parts_seed:
        return SeedFits(strip, np.concatenate(parts_seed), concat_planes(parts_planes))
    return SeedFits(strip, np.zeros(0, np.int64), concat_planes([]))


def _compatible(planes: Planes, seeds: Seeds, rows: np.ndarray, options: PatchOptions) -> np.ndarray:
    n0 = seeds.normal[rows]
    angle_ok = np.einsum("ij,ij->i", planes.normal, n0) >= np.cos(np.radians(options.max_angle_deg))
    offset = np.abs(np.einsum("ij,ij->i", planes.centroid - seeds.centroid[rows], n0))
    return angle_ok & (offset <= options.max_offset)


def members(fits: dict[str, SeedFits], seeds: Seeds) -> dict[str, StripPatches]:
    """Per strip its members of the seeds accepted in two or more strips (``cells`` = seed index);
    :func:`scangeo.lidar.patches.homologous` turns them into thinned tie patches."""
    strips = list(fits)
    seed = np.concatenate([fits[s].seed for s in strips]) if strips else np.zeros(0, np.int64)
    tied = np.bincount(seed, minlength=seeds.size) >= 2
    out = {}
    for s in strips:
        sel = np.flatnonzero(tied[fits[s].seed])
        out[s] = StripPatches(s, fits[s].seed[sel], fits[s].planes.take(sel))
    return out
