"""The inverse map of a tile refined per cell: interpolated from a coarse lattice of exact
solutions, then one or two Newton steps of the sensor model at every cell.

:mod:`scangeo.rectify.inverse_map` interpolates (line, pixel) under error control; its checks of
the interpolation against exact solutions cost more than the interpolation saves (about 0.2
exact solutions per cell on a turbulent 10,000-line strip, plus the bookkeeping of the adaptive
lattice). Here the interpolation is only the start: ground -> image is solved at every cell by
Newton on time from the interpolated (line, pixel), which converges in one or two evaluations of
the orientation spline instead of the bracketed search's three to five (no search at all). The
result is the exact solution at every cell (Newton's last step under ``tol_line``, 0.01 lines by
default, leaves an error of about 4e-6 lines, against the tolerance's 0.05 px), so the interpolation error is zero by construction: each cell's last Newton
step is its own error check. What remains to control is convergence:

1. exact solutions (the geometry's bracketed ground -> image) on a coarse lattice of every
   ``coarse_step``-th cell, at the DTM's height there; nodes outside the swath are filled from the
   nearest seen node of their lattice row or column (a start for Newton, no more);
2. every cell with a DTM height starts from the bilinear interpolation of the lattice and runs
   Newton; a cell that has not converged after ``max_iter`` evaluations, or whose step leaves
   ``max_step_lines``, is solved by the bracketed ground -> image;
3. a random sample of seen cells is compared with the bracketed solutions (the validation of the
   lattice method, reported in the same statistics).

Strips that over-scan (pitch rates that make the scan line run backwards, so a ground point can
be seen twice) need the bracketed search's "first sighting" rule: every cell is solved by it.
"""
from __future__ import annotations

import numba
import numpy as np

from scangeo.rectify.inverse_map import InverseMapOptions, InverseMapStats, TileGrid, _validate


def build_refined_map(
    geometry,
    grid: TileGrid,
    H: np.ndarray,
    options: InverseMapOptions = InverseMapOptions(),
    seed: int = 0,
) -> tuple[np.ndarray, np.ndarray, InverseMapStats]:
    """(line, pixel) of every cell of a tile, solved per cell from interpolated starts.

    Parameters
    ----------
    geometry : a rectification strip geometry with ``ground_to_image`` (bracketed, map
        coordinates) and ``ground_to_image_near(x, y, H, line0, pixel0) -> (line, pixel, status,
        evaluations)`` (Newton from guesses; status 0 seen, 4 not converged, others unseen), and
        ``monotonic`` (False when the strip over-scans).
    grid : the tile's cell centres in map units.
    H : (rows, cols) DTM heights at the cell centres; NaN where the DTM has none.
    options : ``coarse_step`` of the lattice, ``validation_samples``.
    seed : seed of the validation sample.

    Returns
    -------
    line, pixel : (rows, cols) float64, NaN where the cell is unseen or has no height.
    stats : exact (bracketed) solutions, refined cells, Newton evaluations, validation.
    """
    H = np.asarray(H, dtype=float)
    R, C = H.shape
    stats = InverseMapStats()
    line = np.full((R, C), np.nan)
    pixel = np.full((R, C), np.nan)
    has_h = np.isfinite(H)
    if not has_h.any():
        return line, pixel, stats
    image_shape = (geometry.lines, geometry.pixels)
    if not getattr(geometry, "monotonic", False):
        return _bracketed(geometry, grid, H, has_h, line, pixel, stats)
    S = int(options.coarse_step)
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
        # the lattice saw nothing: the tile is outside the swath or a sliver of it lies between
        # the nodes; the bracketed search decides per cell
        return _bracketed(geometry, grid, H, has_h, line, pixel, stats)
    ln, pn = _fill(ln, seen), _fill(pn, seen)
    gl = np.empty((R, C))
    gp = np.empty((R, C))
    _upsample(ln, pn, S, gl, gp)
    idx = np.flatnonzero(has_h)
    rows, cols = np.divmod(idx, C)
    Hc = H.ravel()[idx]
    l0, p0 = gl.ravel()[idx], gp.ravel()[idx]
    newton = dict(tol_line=options.tol_line, max_step_lines=options.max_step_lines, max_iter=options.max_iter)
    if hasattr(geometry, "project_to_image_near"):
        p_P = _project_points(geometry, X, Y, S, rows, cols, Hc)
        l, p, status, evaluations = geometry.project_to_image_near(p_P, l0, p0, **newton)
    else:
        x, y = grid.xy(rows, cols)
        l, p, status, evaluations = geometry.ground_to_image_near(x, y, Hc, l0, p0, **newton)
    stats.refined_cells += idx.size
    stats.newton_evaluations += int(evaluations.sum())
    ok = status == 0
    line.ravel()[idx] = np.where(ok, l, np.nan)
    pixel.ravel()[idx] = np.where(ok, p, np.nan)
    again = status == 4  # no convergence: the bracketed search
    if again.any():
        r2, c2 = rows[again], cols[again]
        x2, y2 = grid.xy(r2, c2)
        line[r2, c2], pixel[r2, c2] = geometry.ground_to_image(x2, y2, H[r2, c2])
        stats.exact_points += r2.size
        stats.exact_cells += r2.size
    _validate(geometry.ground_to_image, grid, line, pixel, H, image_shape, options.validation_samples, seed, stats)
    return line, pixel, stats


def _bracketed(geometry, grid, H, cells, line, pixel, stats):
    """Every cell of ``cells`` (a mask) by the bracketed ground -> image."""
    rows, cols = np.nonzero(cells)
    x, y = grid.xy(rows, cols)
    line[rows, cols], pixel[rows, cols] = geometry.ground_to_image(x, y, H[rows, cols])
    stats.exact_points += rows.size
    stats.exact_cells += rows.size
    return line, pixel, stats


def _project_points(geometry, X, Y, S, rows, cols, H) -> np.ndarray:
    """Project-frame points of cells (rows, cols) at heights H, from the lattice (X, Y).

    For a fixed map position the project frame point is affine in the height (ellipsoidal height
    moves the point along the ellipsoid normal; orthometric height differs from it by the geoid
    undulation there; a datum change is affine too), ``p = A(x, y) + H B(x, y)``. A and B are
    exact at the lattice nodes and bilinear between; over a few cells they are flat to far below a
    millimetre (tests/rectify/test_refined_map.py measures it).
    """
    # two heights inside the cells' range (the geometry's fast conversion covers the DTM's)
    h0 = float(np.min(H))
    h1 = h0 + max(float(np.max(H)) - h0, 10.0)
    n0, n1 = (geometry.map_to_project(X.ravel(), Y.ravel(), np.full(X.size, h)) for h in (h0, h1))
    A = np.ascontiguousarray(n0.reshape(X.shape + (3,)))
    B = np.ascontiguousarray(((n1 - n0) / (h1 - h0)).reshape(X.shape + (3,)))
    out = np.empty((rows.size, 3))
    _lattice_points(A, B, S, rows.astype(np.int64), cols.astype(np.int64), np.ascontiguousarray(H, dtype=float),
                    h0, out)
    return out


@numba.njit(parallel=True, cache=True)
def _lattice_points(A, B, S, rows, cols, H, h0, out):
    nr, nc = A.shape[0], A.shape[1]
    for k in numba.prange(rows.size):
        r, c = rows[k], cols[k]
        i = min(r // S, nr - 2) if nr > 1 else 0
        fr = (r - i * S) / S if nr > 1 else 0.0
        i1 = i + 1 if nr > 1 else 0
        j = min(c // S, nc - 2) if nc > 1 else 0
        fc = (c - j * S) / S if nc > 1 else 0.0
        j1 = j + 1 if nc > 1 else 0
        w00, w01, w10, w11 = (1 - fr) * (1 - fc), (1 - fr) * fc, fr * (1 - fc), fr * fc
        dh = H[k] - h0
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

