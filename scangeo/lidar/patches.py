"""Patch finding (Kager 2003, section 2): planar patches in each strip, homologous patches across strips.

Each strip's returns are binned into square cells of ``size`` metres on one grid common to all strips
(in the map CRS); every cell is fitted by a plane with data snooping (``planes.py``) and accepted as a
patch when it keeps at least ``min_points`` returns, its sigma is below ``max_sigma`` and snooping
removed at most ``max_rejected`` of its returns (vegetation, edges and ridges fail). Homologous
patches are the same cell accepted in two or more strips whose normals agree within ``max_angle_deg``
and whose planes lie within ``max_offset`` of each other along the normal. Patches are then thinned to
one per exposition class (flat, or roof faces looking to one of 8 directions) per ``thin_cell`` square:
patches of different exposition tie the strips like points do, and the adjustment stays small.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from scangeo.lidar.lasio import StripCloud
from scangeo.lidar.plane_kernel import fit_planes
from scangeo.lidar.planes import Planes

OFFSET = 1 << 30


@dataclass(frozen=True)
class PatchOptions:
    size: float = 10.0
    min_points: int = 13
    max_sigma: float = 0.05
    max_rejected: float = 0.2
    critical_value: float = 3.29
    max_angle_deg: float = 5.0
    max_offset: float = 1.0
    thin_cell: float = 40.0
    flat_deg: float = 8.0
    max_slope_deg: float = 60.0


@dataclass
class StripPatches:
    """Accepted planar cells of one strip: cell keys (ix, iy packed) and planes in map coordinates."""

    strip: str
    cells: np.ndarray
    planes: Planes


def cell_keys(xy: np.ndarray, size: float) -> np.ndarray:
    ix = np.floor(xy[:, 0] / size).astype(np.int64) + OFFSET
    iy = np.floor(xy[:, 1] / size).astype(np.int64) + OFFSET
    return ix * (2 * OFFSET) + iy


def cell_centres(keys: np.ndarray, size: float) -> np.ndarray:
    ix, iy = keys // (2 * OFFSET) - OFFSET, keys % (2 * OFFSET) - OFFSET
    return np.column_stack([(ix + 0.5) * size, (iy + 0.5) * size])


def fit_groups(
    xyz: np.ndarray,
    t: np.ndarray,
    group: np.ndarray,
    m: int,
    reference: np.ndarray,
    options: PatchOptions,
    prior_sigma: float,
) -> tuple[Planes, np.ndarray]:
    """Planes of ``m`` groups (points relative to ``reference[group]``) and which are accepted."""
    rel = xyz - reference[group]
    planes = fit_planes(rel, group, m, prior_sigma, t, options.critical_value)
    planes.centroid = planes.centroid + reference
    total = planes.count + planes.rejected
    ok = (
        (planes.count >= options.min_points)
        & (planes.sigma < options.max_sigma)
        & (planes.rejected <= options.max_rejected * total)
    )
    return planes, ok


def fit_cells(
    xyz: np.ndarray, t: np.ndarray, keys: np.ndarray, options: PatchOptions, prior_sigma: float
) -> tuple[np.ndarray, Planes]:
    """The accepted planar cells among returns ``xyz`` (n, 3) with times ``t`` in the grid cells ``keys``
    (:func:`cell_keys`): their keys (sorted) and planes."""
    uniq, inv, counts = np.unique(keys, return_inverse=True, return_counts=True)
    cand = counts >= options.min_points
    remap = np.full(uniq.size, -1, np.int64)
    remap[cand] = np.arange(int(cand.sum()))
    g = remap[inv.ravel()]
    sel = g >= 0
    uniq = uniq[cand]
    ref = np.column_stack([cell_centres(uniq, options.size), np.zeros(uniq.size)])
    z = xyz[sel, 2]
    ref[:, 2] = np.bincount(g[sel], z, uniq.size) / np.maximum(np.bincount(g[sel], minlength=uniq.size), 1)
    planes, ok = fit_groups(xyz[sel], t[sel], g[sel], uniq.size, ref, options, prior_sigma)
    return uniq[ok], planes.take(ok)


def find_strip_patches(cloud: StripCloud, options: PatchOptions, prior_sigma: float) -> StripPatches:
    """The accepted planar cells of a strip held in memory (a stream of chunks:
    :class:`scangeo.lidar.cells.GridCellStream`)."""
    cells, planes = fit_cells(cloud.xyz, cloud.time, cell_keys(cloud.xyz, options.size), options, prior_sigma)
    return StripPatches(cloud.id, cells, planes)


def grid_name(cell: int) -> str:
    ix, iy = cell // (2 * OFFSET) - OFFSET, cell % (2 * OFFSET) - OFFSET
    return f"t{ix}_{iy}"


def exposition(normal: np.ndarray, flat_deg: float) -> np.ndarray:
    """0 for flat patches, 1..8 for the direction (N, NE, E, ...) a sloped patch faces."""
    tilt = np.degrees(np.arccos(np.clip(normal[:, 2], -1, 1)))
    aspect = np.degrees(np.arctan2(normal[:, 0], normal[:, 1])) % 360.0
    return np.where(tilt < flat_deg, 0, 1 + (np.floor((aspect + 22.5) / 45.0).astype(int) % 8))


@dataclass
class TiePatch:
    """A tie patch: its id, exposition class and members ``[(strip, index into that strip's patches)]``."""

    id: str
    cls: int
    members: list[tuple[str, int]]


def homologous(
    found: dict[str, StripPatches], options: PatchOptions, thin: bool = True, name: Callable[[int], str] | None = None
) -> list[TiePatch]:
    """Tie patches: the same cell accepted in 2+ strips with compatible planes, thinned; ``name`` of a
    cell key (default ``t{ix}_{iy}`` of a grid cell)."""
    strips = list(found)
    cells = np.concatenate([found[s].cells for s in strips]) if strips else np.zeros(0, np.int64)
    owner = (
        np.concatenate([np.full(found[s].cells.size, i) for i, s in enumerate(strips)]) if strips else np.zeros(0, int)
    )
    index = np.concatenate([np.arange(found[s].cells.size) for s in strips]) if strips else np.zeros(0, int)
    order = np.argsort(cells, kind="stable")
    cells, owner, index = cells[order], owner[order], index[order]
    starts = np.flatnonzero(np.r_[True, cells[1:] != cells[:-1]])
    ends = np.r_[starts[1:], cells.size]
    multi = np.flatnonzero(ends - starts >= 2)
    cos_max = np.cos(np.radians(options.max_angle_deg))
    candidates = []
    for k in multi:
        rows = range(starts[k], ends[k])
        planes = [found[strips[owner[r]]].planes for r in rows]
        idx = [int(index[r]) for r in rows]
        weight = [p.sigma[i] / np.sqrt(p.count[i]) for p, i in zip(planes, idx)]
        ref = int(np.argmin(weight))
        n_ref, c_ref = planes[ref].normal[idx[ref]], planes[ref].centroid[idx[ref]]
        members = []
        for j, (p, i) in enumerate(zip(planes, idx)):
            if p.normal[i] @ n_ref >= cos_max and abs(n_ref @ (p.centroid[i] - c_ref)) <= options.max_offset:
                members.append((strips[owner[starts[k] + j]], i))
        if len(members) >= 2:
            candidates.append((int(cells[starts[k]]), members, n_ref, c_ref, weight[ref]))
    if not candidates:
        return []
    normals = np.array([c[2] for c in candidates])
    classes = exposition(normals, options.flat_deg)
    out = []
    if thin:
        centres = np.array([c[3][:2] for c in candidates])
        key = cell_keys(centres, options.thin_cell) * 16 + classes
        score = np.array([-len(c[1]) + 1e-3 * min(c[4] / 0.01, 0.99) for c in candidates])
        order = np.lexsort((score, key))
        first = np.r_[True, key[order][1:] != key[order][:-1]]
        chosen = np.sort(order[first])
    else:
        chosen = np.arange(len(candidates))
    for k in chosen:
        cell, members, *_ = candidates[k]
        out.append(TiePatch((name or grid_name)(cell), int(classes[k]), members))
    return out


def box_members(
    xyz: np.ndarray, centres: np.ndarray, axes: np.ndarray, half: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Which returns lie in which given box (centre, unit axes (2, 2), half extents): box index and row
    of every (box, return) pair."""
    groups, rows = [], []
    for k in range(centres.shape[0]):
        r = float(np.hypot(*half[k]))
        lo, hi = centres[k] - r, centres[k] + r
        box = np.flatnonzero(np.all((xyz[:, :2] >= lo) & (xyz[:, :2] <= hi), axis=1))
        local = (xyz[box, :2] - centres[k]) @ axes[k].T
        inside = box[np.all(np.abs(local) <= half[k], axis=1)]
        groups.append(np.full(inside.size, k))
        rows.append(inside)
    if not rows:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    return np.concatenate(groups).astype(np.int64), np.concatenate(rows)
