"""The inverse map of a tile: (line, pixel) for every output cell, exact on a coarse lattice.

Ground -> image is smooth in the map position *and in the height* but the DTM heights of
neighbouring cells are not smooth; so the map is not interpolated in (x, y) alone. Each square
block of cells gets exact solutions at its four corners on a few height levels spanning the
block's DTM heights; a cell's (line, pixel) is bilinear in (x, y) on the two levels bracketing its
height and linear between them. The number of levels comes from the curvature in height measured
at the block centre (linear interpolation error grows with the square of the level spacing).

Error control: every block is checked against exact solutions at check cells inside it (at their
own DTM heights); a block whose largest error exceeds half the tolerance, or which lies across an
image edge (its check cells beyond the edge say nothing), is split in four, down to ``min_block``
cells, below which cells are solved exactly. Blocks entirely outside the image
(all corners and check cells beyond one image edge, or unseen) are left unseen. A random sample of
cells is finally compared with exact solutions and its largest error reported: that figure, not
the check cells, is what :class:`InverseMapStats` states as the achieved accuracy.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from scangeo.errors import ScangeoError

#: ``ground_to_image(x, y, H) -> (line, pixel)``: map points to fractional image coordinates.
GroundToImage = Callable[[np.ndarray, np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]

#: image pixels beyond an edge by which a block counts as outside the image
OUTSIDE_MARGIN_PX = 2.0
#: most height levels a block may get (beyond, it is split instead)
MAX_LEVELS = 65


@dataclass(frozen=True)
class InverseMapOptions:
    """Accuracy and block sizes of the interpolated inverse map.

    Parameters
    ----------
    max_error_px : tolerated interpolation error, image pixels (largest of |d line|, |d pixel|).
        Blocks are accepted when their check cells are within half of it.
    initial_block : size of the first blocks, cells (a power of two).
    min_block : smallest interpolated block; blocks failing at this size are solved per cell.
    validation_samples : cells per tile compared with exact solutions after the fact.
    """

    max_error_px: float = 0.05
    initial_block: int = 32
    min_block: int = 8
    validation_samples: int = 256

    def __post_init__(self) -> None:
        if not self.max_error_px > 0:
            raise ScangeoError(f"inverse map: max_error_px must be positive, got {self.max_error_px}")
        for name in ("initial_block", "min_block"):
            v = getattr(self, name)
            if v < 2 or v & (v - 1):
                raise ScangeoError(f"inverse map: {name} must be a power of two >= 2, got {v}")
        if self.min_block > self.initial_block:
            raise ScangeoError("inverse map: min_block must not exceed initial_block")


@dataclass
class InverseMapStats:
    """What building an inverse map cost and achieved."""

    exact_points: int = 0
    exact_cells: int = 0
    blocks: dict[int, int] = field(default_factory=dict)
    validated: int = 0
    max_error_px: float = 0.0

    def merge(self, other: "InverseMapStats") -> None:
        self.exact_points += other.exact_points
        self.exact_cells += other.exact_cells
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


class _Solver:
    """Calls ``ground_to_image`` and counts the points."""

    def __init__(self, g2i: GroundToImage, grid: TileGrid, stats: InverseMapStats) -> None:
        self.g2i, self.grid, self.stats = g2i, grid, stats

    def __call__(self, row, col, H) -> tuple[np.ndarray, np.ndarray]:
        x, y = self.grid.xy(row, col)
        H = np.asarray(H, float)
        x, y, H = np.broadcast_arrays(x, y, H)
        self.stats.exact_points += x.size
        if x.size == 0:
            return np.empty(x.shape), np.empty(x.shape)
        line, pixel = self.g2i(x.ravel(), y.ravel(), H.ravel())
        return np.asarray(line, float).reshape(x.shape), np.asarray(pixel, float).reshape(x.shape)


def _block_height_range(H: np.ndarray, r0: np.ndarray, c0: np.ndarray, B: int):
    """Per block: (Hmin, Hmax) of its valid cells (NaN when none)."""
    R, C = H.shape
    rows = np.minimum(r0[:, None] + np.arange(B), R - 1)
    cols = np.minimum(c0[:, None] + np.arange(B), C - 1)
    h = H[rows[:, :, None], cols[:, None, :]].reshape(len(r0), -1)
    with np.errstate(invalid="ignore"), _quiet():
        return np.nanmin(h, axis=1), np.nanmax(h, axis=1)


class _quiet:
    """Silence numpy's all-NaN-slice warnings inside a block."""

    def __enter__(self):
        import warnings

        self._w = warnings.catch_warnings()
        self._w.__enter__()
        warnings.simplefilter("ignore", RuntimeWarning)

    def __exit__(self, *exc):
        self._w.__exit__(*exc)


@dataclass
class _Blocks:
    """Blocks of one size with their exact corner values on height levels."""

    r0: np.ndarray
    c0: np.ndarray
    B: int
    Hlo: np.ndarray
    Hhi: np.ndarray
    nseg: np.ndarray
    L: np.ndarray  # (K, levels, 4) exact line at corners (r0,c0), (r0,c0+B), (r0+B,c0), (r0+B,c0+B)
    P: np.ndarray

    def mid_segment(self, k: np.ndarray, h: np.ndarray) -> np.ndarray:
        """The height half-way between the two levels of block ``k`` that bracket ``h``."""
        dh = (self.Hhi[k] - self.Hlo[k]) / self.nseg[k]
        i = np.clip(np.floor((h - self.Hlo[k]) / dh), 0, self.nseg[k] - 1)
        return self.Hlo[k] + (i + 0.5) * dh

    def interpolate(self, k: np.ndarray, row: np.ndarray, col: np.ndarray, h: np.ndarray):
        """(line, pixel) interpolated at cells (row, col) of blocks ``k`` with heights ``h``."""
        fr = (row - self.r0[k]) / self.B
        fc = (col - self.c0[k]) / self.B
        s = (h - self.Hlo[k]) / (self.Hhi[k] - self.Hlo[k]) * self.nseg[k]
        i = np.clip(np.floor(s), 0, self.nseg[k] - 1).astype(np.intp)
        f = s - i
        w = np.stack([(1 - fr) * (1 - fc), (1 - fr) * fc, fr * (1 - fc), fr * fc], axis=-1)
        out = []
        for V in (self.L, self.P):
            v0 = np.einsum("...j,...j->...", V[k, i], w)
            v1 = np.einsum("...j,...j->...", V[k, i + 1], w)
            out.append(v0 + f * (v1 - v0))
        return out[0], out[1]


def _corner_offsets(B: int) -> tuple[np.ndarray, np.ndarray]:
    return np.array([0, 0, B, B]), np.array([0, B, 0, B])


def _check_cells(r0, c0, B: int, shape) -> tuple[np.ndarray, np.ndarray]:
    """Check cells of blocks (K, n) on the block's part inside the tile.

    A grid of fractions ``{0, 1/4, 1/2, 3/4}`` (``{0, 1/8, 3/8, 1/2, 5/8, 7/8}`` for blocks of 16
    cells and more) in rows and columns, the exact corner left out. The block's own first row and
    column are included on purpose: the bilinear error is ``f_xx u(B-u)/2 + f_yy v(B-v)/2``, and
    where the two curvatures have opposite signs (across-track perspective against an attitude
    oscillation) it cancels inside the block but not along its edges.
    """
    R, C = shape
    f = np.array([0.0, 0.125, 0.375, 0.5, 0.625, 0.875]) if B >= 16 else np.array([0.0, 0.25, 0.5, 0.75])
    m = f.size
    ext_r = np.minimum(B, R - r0)[:, None]
    ext_c = np.minimum(B, C - c0)[:, None]
    orow = np.clip(np.round(f * ext_r), 0, ext_r - 1).astype(np.intp)
    ocol = np.clip(np.round(f * ext_c), 0, ext_c - 1).astype(np.intp)
    rows = r0[:, None] + np.repeat(orow, m, axis=1)
    cols = c0[:, None] + np.tile(ocol, (1, m))
    return rows[:, 1:], cols[:, 1:]


def _outside(line: np.ndarray, pixel: np.ndarray, shape: tuple[int, int], axis: int) -> np.ndarray:
    """Per row of (K, n) arrays: all points unseen or beyond one and the same image edge."""
    lines, pixels = shape
    m = OUTSIDE_MARGIN_PX
    nan = ~(np.isfinite(line) & np.isfinite(pixel))
    with np.errstate(invalid="ignore"):
        sides = [line < -m, line > lines - 1 + m, pixel < -m, pixel > pixels - 1 + m]
    return np.any(np.stack([np.all(s | nan, axis=axis) for s in sides]), axis=0)


def _in_image(line, pixel, shape) -> np.ndarray:
    lines, pixels = shape
    m = OUTSIDE_MARGIN_PX
    with np.errstate(invalid="ignore"):
        return (line >= -m) & (line <= lines - 1 + m) & (pixel >= -m) & (pixel <= pixels - 1 + m)


def _build_blocks(solve: _Solver, r0, c0, B, Hlo, Hhi, tol_level) -> _Blocks:
    """Exact corner values on height levels for blocks of size B."""
    K = len(r0)
    flat = ~(Hhi - Hlo > 1e-3)
    Hhi = np.where(flat, Hlo + 1.0, Hhi)
    # curvature in height at the block centre: error of one linear segment at mid-height
    rc, cc = r0 + B / 2.0, c0 + B / 2.0
    h3 = np.stack([Hlo, 0.5 * (Hlo + Hhi), Hhi], axis=1)
    l3, p3 = solve(np.repeat(rc[:, None], 3, 1), np.repeat(cc[:, None], 3, 1), h3)
    with np.errstate(invalid="ignore"):
        e_mid = np.maximum(np.abs(l3[:, 1] - 0.5 * (l3[:, 0] + l3[:, 2])), np.abs(p3[:, 1] - 0.5 * (p3[:, 0] + p3[:, 2])))
    e_mid = np.where(np.isfinite(e_mid) & ~flat, e_mid, 0.0)
    nseg = np.clip(np.ceil(np.sqrt(e_mid / tol_level)), 1, MAX_LEVELS - 1).astype(np.intp)
    nlev = nseg + 1
    maxlev = int(nlev.max()) if K else 2
    # nodes: every block's 4 corners on its own levels
    k = np.repeat(np.arange(K), 4 * nlev)
    start = np.repeat(np.cumsum(4 * nlev) - 4 * nlev, 4 * nlev)
    j = np.arange(k.size) - start
    level, corner = j // 4, j % 4
    dr, dc = _corner_offsets(B)
    h = Hlo[k] + (Hhi[k] - Hlo[k]) * level / nseg[k]
    lv, pv = solve(r0[k] + dr[corner], c0[k] + dc[corner], h)
    L = np.full((K, maxlev, 4), np.nan)
    P = np.full((K, maxlev, 4), np.nan)
    L[k, level, corner] = lv
    P[k, level, corner] = pv
    return _Blocks(r0, c0, B, Hlo, Hhi, nseg, L, P)


def _cells(r0, c0, B, shape):
    """Rows, cols (K, B*B) of the cells of blocks, and which exist in the tile."""
    R, C = shape
    dr, dc = np.meshgrid(np.arange(B), np.arange(B), indexing="ij")
    rows = r0[:, None] + dr.ravel()
    cols = c0[:, None] + dc.ravel()
    return rows, cols, (rows < R) & (cols < C)


def build_inverse_map(
    g2i: GroundToImage,
    grid: TileGrid,
    H: np.ndarray,
    image_shape: tuple[int, int],
    options: InverseMapOptions = InverseMapOptions(),
    seed: int = 0,
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

    Returns
    -------
    line, pixel : (rows, cols) float64 arrays, NaN where the cell is unseen or has no height.
    stats : exact evaluations made and the largest error found on the validation sample.
    """
    H = np.asarray(H, dtype=float)
    R, C = H.shape
    stats = InverseMapStats()
    solve = _Solver(g2i, grid, stats)
    line = np.full((R, C), np.nan)
    pixel = np.full((R, C), np.nan)
    tol = 0.5 * options.max_error_px
    B = options.initial_block
    rr, cc = np.meshgrid(np.arange(0, R, B), np.arange(0, C, B), indexing="ij")
    r0, c0 = rr.ravel(), cc.ravel()
    while len(r0):
        Hlo, Hhi = _block_height_range(H, r0, c0, B)
        has = np.isfinite(Hlo)
        r0, c0, Hlo, Hhi = r0[has], c0[has], Hlo[has], Hhi[has]
        if not len(r0):
            break
        blocks = _build_blocks(solve, r0, c0, B, Hlo, Hhi, tol / 4.0)
        K = len(r0)
        # check cells at their own heights
        crow, ccol = _check_cells(r0, c0, B, (R, C))
        kk = np.repeat(np.arange(K)[:, None], crow.shape[1], 1)
        # at the middle of the height segment holding the cell's height: the worst height there
        ch = blocks.mid_segment(kk, H[crow, ccol])
        usable = np.isfinite(ch)
        el, ep = np.full(ch.shape, np.nan), np.full(ch.shape, np.nan)
        el[usable], ep[usable] = solve(crow[usable], ccol[usable], ch[usable])
        il, ip = np.full(ch.shape, np.nan), np.full(ch.shape, np.nan)
        il[usable], ip[usable] = blocks.interpolate(kk[usable], crow[usable], ccol[usable], ch[usable])
        relevant = usable & _in_image(el, ep, image_shape)
        with np.errstate(invalid="ignore"):
            err = np.where(relevant, np.maximum(np.abs(il - el), np.abs(ip - ep)), 0.0)
        err = np.where(relevant & ~np.isfinite(err), np.inf, err)
        block_err = err.max(axis=1)
        nodes_l = blocks.L.reshape(K, -1)
        nodes_p = blocks.P.reshape(K, -1)
        level_used = np.arange(blocks.L.shape[1])[None, :] <= blocks.nseg[:, None]
        used = np.repeat(level_used, 4, axis=1)
        nodes_bad = np.any(used & ~(np.isfinite(nodes_l) & np.isfinite(nodes_p)), axis=1)
        all_l = np.concatenate([np.where(used, nodes_l, np.nan), np.where(usable, el, np.nan)], axis=1)
        all_p = np.concatenate([np.where(used, nodes_p, np.nan), np.where(usable, ep, np.nan)], axis=1)
        empty = _outside(all_l, all_p, image_shape, axis=1)
        # a block across the image edge is checked only on its part inside: split it further
        present = np.concatenate([used, usable], axis=1)
        inside_pts = _in_image(all_l, all_p, image_shape)
        across_edge = (inside_pts & present).any(axis=1) & (~inside_pts & present).any(axis=1)
        across_edge &= B > options.min_block
        accept = ~empty & ~nodes_bad & ~across_edge & (block_err <= tol)
        if accept.any():
            stats.blocks[B] = stats.blocks.get(B, 0) + int(accept.sum())
            ka = np.flatnonzero(accept)
            rows, cols, exists = _cells(r0[ka], c0[ka], B, (R, C))
            kcell = np.repeat(ka[:, None], rows.shape[1], 1)
            rows, cols, kcell = rows[exists], cols[exists], kcell[exists]
            h = H[rows, cols]
            ok = np.isfinite(h)
            rows, cols, kcell, h = rows[ok], cols[ok], kcell[ok], h[ok]
            line[rows, cols], pixel[rows, cols] = blocks.interpolate(kcell, rows, cols, h)
        fail = ~empty & ~accept
        if B <= options.min_block:
            _solve_cells(solve, r0[fail], c0[fail], B, H, line, pixel, stats)
            break
        half = B // 2
        r0 = np.concatenate([r0[fail], r0[fail], r0[fail] + half, r0[fail] + half])
        c0 = np.concatenate([c0[fail], c0[fail] + half, c0[fail], c0[fail] + half])
        keep = (r0 < R) & (c0 < C)
        r0, c0 = r0[keep], c0[keep]
        B = half
    _validate(solve, line, pixel, H, image_shape, options.validation_samples, seed, stats)
    return line, pixel, stats


def _solve_cells(solve, r0, c0, B, H, line, pixel, stats) -> None:
    """Exact (line, pixel) for every cell with a height in blocks of size B."""
    rows, cols, exists = _cells(r0, c0, B, H.shape)
    rows, cols = rows[exists], cols[exists]
    ok = np.isfinite(H[rows, cols])
    rows, cols = rows[ok], cols[ok]
    line[rows, cols], pixel[rows, cols] = solve(rows, cols, H[rows, cols])
    stats.exact_cells += rows.size


def _validate(solve, line, pixel, H, image_shape, n, seed, stats) -> None:
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
    el, ep = solve(rows, cols, H[rows, cols])
    err = np.maximum(np.abs(el - line[rows, cols]), np.abs(ep - pixel[rows, cols]))
    err = np.where(np.isfinite(err), err, np.inf)
    stats.validated += pick.size
    stats.max_error_px = max(stats.max_error_px, float(err.max()))
