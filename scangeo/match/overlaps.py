"""Where strips overlap, and the cells that spread points evenly over an overlap or a strip.

A strip's footprint box comes from its image border projected onto the DTM
(:func:`scangeo.rectify.geometry.footprint_bounds`). For every pair of strips whose boxes meet, a
lattice of ground points (every ``LATTICE`` chip cells) inside the intersection is projected into
both strips; the points both see (away from the image border by the matching window's reach) form
the overlap. The overlap is cut into square cells of equal area so that ``per_overlap / per_cell``
cells cover it; each cell is later matched in one chip.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from scangeo.match.strips import MatchStrip
from scangeo.rectify.geometry import footprint_bounds

#: spacing of the overlap lattice, chip cells
LATTICE = 8


@dataclass(frozen=True)
class Cell:
    """One cell of an overlap (or of a strip, for control): a map box and the strips that see it."""

    index: int
    xmin: float
    ymin: float
    xmax: float
    ymax: float
    others: tuple[str, ...] = ()  # further strips that see the cell's centre (triple overlaps)


@dataclass(frozen=True)
class Overlap:
    """The overlap of strips ``a`` and ``b``: its area (m^2) and cells."""

    a: str
    b: str
    area: float
    cells: tuple[Cell, ...]

    @property
    def name(self) -> str:
        return f"{self.a}-{self.b}"


def boxes(strips: dict[str, MatchStrip]) -> dict[str, tuple[float, float, float, float]]:
    return {sid: footprint_bounds(s.geometry) for sid, s in strips.items()}


def _lattice(box, step: float) -> tuple[np.ndarray, np.ndarray]:
    xs = np.arange(box[0] + 0.5 * step, box[2], step)
    ys = np.arange(box[1] + 0.5 * step, box[3], step)
    X, Y = np.meshgrid(xs, ys)
    return X.ravel(), Y.ravel()


def _cells(x: np.ndarray, y: np.ndarray, step: float, count: int) -> list[tuple[float, float, float, float]]:
    """Square cells of equal area over lattice points (x, y) of spacing ``step``: about ``count``."""
    area = x.size * step * step
    size = math.sqrt(area / max(count, 1))
    x0, y0 = x.min() - 0.5 * step, y.min() - 0.5 * step
    ix = np.floor((x - x0) / size).astype(int)
    iy = np.floor((y - y0) / size).astype(int)
    out = []
    for key in sorted(set(zip(iy.tolist(), ix.tolist()))):
        inside = (iy == key[0]) & (ix == key[1])
        if inside.sum() * step * step < 0.25 * size * size:
            continue  # a sliver at the overlap's edge
        out.append((float(x[inside].min() - 0.5 * step), float(y[inside].min() - 0.5 * step),
                    float(x[inside].max() + 0.5 * step), float(y[inside].max() + 0.5 * step)))
    return out


def find_overlaps(strips: dict[str, MatchStrip], res: float, per_overlap: int, per_cell: int,
                  margin_px: float) -> tuple[list[Overlap], dict[str, tuple[float, float, float, float]]]:
    """Overlaps of every pair of strips (in project order) with their cells; and the footprint boxes."""
    footprint = boxes(strips)
    ids = list(strips)
    step = LATTICE * res
    out = []
    for i, a in enumerate(ids):
        for b in ids[i + 1:]:
            ba, bb = footprint[a], footprint[b]
            box = (max(ba[0], bb[0]), max(ba[1], bb[1]), min(ba[2], bb[2]), min(ba[3], bb[3]))
            if box[2] - box[0] < 2 * step or box[3] - box[1] < 2 * step:
                continue
            x, y = _lattice(box, step)
            both = strips[a].sees(x, y, margin_px) & strips[b].sees(x, y, margin_px)
            if both.sum() < 4:
                continue
            x, y = x[both], y[both]
            boxes_ab = _cells(x, y, step, math.ceil(per_overlap / per_cell))
            seen = _seen_by_others(strips, footprint, (a, b), boxes_ab, margin_px)
            cells = tuple(Cell(k, *c, others=tuple(s for s, v in seen.items() if v[k]))
                          for k, c in enumerate(boxes_ab))
            out.append(Overlap(a, b, float(x.size * step * step), cells))
    return out, footprint


def _seen_by_others(strips: dict[str, MatchStrip], footprint: dict, pair: tuple[str, str],
                    cells: list[tuple[float, float, float, float]], margin_px: float) -> dict[str, np.ndarray]:
    """For every strip but the pair's that sees one of the cells' centres: which centres it sees.

    Only strips whose footprint box (widened by a tenth of its size on every side: the box comes
    from border samples) holds a centre are projected, all their centres at once, so the work per
    overlap does not grow with the block.
    """
    if not cells:
        return {}
    c = np.asarray(cells, float)
    cx, cy = 0.5 * (c[:, 0] + c[:, 2]), 0.5 * (c[:, 1] + c[:, 3])
    out = {}
    for s, strip in strips.items():
        if s in pair:
            continue
        x0, y0, x1, y1 = footprint[s]
        px, py = 0.1 * (x1 - x0), 0.1 * (y1 - y0)
        near = (cx >= x0 - px) & (cx <= x1 + px) & (cy >= y0 - py) & (cy <= y1 + py)
        if not near.any():
            continue
        seen = np.zeros(cx.size, bool)
        seen[near] = strip.sees(cx[near], cy[near], margin_px)
        if seen.any():
            out[s] = seen
    return out


def strip_cells(strip: MatchStrip, box, res: float, count: int, margin_px: float) -> list[Cell]:
    """About ``count`` cells of equal area over the ground a strip sees (for control points)."""
    step = LATTICE * res
    x, y = _lattice(box, step)
    seen = strip.sees(x, y, margin_px)
    if seen.sum() < 4 or count < 1:
        return []
    return [Cell(k, *c) for k, c in enumerate(_cells(x[seen], y[seen], step, count))]
