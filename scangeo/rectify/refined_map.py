"""The inverse map of a tile refined per cell: interpolated from a coarse lattice of exact
solutions, then one or two Newton steps of the sensor model at every cell.

Interpolating (line, pixel) under error control (the lattice method of earlier versions) cost more
in checks than the interpolation saved (about 0.2 exact solutions per cell on a turbulent
10,000-line strip, plus the bookkeeping of an adaptive lattice) and still missed its tolerance on
steep turbulent strips. Here the interpolation is only the start: ground -> image is solved at
every cell by Newton on time from the interpolated (line, pixel), which converges in one or two
evaluations of the orientation spline instead of the bracketed search's three to five (no search
at all). The result is the exact solution at every cell (Newton's last step under ``tol_line``,
0.01 lines by default, leaves an error of about 4e-6 lines, against the tolerance's 0.05 px), so
the interpolation error is zero by construction: each cell's last Newton step is its own error
check. What remains to control is convergence:

1. exact solutions (the geometry's bracketed ground -> image) on a coarse lattice of every
   ``coarse_step``-th cell, at the DTM's height there; nodes outside the swath are filled from the
   nearest seen node of their lattice row or column (a start for Newton, no more);
2. every cell with a DTM height starts from the bilinear interpolation of the lattice and runs
   Newton; a cell that has not converged after ``max_iter`` evaluations, or whose step leaves
   ``max_step_lines``, is solved by the bracketed ground -> image;
3. a random sample of seen cells is compared with the bracketed solutions (reported in
   :class:`scangeo.rectify.inverse_map.InverseMapStats`).

Strips that over-scan (pitch rates that make the scan line run backwards, so a ground point can
be seen twice) need the bracketed search's "first sighting" rule: every cell is solved by it.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numba
import numpy as np

from scangeo.rectify.geometry import MapStripGeometry
from scangeo.rectify.inverse_map import InverseMapOptions, InverseMapStats, TileGrid, solve_cells, validate
from scangeo.sensors.kernels import NO_CONVERGENCE
from scangeo.threading_layer import choose_threading_layer


@runtime_checkable
class RefinableStrip(MapStripGeometry, Protocol):
    """A strip geometry whose inverse map can be refined per cell (what the geometry core offers
    through :class:`scangeo.rectify.core_geometry.CoreStripGeometry`)."""

    #: False when the strip over-scans (a ground point may be seen twice): no Newton then
    monotonic: bool

    def map_to_project(self, x: np.ndarray, y: np.ndarray, H: np.ndarray) -> np.ndarray:
        """Project-frame points (n, 3) of map points (x, y map units, H orthometric metres)."""
        ...

    def project_to_image_near(
        self, p_P: np.ndarray, line0: np.ndarray, pixel0: np.ndarray, tol_line: float = 1e-2,
        max_step_lines: float = 64.0, max_iter: int = 8,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(line, pixel, status, evaluations) of project-frame points by Newton from the guesses
        (line0, pixel0); status 0 seen, 4 not converged, others unseen (line, pixel NaN)."""
        ...

    def height_on_lattice(self, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
        """DTM heights (len(ys), len(xs)) at the map points (xs[j], ys[i]); NaN where none."""
        ...


def build_refined_map(
    geometry: RefinableStrip,
    grid: TileGrid,
    H: np.ndarray,
    options: InverseMapOptions | None = None,
    seed: int = 0,
) -> tuple[np.ndarray, np.ndarray, InverseMapStats]:
    """(line, pixel) of every cell of a tile, solved per cell from interpolated starts.

    Parameters
    ----------
    geometry : the strip (its bracketed ``ground_to_image`` for the lattice, the fallbacks and the
        validation; ``project_to_image_near`` for Newton at every cell).
    grid : the tile's cell centres in map units.
    H : (rows, cols) DTM heights at the cell centres; NaN where the DTM has none.
    options : ``coarse_step`` of the lattice, Newton's settings, ``validation_samples``
        (default: ``InverseMapOptions()``).
    seed : seed of the validation sample.

    Returns
    -------
    line, pixel : (rows, cols) float64, NaN where the cell is unseen or has no height.
    stats : exact (bracketed) solutions, refined cells, Newton evaluations, validation.
    """
    options = options or InverseMapOptions()
    H = np.asarray(H, dtype=float)
    stats = InverseMapStats()
    line = np.full(H.shape, np.nan)
    pixel = np.full(H.shape, np.nan)
    has_h = np.isfinite(H)
    if not has_h.any():
        return line, pixel, stats
    lattice = _Lattice.solve(geometry, grid, H, options.coarse_step, stats) if geometry.monotonic else None
    if lattice is None:
        # over-scanning strip, or the lattice saw nothing (the tile is outside the swath or a
        # sliver of it lies between the nodes): the bracketed search decides per cell
        solve_cells(geometry.ground_to_image, grid, H, has_h, line, pixel, stats)
        return line, pixel, stats
    _newton_at_every_cell(geometry, grid, H, lattice, options, line, pixel, stats)
    validate(geometry.ground_to_image, grid, line, pixel, H, (geometry.lines, geometry.pixels),
             options.validation_samples, seed, stats)
    return line, pixel, stats


@dataclass
class _Lattice:
    """Exact (line, pixel) at every ``step``-th cell of a tile (map points X, Y), gaps filled."""

    step: int
    X: np.ndarray
    Y: np.ndarray
    line: np.ndarray
    pixel: np.ndarray

    @classmethod
    def solve(cls, geometry: RefinableStrip, grid: TileGrid, H: np.ndarray, step: int,
              stats: InverseMapStats) -> _Lattice | None:
        """The lattice of a tile at the DTM's heights there (where the DTM has none: filled from
        the neighbouring nodes, or the tile's mean); None if no node is seen."""
        R, C = H.shape
        S = int(step)
        nr, nc = (R - 1 + S - 1) // S + 1, (C - 1 + S - 1) // S + 1
        xs = grid.x0 + np.arange(nc) * S * grid.res
        ys = grid.y0 - np.arange(nr) * S * grid.res
        Hn = geometry.height_on_lattice(xs, ys)
        Hn = _fill(Hn, np.isfinite(Hn))
        if not np.isfinite(Hn).any():
            Hn = np.full((nr, nc), float(np.nanmean(H)))
        X, Y = np.meshgrid(xs, ys)
        ln, pn = geometry.ground_to_image(X.ravel(), Y.ravel(), Hn.ravel())
        stats.exact_points += ln.size
        ln, pn = ln.reshape(nr, nc), pn.reshape(nr, nc)
        seen = np.isfinite(ln) & np.isfinite(pn)
        if not seen.any():
            return None
        return cls(S, X, Y, _fill(ln, seen), _fill(pn, seen))

    def starts(self, shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
        """(line, pixel) bilinear between the nodes at every cell of the tile."""
        gl = np.empty(shape)
        gp = np.empty(shape)
        choose_threading_layer()
        _upsample(self.line, self.pixel, self.step, gl, gp)
        return gl, gp


def _newton_at_every_cell(geometry: RefinableStrip, grid: TileGrid, H: np.ndarray, lattice: _Lattice,
                          options: InverseMapOptions, line: np.ndarray, pixel: np.ndarray,
                          stats: InverseMapStats) -> None:
    """In place: (line, pixel) of every cell with a height by Newton from the lattice's starts;
    cells that do not converge by the bracketed search."""
    finite = np.isfinite(H)
    # every cell has a height (the usual case): no gathering and scattering of 10^7 cells
    idx = None if finite.all() else np.flatnonzero(finite)
    gl, gp = lattice.starts(H.shape)
    p_P = _project_points(geometry, lattice.X, lattice.Y, lattice.step, H, idx)
    starts = (gl.ravel(), gp.ravel()) if idx is None else (gl.ravel()[idx], gp.ravel()[idx])
    ln, pn, status, evaluations = geometry.project_to_image_near(
        p_P, *starts, tol_line=options.tol_line, max_step_lines=options.max_step_lines, max_iter=options.max_iter)
    stats.refined_cells += status.size
    stats.newton_evaluations += int(evaluations.sum())
    ok = status == 0
    if idx is None:
        line.ravel()[:] = np.where(ok, ln, np.nan)
        pixel.ravel()[:] = np.where(ok, pn, np.nan)
    else:
        line.ravel()[idx] = np.where(ok, ln, np.nan)
        pixel.ravel()[idx] = np.where(ok, pn, np.nan)
    failed = np.flatnonzero(status == NO_CONVERGENCE)
    if failed.size:
        again = np.zeros(H.shape, dtype=bool)
        again.ravel()[failed if idx is None else idx[failed]] = True
        solve_cells(geometry.ground_to_image, grid, H, again, line, pixel, stats)


def _project_points(geometry: RefinableStrip, X, Y, S, H: np.ndarray, idx: np.ndarray | None) -> np.ndarray:
    """Project-frame points of the tile's cells ``idx`` (flat indices into ``H``; None: every
    cell) at their heights ``H`` (the tile's, rows x cols), from the lattice (X, Y).

    For a fixed map position the project frame point is affine in the height (ellipsoidal height
    moves the point along the ellipsoid normal; orthometric height differs from it by the geoid
    undulation there; a datum change is affine too), ``p = A(x, y) + H B(x, y)``. A and B are
    exact at the lattice nodes and bilinear between; over a few cells they are flat to far below a
    millimetre (tests/rectify/test_refined_map.py measures it).
    """
    Hf = np.ascontiguousarray(H, dtype=float).ravel()
    # two heights inside the cells' range (the geometry's fast conversion covers the DTM's)
    h0 = float(np.nanmin(Hf))
    h1 = h0 + max(float(np.nanmax(Hf)) - h0, 10.0)
    n0, n1 = (geometry.map_to_project(X.ravel(), Y.ravel(), np.full(X.size, h)) for h in (h0, h1))
    A = np.ascontiguousarray(n0.reshape(X.shape + (3,)))
    B = np.ascontiguousarray(((n1 - n0) / (h1 - h0)).reshape(X.shape + (3,)))
    every = idx is None
    cells = np.empty(0, dtype=np.int64) if idx is None else idx.astype(np.int64)
    out = np.empty((Hf.size if every else cells.size, 3))
    choose_threading_layer()
    _lattice_points(A, B, S, cells, every, H.shape[1], Hf, h0, out)
    return out


@numba.njit(parallel=True, cache=True)
def _lattice_points(A, B, S, cells, every, C, H, h0, out):
    nr, nc = A.shape[0], A.shape[1]
    for k in numba.prange(out.shape[0]):
        f = np.int64(k)
        if not every:
            f = cells[k]
        r, c = f // C, f % C
        i = min(r // S, nr - 2) if nr > 1 else 0
        fr = (r - i * S) / S if nr > 1 else 0.0
        i1 = i + 1 if nr > 1 else 0
        j = min(c // S, nc - 2) if nc > 1 else 0
        fc = (c - j * S) / S if nc > 1 else 0.0
        j1 = j + 1 if nc > 1 else 0
        w00, w01, w10, w11 = (1 - fr) * (1 - fc), (1 - fr) * fc, fr * (1 - fc), fr * fc
        dh = H[f] - h0
        for d in range(3):
            a = w00 * A[i, j, d] + w01 * A[i, j1, d] + w10 * A[i1, j, d] + w11 * A[i1, j1, d]
            b = w00 * B[i, j, d] + w01 * B[i, j1, d] + w10 * B[i1, j, d] + w11 * B[i1, j1, d]
            out[k, d] = a + dh * b


def _fill(a: np.ndarray, good: np.ndarray) -> np.ndarray:
    """``a`` with its gaps filled along rows (linear between, constant beyond the seen nodes),
    then along columns for rows without any."""
    out = np.array(a, dtype=float)
    row_ok = good.any(axis=1)
    _fill_rows(out, good)
    if row_ok.any() and not row_ok.all():
        out = _fill_rows(np.ascontiguousarray(out.T), np.ascontiguousarray(np.broadcast_to(row_ok, out.T.shape)))
        out = np.ascontiguousarray(out.T)
    return out


@numba.njit(cache=True)
def _fill_rows(a, good):
    """In place: the gaps of every row with a good value filled as ``np.interp`` does."""
    R, C = a.shape
    for i in range(R):
        last = -1
        for j in range(C):
            if not good[i, j]:
                continue
            if last < 0:
                for k in range(j):
                    a[i, k] = a[i, j]
            else:
                for k in range(last + 1, j):
                    a[i, k] = a[i, last] + (a[i, j] - a[i, last]) * (k - last) / (j - last)
            last = j
        if last >= 0:
            for k in range(last + 1, C):
                a[i, k] = a[i, last]
    return a


@numba.njit(parallel=True, cache=True)
def _upsample(ln, pn, S, gl, gp):
    """Bilinear interpolation of lattice values (every S-th cell) to every cell."""
    R, C = gl.shape
    nr, nc = ln.shape
    for r in numba.prange(R):
        i = min(r // S, nr - 2) if nr > 1 else 0
        fr = (r - i * S) / S if nr > 1 else 0.0
        i1 = i + 1 if nr > 1 else 0
        for c in range(C):
            j = min(c // S, nc - 2) if nc > 1 else 0
            fc = (c - j * S) / S if nc > 1 else 0.0
            j1 = j + 1 if nc > 1 else 0
            a = ln[i, j] + fc * (ln[i, j1] - ln[i, j])
            b = ln[i1, j] + fc * (ln[i1, j1] - ln[i1, j])
            gl[r, c] = a + fr * (b - a)
            a = pn[i, j] + fc * (pn[i, j1] - pn[i, j])
            b = pn[i1, j] + fc * (pn[i1, j1] - pn[i1, j])
            gp[r, c] = a + fr * (b - a)

