"""A reference orthoimage for control points: any raster rasterio opens, any CRS, any resolution.

:meth:`Reference.chip` resamples the reference onto a chip grid of the project's map CRS: the
chip's cell centres are transformed into the reference's CRS (pyproj), the reference window around
them is read with rasterio, averaged down first when the reference is finer than the chip (so that
a 0.2 m orthophoto does not alias on a 2.5 m chip), and resampled bicubically. Cells the reference
does not cover (or covers with nodata) are NaN.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
import pyproj
import rasterio
from rasterio.enums import Resampling
from rasterio.windows import Window

from scangeo.errors import InputFileError
from scangeo.match.strips import ChipGrid


@dataclass(frozen=True)
class ReferenceInfo:
    path: str
    crs: str
    resolution: float  # map units of the project CRS per reference pixel (mean of x and y)
    bounds: tuple[float, float, float, float]  # in the project CRS (box of the transformed corners)
    bands: tuple[int, ...]


class Reference:
    """A reference orthoimage seen from the project's map CRS."""

    def __init__(self, path: str | Path, map_crs: str, bands: tuple[int, ...] = ()) -> None:
        self.path = Path(path)
        try:
            self._src = rasterio.open(self.path)
        except rasterio.errors.RasterioIOError as exc:
            raise InputFileError(f"{self.path}: cannot read the reference orthoimage ({exc})") from exc
        src = self._src
        if src.crs is None:
            raise InputFileError(f"{self.path}: the reference orthoimage has no CRS (expected a georeferenced raster)")
        if bands and max(bands) > src.count:
            raise InputFileError(f"{self.path}: band {max(bands)} asked for matching, the reference has {src.count}")
        self.bands = tuple(bands) or tuple(range(1, min(src.count, 3) + 1))
        self._to_ref = pyproj.Transformer.from_crs(map_crs, src.crs.to_wkt(), always_xy=True)
        to_map = pyproj.Transformer.from_crs(src.crs.to_wkt(), map_crs, always_xy=True)
        b = src.bounds
        xs = np.array([b.left, b.right, b.right, b.left, 0.5 * (b.left + b.right)])
        ys = np.array([b.bottom, b.bottom, b.top, b.top, 0.5 * (b.bottom + b.top)])
        mx, my = to_map.transform(xs, ys)
        cx, cy = to_map.transform([xs[4], xs[4] + src.res[0]], [ys[4], ys[4] + src.res[1]])
        res = 0.5 * (abs(cx[1] - cx[0]) + abs(cy[1] - cy[0]))  # along the reference's axes, map units
        self.info = ReferenceInfo(str(self.path), src.crs.to_string(), float(res),
                                  (float(np.min(mx[:4])), float(np.min(my[:4])), float(np.max(mx[:4])),
                                   float(np.max(my[:4]))), self.bands)

    def close(self) -> None:
        self._src.close()

    def __enter__(self) -> Reference:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def chip(self, grid: ChipGrid) -> np.ndarray:
        """The reference's grey image (mean of its bands) on ``grid``, float32, NaN where it has none."""
        src = self._src
        X, Y = np.meshgrid(grid.xs(), grid.ys())
        rx, ry = self._to_ref.transform(X.ravel(), Y.ravel())
        inv = ~src.transform
        rx, ry = np.asarray(rx), np.asarray(ry)
        col, row = inv.a * rx + inv.b * ry + inv.c, inv.d * rx + inv.e * ry + inv.f
        col, row = np.asarray(col) - 0.5, np.asarray(row) - 0.5  # pixel centres at integers
        c0, c1 = int(math.floor(col.min())) - 3, int(math.ceil(col.max())) + 4
        r0, r1 = int(math.floor(row.min())) - 3, int(math.ceil(row.max())) + 4
        c0, r0 = max(c0, 0), max(r0, 0)
        c1, r1 = min(c1, src.width), min(r1, src.height)
        if c1 - c0 < 4 or r1 - r0 < 4:
            return np.full(X.shape, np.nan, np.float32)
        factor = max(1.0, grid.res / self.info.resolution)  # reference pixels per chip cell
        out_w, out_h = max(int(round((c1 - c0) / factor)), 4), max(int(round((r1 - r0) / factor)), 4)
        window = Window(c0, r0, c1 - c0, r1 - r0)
        data = src.read(list(self.bands), window=window, out_shape=(len(self.bands), out_h, out_w),
                        resampling=Resampling.average if factor > 1.0 else Resampling.nearest, masked=True)
        grey = data.astype(np.float32).mean(axis=0)
        valid = ~np.ma.getmaskarray(grey)
        grey = np.ma.filled(grey, np.nan).astype(np.float32)
        sx, sy = out_w / (c1 - c0), out_h / (r1 - r0)
        map_x = ((col + 0.5 - c0) * sx - 0.5).reshape(X.shape).astype(np.float32)
        map_y = ((row + 0.5 - r0) * sy - 0.5).reshape(X.shape).astype(np.float32)
        chip = cv2.remap(grey, map_x, map_y, cv2.INTER_CUBIC, borderMode=cv2.BORDER_CONSTANT, borderValue=np.nan)
        inside = cv2.remap(valid.astype(np.float32), map_x, map_y, cv2.INTER_LINEAR,
                           borderMode=cv2.BORDER_CONSTANT, borderValue=0.0)
        chip[inside < 0.999] = np.nan
        return chip
