"""How well the sensors of a platform line up: the propagated relative ground displacement of their rays.

Two strips of different sensors on one flight line see the same ground. Where a ground point ``G`` is
seen in both, each strip's adjusted orientation puts the pixel that sees it at ``G``; an error ``dx`` of
the adjusted unknowns moves the two placements by ``M_S dx`` and ``M_R dx`` (horizontal, metres:
:func:`scangeo.adjustment.sensitivity.ground_sensitivity`). Their **relative displacement** ``(M_S -
M_R) dx`` is what misregisters the sensors' orthoimages, with the covariance

    C = (M_S - M_R) Cov(x) (M_S - M_R)^T         (2 x 2, from the joint covariance of the unknowns)

The unknowns the two strips share (their flight line's spline and GPS/IMU corrections) cancel to the
extent that both rays are moved alike; the two sensors' mountings and calibrations do not. The figure
reported is the **1-sigma radial displacement** ``sqrt(trace C)`` (metres): the rms length of the
displacement vector. :func:`coregistration` gives it on a grid of each strip's image, relative to the
flight line's reference strip (the first strip on it, of the first sensor); :func:`ground_precision`
the absolute counterpart ``sqrt(trace(M Cov(x) M^T))`` of one strip.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from scangeo.adjustment.results import VariantResult
from scangeo.adjustment.sensitivity import GroundSensitivity, ground_sensitivity, image_grid

#: The grid (lines x pixels of the strip's image) on which the displacement is propagated.
GRID = (25, 9)


@dataclass(frozen=True)
class PropagatedGrid:
    """A propagated 1-sigma horizontal displacement on a grid of a strip's image.

    ``line``, ``pixel`` (k,) the image positions of ``strip`` (those that hit the DTM, and for a relative
    displacement are seen by ``reference`` too); ``covariance`` (k, 2, 2) of the displacement (x, y in
    metres, project frame); ``sigma`` (k,) its radial 1-sigma ``sqrt(trace)``, metres. ``grid``: the
    grid's shape, ``index`` each position's place in it (row-major). ``reference`` is None for an
    absolute precision.
    """

    strip: str
    reference: str | None
    flight_line: str
    grid: tuple[int, int]
    index: np.ndarray
    line: np.ndarray
    pixel: np.ndarray
    covariance: np.ndarray
    sigma: np.ndarray

    def summary(self) -> dict:
        """Median and largest sigma (m) and the number of positions: for reports and STAC items."""
        if self.sigma.size == 0:
            return {"n": 0, "median_m": None, "max_m": None}
        return {"n": int(self.sigma.size), "median_m": float(np.median(self.sigma)),
                "max_m": float(self.sigma.max())}

    def as_dict(self) -> dict:
        """JSON-able: the strip, its reference, the grid and the sigma per position (m)."""
        return {"strip": self.strip, "reference": self.reference, "flight_line": self.flight_line,
                "grid": list(self.grid), "line": self.line.round(3).tolist(), "pixel": self.pixel.round(3).tolist(),
                "sigma_m": self.sigma.round(6).tolist(),
                "covariance_m2": self.covariance.reshape(-1, 4).round(9).tolist(), **self.summary()}


def _propagate(result: VariantResult, D: sp.csr_matrix) -> np.ndarray:
    """``D Cov(x) D^T`` per pair of rows of ``D`` (2 k x n, the layout's unscaled columns): (k, 2, 2)."""
    sol, stats = result.adjustment.solution, result.adjustment.statistics
    scale = sol.system.scale
    solver = stats.inverse.partial_solver()
    Ds = (D @ sp.diags(1.0 / scale)).tocsr()
    k = Ds.shape[0] // 2
    out = np.zeros((k, 2, 2))
    for i in range(k):
        rows = Ds[2 * i:2 * i + 2]
        cols = np.unique(rows.indices)
        if cols.size == 0:
            continue
        B = rows[:, cols].toarray().T                    # (m, 2)
        Z = solver.solve(cols, B, cols)                  # N^-1 B on the columns
        out[i] = B.T @ Z
    return 0.5 * (out + np.swapaxes(out, 1, 2)) * stats.sigma0 ** 2


def _grid(result: VariantResult, strip: str, reference: str | None, g: GroundSensitivity, keep: np.ndarray,
          D: sp.csr_matrix, grid: tuple[int, int]) -> PropagatedGrid:
    cov = _propagate(result, D)
    sigma = np.sqrt(np.clip(np.trace(cov, axis1=1, axis2=2), 0.0, None))
    return PropagatedGrid(strip, reference, result.block.strips[strip].flight_line, grid, g.index[keep],
                          g.line[keep], g.pixel[keep], cov, sigma)


def ground_precision(result: VariantResult, strip: str, grid: tuple[int, int] = GRID) -> PropagatedGrid | None:
    """The propagated 1-sigma horizontal ground precision of a strip's pixels on a grid of its image.

    Parameters
    ----------
    result : VariantResult
        The adjusted variant.
    strip : str
        The strip's id.
    grid : tuple of 2 int
        Lines x pixels of the grid over the strip's image.

    Returns
    -------
    PropagatedGrid or None
        ``sqrt(trace(M Cov(x) M^T))`` (metres) at each position that hits the DTM; None when none does.
    """
    g = ground_sensitivity(result, strip, *image_grid(result, strip, grid))
    if g is None:
        return None
    return _grid(result, strip, None, g, np.arange(g.index.size), g.matrix, grid)


def relative_displacement(result: VariantResult, strip: str, reference: str,
                          grid: tuple[int, int] = GRID) -> PropagatedGrid | None:
    """The propagated 1-sigma relative ground displacement of two strips' rays on a grid of ``strip``.

    Parameters
    ----------
    result : VariantResult
        The adjusted variant.
    strip, reference : str
        The two strips (of different sensors, on one flight line); the grid is over ``strip``'s image.
    grid : tuple of 2 int
        Lines x pixels of the grid.

    Returns
    -------
    PropagatedGrid or None
        ``sqrt(trace C)`` (metres) where ``reference`` sees the ground point too; None where nothing is
        seen by both.
    """
    g = ground_sensitivity(result, strip, *image_grid(result, strip, grid))
    if g is None:
        return None
    line_r, pixel_r, status = result.geometry(reference).ground_to_image(g.p_P)
    seen = np.flatnonzero((status & ~16) == 0)        # inside the reference's image (over-scanning allowed)
    if seen.size == 0:
        return None
    r = ground_sensitivity(result, reference, line_r[seen], pixel_r[seen])
    if r is None:
        return None
    keep = seen[r.index]
    rows = np.column_stack([2 * keep, 2 * keep + 1]).ravel()
    D = (g.matrix[rows] - r.matrix).tocsr()
    return _grid(result, strip, reference, g, keep, D, grid)


def coregistration(result: VariantResult, grid: tuple[int, int] = GRID) -> list[PropagatedGrid]:
    """The relative displacement of every strip of a platform's flight line to the flight line's
    reference strip (its first strip of another sensor than the strip's, the first sensor's where it
    can be); nothing for strips alone on their flight line or of one sensor.

    Parameters
    ----------
    result : VariantResult
        The adjusted variant.
    grid : tuple of 2 int
        Lines x pixels of the grid over each strip's image.

    Returns
    -------
    list of PropagatedGrid
        One per strip that has a reference, in the block's order (computed once per result and grid).
    """
    cached = result.__dict__.setdefault("_coregistration", {})
    if grid not in cached:
        cached[grid] = _coregistration(result, grid)
    return cached[grid]


def _coregistration(result: VariantResult, grid: tuple[int, int]) -> list[PropagatedGrid]:
    out = []
    block = result.block
    for line in block.flight_lines.values():
        strips = [sid for sid in line.strips if sid in block.strips]
        sensors = {sid: block.strips[sid].sensor for sid in strips}
        if len(set(sensors.values())) < 2:
            continue
        reference = strips[0]
        for sid in strips[1:]:
            if sensors[sid] == sensors[reference]:
                continue
            found = relative_displacement(result, sid, reference, grid)
            if found is not None:
                out.append(found)
    return out


__all__ = ["GRID", "PropagatedGrid", "coregistration", "ground_precision", "relative_displacement"]
