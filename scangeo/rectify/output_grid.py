"""The output grid of an orthoimage: map CRS, square cells, edges aligned to the resolution.

Every strip of a project is rectified onto a grid whose cell edges lie on integer multiples of the
resolution (in map units), so the grids of different strips share cell boundaries and a mosaic is
a plain window arithmetic. Cell ``(row, col)`` has its centre at
``(xmin + (col + 0.5) * res, ymax - (row + 0.5) * res)`` (rasterio's corner-based affine
convention: the transform maps the top-left corner of cell (0, 0)).
"""
from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
from affine import Affine
from rasterio.windows import Window

from scangeo.errors import GeometryError, RectifyOptionsError


@dataclass(frozen=True)
class OutputGrid:
    """A north-up grid of square cells in a map CRS.

    Parameters
    ----------
    crs : the map CRS as WKT (or anything rasterio accepts).
    resolution : cell size, map units (metres for projected CRSs).
    xmin, ymax : left and top edge of the grid, map units (multiples of ``resolution`` when built
        by :meth:`from_bounds`).
    width, height : number of columns and rows.
    """

    crs: str
    resolution: float
    xmin: float
    ymax: float
    width: int
    height: int

    def __post_init__(self) -> None:
        if not (self.resolution > 0 and math.isfinite(self.resolution)):
            raise RectifyOptionsError(f"output grid: resolution must be a positive number, got {self.resolution!r}")
        if self.width < 1 or self.height < 1:
            raise GeometryError(f"output grid: empty grid ({self.width} x {self.height} cells)")

    @classmethod
    def from_bounds(
        cls, crs: str, bounds: tuple[float, float, float, float], resolution: float
    ) -> OutputGrid:
        """The smallest aligned grid covering ``bounds = (xmin, ymin, xmax, ymax)`` (map units).

        Edges are snapped outwards to integer multiples of ``resolution``.
        """
        xmin, ymin, xmax, ymax = (float(v) for v in bounds)
        if not (resolution > 0):
            raise RectifyOptionsError(f"output grid: resolution must be positive, got {resolution!r}")
        if not all(math.isfinite(v) for v in (xmin, ymin, xmax, ymax)) or xmax <= xmin or ymax <= ymin:
            raise RectifyOptionsError(f"output grid: invalid bounds {bounds!r} (need xmin < xmax, ymin < ymax)")
        eps = 1e-9
        x0 = math.floor(xmin / resolution + eps) * resolution
        y0 = math.floor(ymin / resolution + eps) * resolution
        x1 = math.ceil(xmax / resolution - eps) * resolution
        y1 = math.ceil(ymax / resolution - eps) * resolution
        width = max(1, int(round((x1 - x0) / resolution)))
        height = max(1, int(round((y1 - y0) / resolution)))
        return cls(crs, float(resolution), x0, y1, width, height)

    @property
    def transform(self) -> Affine:
        """rasterio affine transform (top-left corner convention)."""
        return Affine(self.resolution, 0.0, self.xmin, 0.0, -self.resolution, self.ymax)

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) of the cell edges."""
        return (
            self.xmin,
            self.ymax - self.height * self.resolution,
            self.xmin + self.width * self.resolution,
            self.ymax,
        )

    @property
    def shape(self) -> tuple[int, int]:
        return self.height, self.width

    def x_of_col(self, col) -> np.ndarray:
        """Map x of cell-centre columns (fractional columns allowed)."""
        return self.xmin + (np.asarray(col, dtype=float) + 0.5) * self.resolution

    def y_of_row(self, row) -> np.ndarray:
        """Map y of cell-centre rows (fractional rows allowed)."""
        return self.ymax - (np.asarray(row, dtype=float) + 0.5) * self.resolution

    def col_of_x(self, x) -> np.ndarray:
        """Fractional column of map x (cell centres at integers)."""
        return (np.asarray(x, dtype=float) - self.xmin) / self.resolution - 0.5

    def row_of_y(self, y) -> np.ndarray:
        """Fractional row of map y (cell centres at integers)."""
        return (self.ymax - np.asarray(y, dtype=float)) / self.resolution - 0.5

    def tiles(self, size: int) -> Iterator[Window]:
        """Windows of at most ``size`` x ``size`` cells covering the grid, row by row."""
        for row in range(0, self.height, size):
            for col in range(0, self.width, size):
                yield Window(col, row, min(size, self.width - col), min(size, self.height - row))

    def offset_in(self, other: OutputGrid) -> tuple[int, int]:
        """(row, col) of this grid's top-left cell in ``other`` (both aligned, same resolution)."""
        if not math.isclose(self.resolution, other.resolution, rel_tol=1e-12):
            raise GeometryError(
                f"output grids differ in resolution ({self.resolution} and {other.resolution})"
            )
        col = (self.xmin - other.xmin) / self.resolution
        row = (other.ymax - self.ymax) / self.resolution
        if abs(col - round(col)) > 1e-6 or abs(row - round(row)) > 1e-6:
            raise GeometryError("output grids are not aligned to a common origin")
        return int(round(row)), int(round(col))

    @classmethod
    def union(cls, grids: list[OutputGrid]) -> OutputGrid:
        """The aligned grid covering all ``grids`` (same CRS and resolution)."""
        if not grids:
            raise GeometryError("output grid union of no grids")
        b = np.array([g.bounds for g in grids])
        return cls.from_bounds(
            grids[0].crs, (b[:, 0].min(), b[:, 1].min(), b[:, 2].max(), b[:, 3].max()), grids[0].resolution
        )

    def to_dict(self) -> dict:
        return {
            "resolution": self.resolution,
            "xmin": self.xmin,
            "ymax": self.ymax,
            "width": self.width,
            "height": self.height,
        }


def nice_resolution(value: float) -> float:
    """``value`` rounded to two significant digits (2.487 -> 2.5, 0.3142 -> 0.31)."""
    if not (value > 0 and math.isfinite(value)):
        raise GeometryError(f"cannot derive a resolution from the ground pixel size {value!r}")
    exponent = math.floor(math.log10(value)) - 1
    return float(round(value, -exponent))
