"""The inverse map of a tile: (line, pixel) for every output cell, exact on an adaptive lattice.

Ground -> image is smooth across track and in height, but along track it follows the attitude,
which turbulence shakes at periods of a few seconds (tens of lines). The map is therefore
interpolated on a lattice aligned with the flight: ``u`` along track, ``v`` across, in units of
the cell size. Blocks of the lattice are refined anisotropically: a block whose error grows along
``u`` is halved along ``u`` only (down to one cell: nodes on every line's worth of ground), one
whose error grows across track along ``v`` only. Heights enter through levels shared by the
whole tile (``H_k = H_0 + k dH``, ``dH`` from the curvature in height measured over the tile); a
cell's (line, pixel) is bilinear in (u, v) on the two levels bracketing its DTM height and linear
between them. Nodes (lattice point, level) are solved exactly once and shared between blocks.

Error control: each block is compared with exact solutions at check points (a grid of fractions
of the block including its own first row and column, at the middle of the height segment holding
the DTM height there: the worst height). A block whose error exceeds half the tolerance is split,
down to blocks of a few cells, whose cells are then solved exactly. Blocks across an image edge
are split (their checks beyond the edge say nothing); blocks entirely beyond one image edge are
left unseen. Finally a random sample of cells is compared with exact solutions, and its largest
error is what :class:`InverseMapStats` reports as achieved.
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from typing import Callable

import numba
import numpy as np

from scangeo.errors import ScangeoError

#: ``ground_to_image(x, y, H) -> (line, pixel)``: map points to fractional image coordinates.
GroundToImage = Callable[[np.ndarray, np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]
#: ``height(x, y) -> H``: DTM heights at map points.
HeightFunction = Callable[[np.ndarray, np.ndarray], np.ndarray]

#: image pixels beyond an edge by which a point counts as outside the image
OUTSIDE_MARGIN_PX = 2.0
#: most height segments in a tile
MAX_SEGMENTS = 256
#: along-track checks of a block: every lattice line up to this many
DENSE_U = 32
#: blocks across an image edge (or with unseen corners) of at most this many cells are solved per cell
EDGE_EXACT_CELLS = 64


@dataclass(frozen=True)
class InverseMapOptions:
    """Accuracy and block sizes of the interpolated inverse map.

    Parameters
    ----------
    max_error_px : tolerated interpolation error, image pixels (largest of |d line|, |d pixel|).
        Blocks are accepted when their check points are within half of it.
    initial_block : size of the first blocks, cells (a power of two).
    exact_cells : blocks of at most this many lattice cells that still fail are solved per cell.
    validation_samples : cells per tile compared with exact solutions after the fact.
    method : ``refine`` (default; :mod:`scangeo.rectify.refined_map`: interpolated starts, then
        Newton at every cell: exact everywhere, and faster) or ``lattice`` (interpolation under
        error control, this module), used also for geometries that cannot refine.
    coarse_step : ``refine``: lattice spacing of the exact starts, cells.
    tol_line : ``refine``: Newton's last step below this many lines ends it (the error left is
        of the order of its square: about 4e-6 lines for 0.01 on a turbulent strip).
    max_step_lines, max_iter : ``refine``: a longer step or more evaluations hand the cell to the
        bracketed ground -> image.
    """

    max_error_px: float = 0.05
    initial_block: int = 32
    exact_cells: int = 4
    validation_samples: int = 256
    method: str = "refine"
    coarse_step: int = 4
    tol_line: float = 1e-2
    max_step_lines: float = 64.0
    max_iter: int = 8

    def __post_init__(self) -> None:
        if not self.max_error_px > 0:
            raise ScangeoError(f"inverse map: max_error_px must be positive, got {self.max_error_px}")
        v = self.initial_block
        if v < 2 or v & (v - 1):
            raise ScangeoError(f"inverse map: initial_block must be a power of two >= 2, got {v}")
        if self.exact_cells < 1:
            raise ScangeoError(f"inverse map: exact_cells must be at least 1, got {self.exact_cells}")
        if self.method not in ("refine", "lattice"):
            raise ScangeoError(f"inverse map: method must be 'refine' or 'lattice', got {self.method!r}")
        if self.coarse_step < 1:
            raise ScangeoError(f"inverse map: coarse_step must be at least 1, got {self.coarse_step}")
        if not (0 < self.tol_line <= min(0.1, self.max_error_px)):
            raise ScangeoError(f"inverse map: tol_line must be in (0, min(0.1, max_error_px)], got {self.tol_line}")
        if not (self.max_step_lines > 0 and self.max_iter >= 1):
            raise ScangeoError("inverse map: max_step_lines must be positive and max_iter at least 1")


@dataclass
class InverseMapStats:
    """What building an inverse map cost and achieved."""

    exact_points: int = 0
    exact_cells: int = 0
    blocks: dict[tuple[int, int], int] = field(default_factory=dict)
    validated: int = 0
    max_error_px: float = 0.0
    refined_cells: int = 0
    newton_evaluations: int = 0

    def merge(self, other: "InverseMapStats") -> None:
        self.exact_points += other.exact_points
        self.exact_cells += other.exact_cells
        self.refined_cells += other.refined_cells
        self.newton_evaluations += other.newton_evaluations
        for k, v in other.blocks.items():
            self.blocks[k] = self.blocks.get(k, 0) + v
        self.validated += other.validated
        self.max_error_px = max(self.max_error_px, other.max_error_px)


@dataclass(frozen=True)
class TileGrid:
    """Cell centres of a tile: ``x = x0 + col * res``, ``y = y0 - row * res`` (map units)."""

    x0: float
    y0: float
    res: float

    def xy(self, row: np.ndarray, col: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return self.x0 + np.asarray(col, float) * self.res, self.y0 - np.asarray(row, float) * self.res


@dataclass(frozen=True)
class Lattice:
    """The flight-aligned lattice: ``u`` along ``along`` (a unit vector in map x, y), ``v`` to its
    left, unit = ``res``, origin at (x0, y0)."""

    x0: float
    y0: float
    res: float
    cu: float
    su: float

    def to_uv(self, x, y):
        dx, dy = (np.asarray(x) - self.x0) / self.res, (np.asarray(y) - self.y0) / self.res
        return dx * self.cu + dy * self.su, -dx * self.su + dy * self.cu

    def to_xy(self, u, v):
        u, v = np.asarray(u, float), np.asarray(v, float)
        return self.x0 + self.res * (u * self.cu - v * self.su), self.y0 + self.res * (u * self.su + v * self.cu)


class _Nodes:
    """Exact (line, pixel) minus the baseline at lattice nodes (iu, iv) on height levels k, each
    solved once."""

    def __init__(self, solve, lattice: Lattice, H0: float, dH: float) -> None:
        self.solve, self.lattice, self.H0, self.dH = solve, lattice, H0, dH
        self.baseline = None  # set before the first node is asked for
        self.keys = np.zeros(0, np.int64)
        self.line = np.zeros(0)
        self.pixel = np.zeros(0)

    @staticmethod
    def key(iu, iv, k):
        return (np.asarray(iu, np.int64) + 2**20) * 2**42 + (np.asarray(iv, np.int64) + 2**20) * 2**21 + np.asarray(k, np.int64)

    def get(self, iu, iv, k):
        keys = self.key(iu, iv, k)
        new = np.unique(keys[~self._known(keys)])
        if new.size:
            kk = new % 2**21
            iv_n = (new // 2**21) % 2**21 - 2**20
            iu_n = new // 2**42 - 2**20
            x, y = self.lattice.to_xy(iu_n, iv_n)
            line, pixel = self.solve(x, y, self.H0 + kk * self.dH)
            gl, gp = self.baseline(iu_n.astype(float), iv_n.astype(float), self.H0 + kk * self.dH)
            line, pixel = line - gl, pixel - gp
            # ``new`` is sorted and disjoint from the sorted ``keys``: merge by insertion (linear)
            at = np.searchsorted(self.keys, new)
            self.keys = np.insert(self.keys, at, new)
            self.line = np.insert(self.line, at, line)
            self.pixel = np.insert(self.pixel, at, pixel)
        idx = np.searchsorted(self.keys, keys)
        return self.line[idx], self.pixel[idx]

    def _known(self, keys: np.ndarray) -> np.ndarray:
        """Which keys are solved already (binary search in the sorted keys)."""
        if self.keys.size == 0:
            return np.zeros(keys.shape, bool)
        idx = np.minimum(np.searchsorted(self.keys, keys), self.keys.size - 1)
        return self.keys[idx] == keys


class _Solver:
    """Calls ``ground_to_image`` and counts the points."""

    def __init__(self, g2i: GroundToImage, stats: InverseMapStats) -> None:
        self.g2i, self.stats = g2i, stats

    def __call__(self, x, y, H) -> tuple[np.ndarray, np.ndarray]:
        x, y, H = np.broadcast_arrays(np.asarray(x, float), np.asarray(y, float), np.asarray(H, float))
        self.stats.exact_points += x.size
        if x.size == 0:
            return np.empty(x.shape), np.empty(x.shape)
        line, pixel = self.g2i(x.ravel(), y.ravel(), H.ravel())
        return np.asarray(line, float).reshape(x.shape), np.asarray(pixel, float).reshape(x.shape)


def _in_image(line, pixel, shape) -> np.ndarray:
    lines, pixels = shape
    m = OUTSIDE_MARGIN_PX
    with np.errstate(invalid="ignore"):
        return (line >= -m) & (line <= lines - 1 + m) & (pixel >= -m) & (pixel <= pixels - 1 + m)


def _beyond_one_edge(line, pixel, present, shape) -> np.ndarray:
    """Per row of (K, n): every present point unseen or beyond one and the same image edge."""
    lines, pixels = shape
    m = OUTSIDE_MARGIN_PX
    nan = ~(np.isfinite(line) & np.isfinite(pixel)) | ~present
    with np.errstate(invalid="ignore"):
        sides = [line < -m, line > lines - 1 + m, pixel < -m, pixel > pixels - 1 + m]
    return np.any(np.stack([np.all(s | nan, axis=1) for s in sides]), axis=0)


def _fractions(B: np.ndarray) -> np.ndarray:
    """(K, 6) check fractions along an axis of size B (repeated where the block is short): eighths
    on axes of 64 cells and more, quarters from 4 cells, the middle below."""
    f6 = np.array([0.0, 0.125, 0.375, 0.5, 0.625, 0.875])
    f4 = np.array([0.0, 0.25, 0.5, 0.75, 0.75, 0.75])
    f2 = np.array([0.0, 0.5, 0.5, 0.5, 0.5, 0.5])
    B = B[:, None]
    return np.where(B >= 64, f6, np.where(B >= 4, f4, f2))


def _height_levels(solve, lattice, uv_cells, H_cells, tol_level) -> tuple[float, float]:
    """(H0, dH) of the tile's levels: linear interpolation in height within ``tol_level`` where
    the curvature in height is largest among a few cells of the tile."""
    Hmin, Hmax = float(H_cells.min()), float(H_cells.max())
    if Hmax - Hmin < 1e-3:
        return Hmin, 1.0
    pick = np.unique(np.linspace(0, H_cells.size - 1, 25).astype(int))
    u, v = uv_cells[0][pick], uv_cells[1][pick]
    x, y = lattice.to_xy(u, v)
    h3 = np.array([Hmin, 0.5 * (Hmin + Hmax), Hmax])
    l3, p3 = solve(np.repeat(x[:, None], 3, 1), np.repeat(y[:, None], 3, 1), np.broadcast_to(h3, (len(u), 3)))
    with np.errstate(invalid="ignore"):
        e = np.maximum(np.abs(l3[:, 1] - 0.5 * (l3[:, 0] + l3[:, 2])), np.abs(p3[:, 1] - 0.5 * (p3[:, 0] + p3[:, 2])))
    e = e[np.isfinite(e)]
    worst = 2.0 * float(e.max()) if e.size else 0.0  # a margin for cells between the samples
    nseg = int(min(MAX_SEGMENTS, max(1, math.ceil(math.sqrt(worst / tol_level)))))
    return Hmin, max((Hmax - Hmin) / nseg, 1e-3)


def build_inverse_map(
    g2i: GroundToImage,
    grid: TileGrid,
    H: np.ndarray,
    image_shape: tuple[int, int],
    options: InverseMapOptions = InverseMapOptions(),
    seed: int = 0,
    along: tuple[float, float] = (0.0, 1.0),
    height: HeightFunction | None = None,
) -> tuple[np.ndarray, np.ndarray, InverseMapStats]:
    """(line, pixel) of every cell of a tile, interpolated under error control.

    Parameters
    ----------
    g2i : ground -> image, map coordinates and orthometric heights (metres) in, image out.
    grid : the tile's cell centres in map units.
    H : (rows, cols) DTM heights at the cell centres, metres; NaN where the DTM has none.
    image_shape : (lines, pixels) of the strip image.
    options : tolerance and block sizes.
    seed : seed of the validation sample (deterministic per tile).
    along : the flight direction in map (x, y) (need not be normalised).
    height : DTM heights at map points, for check points between cells (default: nearest cell).

    Returns
    -------
    line, pixel : (rows, cols) float64 arrays, NaN where the cell is unseen or has no height.
    stats : exact evaluations made and the largest error found on the validation sample.
    """
    H = np.asarray(H, dtype=float)
    R, C = H.shape
    stats = InverseMapStats()
    solve = _Solver(g2i, stats)
    line = np.full(R * C, np.nan)
    pixel = np.full(R * C, np.nan)
    cells = np.flatnonzero(np.isfinite(H).ravel())
    if cells.size == 0:
        return line.reshape(R, C), pixel.reshape(R, C), stats
    norm = math.hypot(*along)
    lattice = Lattice(grid.x0, grid.y0, grid.res, along[0] / norm, along[1] / norm)
    rows, cols = np.divmod(cells, C)
    xc, yc = grid.xy(rows, cols)
    uc, vc = lattice.to_uv(xc, yc)
    hc = H.ravel()[cells]
    tol = 0.5 * options.max_error_px
    H0, dH = _height_levels(solve, lattice, (uc, vc), hc, tol / 4.0)
    nodes = _Nodes(solve, lattice, H0, dH)
    if height is None:
        height = _nearest_cell_height(grid, H)
    B = options.initial_block
    u_origin, v_origin = math.floor(uc.min()), math.floor(vc.min())
    baseline = _Baseline.measure(solve, lattice, uc, vc, hc, u_origin, v_origin, B)
    nodes.baseline = baseline
    bu = np.floor((uc - u_origin) / B).astype(np.int64)
    bv = np.floor((vc - v_origin) / B).astype(np.int64)
    block_of_cell, first = _group(bu * (2**31) + bv)
    K = first.size - 1
    order = np.argsort(block_of_cell, kind="stable")
    cells_sorted = order
    head = order[first[:-1]]
    u0 = u_origin + bu[head] * B
    v0 = v_origin + bv[head] * B
    Bu = np.full(K, B, np.int64)
    Bv = np.full(K, B, np.int64)
    pending = _Pending(cells_sorted, first, u0, v0, Bu, Bv)
    while pending.count:
        pending = _refine(pending, uc, vc, hc, nodes, solve, lattice, height, H0, dH, image_shape, tol,
                          options, stats, cells, line, pixel)
    line, pixel = line.reshape(R, C), pixel.reshape(R, C)
    _validate(solve, grid, line, pixel, H, image_shape, options.validation_samples, seed, stats)
    return line, pixel, stats


class _Baseline:
    """The along-track profile of the map, subtracted before interpolating and added back after.

    Attitude shakes the map along track only, in a way that changes smoothly across the swath (a
    roll moves every pixel alike; with a pitched scan plane it also moves lines, by an amount that
    grows with the scan angle; a heading change moves lines in proportion to the distance from the
    track) and with the height (the ground distance to the sensor). Exact profiles at unit spacing
    along ``u``, at up to ``MAX_PROFILES`` positions spread over the part of the tile inside the
    swath, and at the tile's lowest and highest height, capture it; ``g(u, v, h)`` interpolates
    them linearly in ``u`` and ``h`` and by a polynomial (Lagrange) in ``v``; beyond the outer
    profiles (the swath's edges, which the roll moves, so no full profile lies there) it follows
    the secant of the outer two for ``EXTRAPOLATE_V`` cells (held constant before: 2.03 M instead of
    1.74 M exact solutions on a 10,000-line strip, nodes on every line along the swath's edges),
    then is held constant. What remains, ``f - g``, is smooth and interpolates on large blocks.
    """

    #: spacing of the candidate profiles across track, lattice units, and how many are used
    PROFILE_SPACING = 32
    MAX_PROFILES = 5
    #: how far beyond the outer profiles g follows their secant, lattice units
    EXTRAPOLATE_V = 64.0

    def __init__(self, u, vs, hs, lines, pixels) -> None:
        self.u, self.vs, self.hs, self.lines, self.pixels = u, vs, hs, lines, pixels

    @classmethod
    def measure(cls, solve, lattice, uc, vc, hc, u_origin, v_origin, B) -> "_Baseline":
        # cover every node of the lattice blocks, which reach up to a block beyond the last cell
        u_end = u_origin + (math.floor((uc.max() - u_origin) / B) + 1) * B
        u = np.arange(u_origin - 1, u_end + 2, dtype=float)
        lo, hi = float(v_origin), float(v_origin + (math.floor((vc.max() - v_origin) / B) + 1) * B)
        n = max(2, int(math.ceil((hi - lo) / cls.PROFILE_SPACING)) + 1)
        candidates = np.linspace(lo, hi, n)
        h_lo, h_hi = float(hc.min()), float(hc.max())
        hs = np.array([h_lo, h_hi]) if h_hi - h_lo > 1.0 else np.array([h_lo])
        # which candidate positions lie inside the swath (probed at three places along track)
        pu, pv = np.meshgrid(np.quantile(u, [0.1, 0.5, 0.9]), candidates, indexing="ij")
        px, py = lattice.to_xy(pu, pv)
        pl, pp = solve(px, py, np.full(px.shape, 0.5 * (h_lo + h_hi)))
        inside = np.flatnonzero((np.isfinite(pl) & np.isfinite(pp)).sum(axis=0) >= 2)
        if inside.size == 0:
            zero = np.zeros((u.size, 1, hs.size))
            return cls(u, np.zeros(1), hs, zero, zero)
        # at most MAX_PROFILES of them, spread evenly
        pick = inside[np.unique(np.round(np.linspace(0, inside.size - 1, min(cls.MAX_PROFILES, inside.size))).astype(int))]
        vs = candidates[pick]
        uu, vv, hh = np.meshgrid(u, vs, hs, indexing="ij")
        x, y = lattice.to_xy(uu, vv)
        line, pixel = solve(x, y, hh)  # (u, v, h)
        good = np.isfinite(line) & np.isfinite(pixel)
        # a profile that leaves the swath somewhere (the edge moves with the roll) would be filled
        # across its gap with a straight line: keep only profiles seen as far as the best one is
        share = good.mean(axis=0).min(axis=1)
        keep = (share > 0.5) & (share >= share.max() - 0.01)
        if not keep.any():
            zero = np.zeros((u.size, 1, hs.size))
            return cls(u, np.zeros(1), hs, zero, zero)
        kept = np.flatnonzero(keep)
        g = good[:, kept]
        fill = lambda a: np.stack([np.stack([_fill(a[:, i, k], g[:, i, k]) for k in range(hs.size)], -1)
                                   for i in range(kept.size)], 1)
        return cls(u, vs[kept], hs, fill(line[:, kept]), fill(pixel[:, kept]))

    def __call__(self, u, v, h) -> tuple[np.ndarray, np.ndarray]:
        u, v, h = np.broadcast_arrays(np.asarray(u, float), np.asarray(v, float), np.asarray(h, float))
        shape = u.shape
        gl = np.empty(u.size)
        gp = np.empty(u.size)
        _baseline_kernel(np.ascontiguousarray(u).ravel(), np.ascontiguousarray(v).ravel(),
                         np.ascontiguousarray(h).ravel(), float(self.u[0]), self.vs, self.hs,
                         np.ascontiguousarray(self.lines), np.ascontiguousarray(self.pixels), self.EXTRAPOLATE_V,
                         gl, gp)
        return gl.reshape(shape), gp.reshape(shape)


@numba.njit(cache=True)
def _baseline_kernel(u, v, h, u_first, vs, hs, lines, pixels, extrapolate_v, gl, gp):
    """g(u, v, h): linear in u and h, Lagrange in v between the outer profiles, linear (their
    secant) up to ``extrapolate_v`` beyond them, constant further out."""
    nu, nv, nh = lines.shape
    for n in range(u.size):
        fu = min(max(u[n] - u_first, 0.0), nu - 1.000001)
        j = int(fu)
        a = fu - j
        vv = min(max(v[n], vs[0]), vs[nv - 1])
        if nh == 2:
            t = (h[n] - hs[0]) / (hs[1] - hs[0])
        else:
            t = 0.0
        # beyond the outer profiles: the secant of the outer two, at most EXTRAPOLATE_V out
        beyond = 0.0
        i0 = 0
        i1 = 0
        if nv >= 2 and v[n] > vs[nv - 1]:
            beyond = min(v[n] - vs[nv - 1], extrapolate_v) / (vs[nv - 1] - vs[nv - 2])
            i0 = nv - 2
            i1 = nv - 1
        elif nv >= 2 and v[n] < vs[0]:
            beyond = min(vs[0] - v[n], extrapolate_v) / (vs[1] - vs[0])
            i0 = 1
            i1 = 0
        sl = 0.0
        sp = 0.0
        for i in range(nv):
            w = 1.0
            for m in range(nv):
                if m != i:
                    w *= (vv - vs[m]) / (vs[i] - vs[m])
            if beyond > 0.0:
                w += beyond if i == i1 else (-beyond if i == i0 else 0.0)
            for k in range(nh):
                wk = w * ((1.0 - t) if k == 0 else t) if nh == 2 else w
                sl += wk * (lines[j, i, k] * (1 - a) + lines[j + 1, i, k] * a)
                sp += wk * (pixels[j, i, k] * (1 - a) + pixels[j + 1, i, k] * a)
        gl[n] = sl
        gp[n] = sp


def _fill(values: np.ndarray, good: np.ndarray) -> np.ndarray:
    """``values`` with gaps filled linearly from the nearest good ones (constant beyond the ends)."""
    idx = np.arange(values.size)
    return np.interp(idx, idx[good], values[good])


def _nearest_cell_height(grid: TileGrid, H: np.ndarray) -> HeightFunction:
    R, C = H.shape

    def height(x, y):
        col = np.clip(np.rint((np.asarray(x) - grid.x0) / grid.res), 0, C - 1).astype(int)
        row = np.clip(np.rint((grid.y0 - np.asarray(y)) / grid.res), 0, R - 1).astype(int)
        return H[row, col]

    return height


def _group(ids: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Dense group index of every element and the start offsets (K + 1) of the groups when sorted."""
    uniq, inverse, counts = np.unique(ids, return_inverse=True, return_counts=True)
    return inverse, np.concatenate([[0], np.cumsum(counts)])


@dataclass
class _Pending:
    """Blocks still to settle, with their cells (indices into the tile's valid cells, grouped)."""

    cells: np.ndarray  # cell indices sorted by block
    first: np.ndarray  # (K + 1) offsets of each block's cells in ``cells``
    u0: np.ndarray
    v0: np.ndarray
    Bu: np.ndarray
    Bv: np.ndarray

    @property
    def count(self) -> int:
        return self.u0.size

    def block_of(self) -> np.ndarray:
        return np.repeat(np.arange(self.count), np.diff(self.first))


@numba.njit(cache=True)
def _interp_kernel(L, P, k, u0, v0, Bu, Bv, klo, nseg, H0, dH, u, v, h, out_l, out_p):
    for n in range(u.size):
        b = k[n]
        fu = (u[n] - u0[b]) / Bu[b]
        fv = (v[n] - v0[b]) / Bv[b]
        s = (h[n] - H0) / dH - klo[b]
        i = min(max(int(np.floor(s)), 0), nseg[b] - 1)
        f = s - i
        w0, w1, w2, w3 = (1 - fu) * (1 - fv), fu * (1 - fv), (1 - fu) * fv, fu * fv
        a = L[b, i, 0] * w0 + L[b, i, 1] * w1 + L[b, i, 2] * w2 + L[b, i, 3] * w3
        c = L[b, i + 1, 0] * w0 + L[b, i + 1, 1] * w1 + L[b, i + 1, 2] * w2 + L[b, i + 1, 3] * w3
        out_l[n] = a + f * (c - a)
        a = P[b, i, 0] * w0 + P[b, i, 1] * w1 + P[b, i, 2] * w2 + P[b, i, 3] * w3
        c = P[b, i + 1, 0] * w0 + P[b, i + 1, 1] * w1 + P[b, i + 1, 2] * w2 + P[b, i + 1, 3] * w3
        out_p[n] = a + f * (c - a)


def _block_interp(L, P, k, pb, klo, nseg, H0, dH, u, v, h, baseline):
    """(line, pixel) at (u, v, h) in blocks ``k`` of ``pb`` with corner node values L, P (K, levels, 4)."""
    out_l = np.empty(u.size)
    out_p = np.empty(u.size)
    _interp_kernel(np.ascontiguousarray(L), np.ascontiguousarray(P), np.ascontiguousarray(k, dtype=np.int64),
                   pb.u0.astype(float), pb.v0.astype(float), pb.Bu.astype(float), pb.Bv.astype(float),
                   klo.astype(np.float64), nseg.astype(np.int64), float(H0), float(dH),
                   np.ascontiguousarray(u, dtype=float), np.ascontiguousarray(v, dtype=float),
                   np.ascontiguousarray(h, dtype=float), out_l, out_p)
    gl, gp = baseline(u, v, h)
    return out_l + gl, out_p + gp


def _refine(pb: _Pending, uc, vc, hc, nodes: _Nodes, solve, lattice, height, H0, dH, shape, tol, options,
            stats, cells, line, pixel) -> _Pending:
    K = pb.count
    hs = hc[pb.cells]
    Hlo = np.minimum.reduceat(hs, pb.first[:-1])
    Hhi = np.maximum.reduceat(hs, pb.first[:-1])
    klo = np.floor((Hlo - H0) / dH + 1e-9).astype(np.int64)
    khi = np.maximum(np.ceil((Hhi - H0) / dH - 1e-9).astype(np.int64), klo + 1)
    nseg = khi - klo
    maxlev = int(nseg.max()) + 1
    # corner nodes on each block's levels (padded by repeating the top level)
    lev = np.minimum(klo[:, None] + np.arange(maxlev), khi[:, None])  # (K, maxlev)
    cu = np.stack([pb.u0, pb.u0 + pb.Bu, pb.u0, pb.u0 + pb.Bu], 1)  # (K, 4)
    cv = np.stack([pb.v0, pb.v0, pb.v0 + pb.Bv, pb.v0 + pb.Bv], 1)
    L, P = nodes.get(np.broadcast_to(cu[:, None, :], (K, maxlev, 4)), np.broadcast_to(cv[:, None, :], (K, maxlev, 4)),
                     np.broadcast_to(lev[:, :, None], (K, maxlev, 4)))
    nodes_bad = ~np.all(np.isfinite(L) & np.isfinite(P), axis=(1, 2))
    # check points: fractions along u and v, the corner left out, at the worst height there
    fu = np.broadcast_to(_fractions(pb.Bu), (K, 6))
    fv = np.broadcast_to(_fractions(pb.Bv), (K, 6))
    qu = (pb.u0[:, None] + fu * pb.Bu[:, None])[:, :, None] * np.ones((1, 1, 6))
    qv = (pb.v0[:, None] + fv * pb.Bv[:, None])[:, None, :] * np.ones((1, 6, 1))
    on_u_edge = np.broadcast_to((fv == 0)[:, None, :], qu.shape).reshape(K, -1)
    on_v_edge = np.broadcast_to((fu == 0)[:, :, None], qu.shape).reshape(K, -1)
    qu, qv = qu.reshape(K, -1), qv.reshape(K, -1)
    # and a dense line along u through the block's middle: the attitude's residue can wiggle at a
    # few lines' period, which a coarse pattern would straddle
    ku = np.arange(1, DENSE_U)
    dense_ok = ku[None, :] < pb.Bu[:, None]
    du = pb.u0[:, None] + np.minimum(ku[None, :], pb.Bu[:, None] - 1)
    dv = np.broadcast_to((pb.v0 + 0.5 * pb.Bv)[:, None], du.shape)
    n_grid = qu.shape[1]
    qu = np.concatenate([qu, du.astype(float)], axis=1)
    qv = np.concatenate([qv, dv], axis=1)
    on_u_edge = np.concatenate([on_u_edge, np.zeros(du.shape, bool)], axis=1)
    on_v_edge = np.concatenate([on_v_edge, np.zeros(du.shape, bool)], axis=1)
    on_dense = np.concatenate([np.zeros((K, n_grid), bool), dense_ok], axis=1)
    qx, qy = lattice.to_xy(qu, qv)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        qh = np.clip(np.asarray(height(qx, qy), float), Hlo[:, None], Hhi[:, None])
    seg = np.clip(np.floor((qh - H0) / dH) - klo[:, None], 0, nseg[:, None] - 1)
    qh = H0 + (klo[:, None] + seg + 0.5) * dH
    dup_u = np.concatenate([np.zeros((K, 1), bool), fu[:, 1:] == fu[:, :-1]], axis=1)
    dup_v = np.concatenate([np.zeros((K, 1), bool), fv[:, 1:] == fv[:, :-1]], axis=1)
    dup = (dup_u[:, :, None] | dup_v[:, None, :]).reshape(K, -1)
    # dense points that are grid points already (the grid's middle column holds some of them)
    dense_f = np.minimum(ku[None, :], pb.Bu[:, None] - 1) / pb.Bu[:, None]
    on_grid = (np.abs(dense_f[:, :, None] - fu[:, None, :]) < 1e-9).any(axis=2) & (fv == 0.5).any(axis=1)[:, None]
    dup = np.concatenate([dup, ~dense_ok | on_grid], axis=1)
    # blocks with an unseen corner fail anyway: no checks for them
    usable = np.isfinite(qh) & ~(on_u_edge & on_v_edge) & ~dup & ~nodes_bad[:, None]
    el, ep = np.full(qu.shape, np.nan), np.full(qu.shape, np.nan)
    el[usable], ep[usable] = solve(qx[usable], qy[usable], qh[usable])
    kk = np.broadcast_to(np.arange(K)[:, None], qu.shape)
    il, ip = np.full(qu.shape, np.nan), np.full(qu.shape, np.nan)
    k_u = kk[usable]
    il[usable], ip[usable] = _block_interp(L, P, k_u, pb, klo, nseg, H0, dH, qu[usable], qv[usable], qh[usable],
                                           nodes.baseline)
    relevant = usable & _in_image(el, ep, shape)
    with np.errstate(invalid="ignore"):
        err = np.where(relevant, np.maximum(np.abs(il - el), np.abs(ip - ep)), 0.0)
    err = np.where(relevant & ~np.isfinite(err), np.inf, err)
    e_v = np.where(on_v_edge, err, 0).max(axis=1)
    # along-track structure shows on the u edge and on the dense line
    e_u = np.maximum(np.where(on_u_edge, err, 0).max(axis=1), np.where(on_dense, err, 0).max(axis=1))
    e_in = np.where(~on_u_edge & ~on_v_edge, err, 0).max(axis=1)
    # which blocks are settled
    # node values back in image units
    gl, gp = nodes.baseline(np.broadcast_to(cu[:, None, :], L.shape).astype(float),
                            np.broadcast_to(cv[:, None, :], L.shape).astype(float),
                            (H0 + lev * dH)[:, :, None] * np.ones((1, 1, 4)))
    pts_l = np.concatenate([(L + gl).reshape(K, -1), el], axis=1)
    pts_p = np.concatenate([(P + gp).reshape(K, -1), ep], axis=1)
    present = np.concatenate([np.ones((K, 4 * maxlev), bool), usable], axis=1)
    empty = _beyond_one_edge(pts_l, pts_p, present, shape)
    inside = _in_image(pts_l, pts_p, shape)
    across_edge = (inside & present).any(axis=1) & (~inside & present).any(axis=1)
    small = pb.Bu * pb.Bv <= options.exact_cells
    across_edge &= ~small
    accept = ~empty & ~nodes_bad & ~across_edge & (np.maximum(np.maximum(e_u, e_v), e_in) <= tol)
    # along the swath's edges the core gives no answer outside: small blocks there are solved
    # per cell at once instead of being split down to single cells
    small |= (nodes_bad | across_edge) & (pb.Bu * pb.Bv <= EDGE_EXACT_CELLS)
    exact = ~empty & ~accept & small
    split = ~empty & ~accept & ~small
    block = pb.block_of()
    # settle accepted blocks
    if accept.any():
        for key in zip(pb.Bu[accept], pb.Bv[accept]):
            key = (int(key[0]), int(key[1]))
            stats.blocks[key] = stats.blocks.get(key, 0) + 1
        sel = accept[block]
        c = pb.cells[sel]
        k = block[sel]
        ci = cells[c]
        line[ci], pixel[ci] = _block_interp(L, P, k, pb, klo, nseg, H0, dH, uc[c], vc[c], hc[c], nodes.baseline)
    if exact.any():
        c = pb.cells[exact[block]]
        x, y = lattice.to_xy(uc[c], vc[c])
        line[cells[c]], pixel[cells[c]] = solve(x, y, hc[c])
        stats.exact_cells += c.size
    if not split.any():
        return _Pending(np.zeros(0, np.int64), np.zeros(1, np.int64), *(np.zeros(0, np.int64),) * 4)
    # split along the axis whose edge shows the larger error (the bilinear error is a sum of one
    # term per axis; each edge sees its own), both when comparable or unclear; never below a cell.
    # The error shrinks with the square of the size: split straight into as many parts as needed.
    e_max = np.maximum(e_u, e_v)
    unclear = nodes_bad | across_edge | ~(e_max > 0.25 * tol) | ~np.isfinite(e_max)
    want_u = unclear | (e_u >= 0.5 * e_max)
    want_v = unclear | (e_v >= 0.5 * e_max)
    su = want_u & (pb.Bu > 1)
    sv = want_v & (pb.Bv > 1)
    su |= ~su & ~sv & (pb.Bu > 1)
    sv |= ~su & ~sv
    nu = np.where(su, _parts(np.where(unclear, 0.0, e_u), tol, pb.Bu), 1)
    nv = np.where(sv, _parts(np.where(unclear, 0.0, e_v), tol, pb.Bv), 1)
    sel = split[block]
    c = pb.cells[sel]
    k = block[sel]
    hu, hv = pb.Bu // nu, pb.Bv // nv
    iu = np.minimum(np.floor((uc[c] - pb.u0[k]) / hu[k]), nu[k] - 1).astype(np.int64)
    iv = np.minimum(np.floor((vc[c] - pb.v0[k]) / hv[k]), nv[k] - 1).astype(np.int64)
    child = (k * 64 + iu) * 64 + iv
    group, first = _group(child)
    order = np.argsort(group, kind="stable")
    starts = child[order[first[:-1]]]
    kp, rest = np.divmod(starts, 64 * 64)
    ju, jv = np.divmod(rest, 64)
    return _Pending(c[order], first, pb.u0[kp] + ju * hu[kp], pb.v0[kp] + jv * hv[kp], hu[kp], hv[kp])


def _parts(err: np.ndarray, tol: float, B: np.ndarray) -> np.ndarray:
    """Parts (a power of two, 2 .. B, at most 32) to split an axis into so its error falls below
    ``tol``: the error of linear interpolation shrinks with the square of the spacing."""
    with np.errstate(divide="ignore", invalid="ignore"):
        need = np.sqrt(np.maximum(err, 0.0) / tol) * 1.25
    n = 2 ** np.ceil(np.log2(np.maximum(need, 2.0)))
    return np.minimum(np.minimum(n, 32), B).astype(np.int64)


def _validate(solve, grid, line, pixel, H, image_shape, n, seed, stats) -> None:
    """Compare a random sample of interpolated cells with exact solutions."""
    lines, pixels = image_shape
    with np.errstate(invalid="ignore"):
        seen = (line >= -0.5) & (line <= lines - 0.5) & (pixel >= -0.5) & (pixel <= pixels - 0.5)
    ok = np.flatnonzero(seen.ravel())
    if n <= 0 or ok.size == 0:
        return
    rng = np.random.default_rng(seed)
    pick = rng.choice(ok, size=min(n, ok.size), replace=False)
    rows, cols = np.unravel_index(pick, line.shape)
    x, y = grid.xy(rows, cols)
    el, ep = solve(x, y, H[rows, cols])
    err = np.maximum(np.abs(el - line[rows, cols]), np.abs(ep - pixel[rows, cols]))
    err = np.where(np.isfinite(err), err, np.inf)
    stats.validated += pick.size
    stats.max_error_px = max(stats.max_error_px, float(err.max()))
