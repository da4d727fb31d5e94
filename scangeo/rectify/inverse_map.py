"""The inverse map of a tile: (line, pixel) of every output cell, and what building it cost.

Two ways, both exact at every cell:

* a geometry that can refine (:class:`scangeo.rectify.refined_map.RefinableStrip`, the geometry
  core through :class:`scangeo.rectify.core_geometry.CoreStripGeometry`) gets the refined map:
  exact solutions on a coarse lattice, Newton from interpolated starts at every cell
  (:func:`scangeo.rectify.refined_map.build_refined_map`);
* any other :class:`scangeo.rectify.geometry.MapStripGeometry` (the analytic geometries of the
  tests, a user's own) has its ``ground_to_image`` asked at every cell (:func:`solve_every_cell`).

Either way a random sample of cells is compared with the geometry's ``ground_to_image`` afterwards
(:func:`validate`) and the largest difference is reported in :class:`InverseMapStats`.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from scangeo.errors import RectifyOptionsError

#: ``ground_to_image(x, y, H) -> (line, pixel)``: map points to fractional image coordinates.
GroundToImage = Callable[[np.ndarray, np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]


@dataclass(frozen=True)
class InverseMapOptions:
    """Settings of the refined inverse map.

    Parameters
    ----------
    max_error_px : tolerance of the validation sample, image pixels (largest of |d line|,
        |d pixel|); a larger error found there is logged as a warning.
    validation_samples : cells per tile compared with the geometry's ``ground_to_image``.
    coarse_step : lattice spacing of the exact starts, cells.
    tol_line : Newton's last step below this many lines ends it (the error left is of the order
        of its square: about 4e-6 lines for 0.01 on a turbulent strip).
    max_step_lines, max_iter : a longer step or more evaluations hand the cell to the bracketed
        ground -> image.
    """

    max_error_px: float = 0.05
    validation_samples: int = 256
    coarse_step: int = 4
    tol_line: float = 1e-2
    max_step_lines: float = 64.0
    max_iter: int = 8

    def __post_init__(self) -> None:
        if not self.max_error_px > 0:
            raise RectifyOptionsError(f"inverse map: max_error_px must be positive, got {self.max_error_px}")
        if self.coarse_step < 1:
            raise RectifyOptionsError(f"inverse map: coarse_step must be at least 1, got {self.coarse_step}")
        if not (0 < self.tol_line <= min(0.1, self.max_error_px)):
            raise RectifyOptionsError(
                f"inverse map: tol_line must be in (0, min(0.1, max_error_px)], got {self.tol_line}")
        if not (self.max_step_lines > 0 and self.max_iter >= 1):
            raise RectifyOptionsError("inverse map: max_step_lines must be positive and max_iter at least 1")


@dataclass
class InverseMapStats:
    """What building an inverse map cost and achieved."""

    #: bracketed (exact) ground -> image solutions: lattice nodes, fallbacks, cells solved directly
    exact_points: int = 0
    #: cells solved by the bracketed search (not refined)
    exact_cells: int = 0
    validated: int = 0
    max_error_px: float = 0.0
    refined_cells: int = 0
    newton_evaluations: int = 0

    def merge(self, other: InverseMapStats) -> None:
        self.exact_points += other.exact_points
        self.exact_cells += other.exact_cells
        self.refined_cells += other.refined_cells
        self.newton_evaluations += other.newton_evaluations
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


def solve_cells(solve: GroundToImage, grid: TileGrid, H: np.ndarray, cells: np.ndarray, line: np.ndarray,
                pixel: np.ndarray, stats: InverseMapStats) -> None:
    """In place: (line, pixel) of the cells of the mask ``cells`` by ``solve`` (exact)."""
    rows, cols = np.nonzero(cells)
    x, y = grid.xy(rows, cols)
    line[rows, cols], pixel[rows, cols] = solve(x, y, H[rows, cols])
    stats.exact_points += rows.size
    stats.exact_cells += rows.size


def solve_every_cell(solve: GroundToImage, grid: TileGrid, H: np.ndarray) -> tuple[np.ndarray, np.ndarray,
                                                                                    InverseMapStats]:
    """(line, pixel, stats) of every cell with a height, each by ``solve``; NaN elsewhere."""
    H = np.asarray(H, dtype=float)
    line = np.full(H.shape, np.nan)
    pixel = np.full(H.shape, np.nan)
    stats = InverseMapStats()
    solve_cells(solve, grid, H, np.isfinite(H), line, pixel, stats)
    return line, pixel, stats


def validate(solve: GroundToImage, grid: TileGrid, line: np.ndarray, pixel: np.ndarray, H: np.ndarray,
             image_shape: tuple[int, int], n: int, seed: int, stats: InverseMapStats) -> None:
    """Compare a random sample of ``n`` seen cells with ``solve``; the largest difference goes
    into ``stats.max_error_px`` (infinite where ``solve`` does not see a cell the map saw)."""
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
