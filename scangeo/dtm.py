"""DTM access: any GDAL raster through rasterio; heights and slopes at map or project-frame points.

Heights are orthometric in the map CRS (``MapFrame``). A raster in another CRS is warped into the
map CRS on reading (bilinear, at the resolution rasterio's default transform suggests). Sampling is
bilinear between pixel centres; points outside the hull of pixel centres or next to nodata give NaN
and a reason (``OUTSIDE`` or ``NODATA``).
"""
from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
import pyproj

from scangeo.errors import DTMError
from scangeo.frames import MapFrame
from scangeo.grid import RasterGrid
from scangeo.localmap import LocalPolynomialMap

log = logging.getLogger(__name__)

INSIDE, OUTSIDE, NODATA = 0, 1, 2
REASONS = {INSIDE: "", OUTSIDE: "outside the DTM", NODATA: "DTM has no data there"}


class DTM:
    """A digital terrain model in the map CRS.

    Parameters
    ----------
    grid : the heights (NaN = nodata) with their transform, in the map CRS.
    map_frame : the map CRS and project frame.
    source : file name (for messages).
    """

    def __init__(self, grid: RasterGrid, map_frame: MapFrame, source: str = "<dtm>") -> None:
        self.grid = grid
        self.map_frame = map_frame
        self.source = source
        finite = grid.values[np.isfinite(grid.values)]
        if finite.size == 0:
            raise DTMError(f"{source}: the DTM has no valid heights")
        self.h_min = float(finite.min())
        self.h_max = float(finite.max())
        self._local_maps: dict[tuple, LocalPolynomialMap] = {}
        self._max_maps: dict[tuple, np.ndarray] = {}

    @classmethod
    def open(cls, path, map_frame: MapFrame, band: int = 1) -> DTM:
        """Read a DTM raster (any GDAL format); warp it into the map CRS if it is in another CRS."""
        import rasterio
        from rasterio.warp import Resampling, calculate_default_transform, reproject

        path = Path(path)
        try:
            with rasterio.open(path) as src:
                if src.crs is None:
                    raise DTMError(f"{path}: the DTM has no CRS (expected a georeferenced raster)")
                values = src.read(band, masked=True).astype(np.float64).filled(np.nan)
                src_crs = pyproj.CRS.from_user_input(src.crs.to_wkt())
                if src_crs.equals(map_frame.crs, ignore_axis_order=True):
                    return cls(RasterGrid(values, src.transform, map_frame.crs), map_frame, str(path))
                dst_crs = rasterio.crs.CRS.from_wkt(map_frame.crs.to_wkt())
                transform, width, height = calculate_default_transform(
                    src.crs, dst_crs, src.width, src.height, *src.bounds
                )
                out = np.full((height, width), np.nan)
                reproject(values, out, src_transform=src.transform, src_crs=src.crs, src_nodata=np.nan,
                          dst_transform=transform, dst_crs=dst_crs, dst_nodata=np.nan,
                          resampling=Resampling.bilinear)
                log.info("warped %s from %s to the map CRS (%d x %d)", path, src.crs, width, height)
                return cls(RasterGrid(out, transform, map_frame.crs), map_frame, str(path))
        except rasterio.errors.RasterioIOError as exc:
            raise DTMError(f"{path}: cannot read the DTM ({exc})") from exc

    # --- map-space sampling -------------------------------------------------------------------
    def height_at_map(self, x, y) -> np.ndarray:
        """Orthometric height (m) at map points; NaN outside or at nodata."""
        return self.grid.sample(x, y)

    def height_on_lattice(self, xs, ys) -> np.ndarray:
        """Heights (len(ys), len(xs)) at the map points ``(xs[j], ys[i])`` (compiled; see
        ``RasterGrid.sample_lattice``); NaN outside or at nodata."""
        return self.grid.sample_lattice(xs, ys)

    def slope_at_map(self, x, y) -> tuple[np.ndarray, np.ndarray]:
        """(dH/dx, dH/dy) (m per map unit) at map points."""
        return self.grid.sample(x, y, gradient=True)[1]

    def reason_at_map(self, x, y) -> np.ndarray:
        """INSIDE, OUTSIDE or NODATA for map points (codes of ``REASONS``)."""
        col, row = self.grid.map_to_index(np.asarray(x, float), np.asarray(y, float))
        rows, cols = self.grid.shape
        outside = ~((col >= 0) & (col <= cols - 1) & (row >= 0) & (row <= rows - 1))
        value = self.grid.sample(x, y)
        return np.where(outside, OUTSIDE, np.where(np.isnan(value), NODATA, INSIDE))

    # --- project-frame sampling ---------------------------------------------------------------
    def sample_project(self, p_P: np.ndarray, local: LocalPolynomialMap | None = None):
        """DTM height and slope under project-frame points.

        Returns
        -------
        H_dtm : (n,) DTM height (m) at the points' map position.
        H_point : (n,) the points' own orthometric heights.
        slope : (n, 2) dH/dx, dH/dy of the DTM in map units.
        """
        p_P = np.atleast_2d(np.asarray(p_P, dtype=float))
        if local is not None:
            xyh = local(p_P)
            x, y, H = xyh[:, 0], xyh[:, 1], xyh[:, 2]
        else:
            x, y, H = self.map_frame.project_to_map(p_P)
        value, (gx, gy) = self.grid.sample(x, y, gradient=True)
        return value, H, np.column_stack([gx, gy])

    def height_condition(self, p_P: np.ndarray, eps: float = 0.01):
        """``H(p) - DTM(x(p), y(p))`` (m) at project points and its gradient w.r.t. p_P (n, 3).

        The gradient is exact for the bilinear DTM and the map conversion (central differences of
        the conversion, analytic bilinear slope).
        """
        p_P = np.atleast_2d(np.asarray(p_P, dtype=float))
        value, H, slope = self.sample_project(p_P)
        grad = np.empty_like(p_P)
        for k in range(3):
            d = np.zeros(3)
            d[k] = eps
            xp, yp, Hp = self.map_frame.project_to_map(p_P + d)
            xm, ym, Hm = self.map_frame.project_to_map(p_P - d)
            dx, dy, dH = (xp - xm) / (2 * eps), (yp - ym) / (2 * eps), (Hp - Hm) / (2 * eps)
            grad[:, k] = dH - slope[:, 0] * dx - slope[:, 1] * dy
        return H - value, grad

    def local_map(self, box_P) -> LocalPolynomialMap:
        """A polynomial P -> (x, y, H) valid over ``box_P`` ((3, 2) bounds), cached."""
        key = tuple(np.round(np.asarray(box_P, float).ravel(), 3))
        if key not in self._local_maps:
            def exact(p):
                x, y, H = self.map_frame.project_to_map(p)
                return np.column_stack([x, y, H])
            self._local_maps[key] = LocalPolynomialMap.fit(exact, box_P)
        return self._local_maps[key]

    def block_max(self, block: int = 8) -> np.ndarray:
        """Highest height within each ``block`` x ``block`` cell block and its 8 neighbours (+inf
        where nodata is near): lets ray casting jump over terrain it cannot touch. Cached."""
        key = ("block_max", block)
        if key not in self._max_maps:
            v = self.grid.values
            rows, cols = v.shape
            nbr, nbc = -(-rows // block), -(-cols // block)
            padded = np.full((nbr * block + 1, nbc * block + 1), -np.inf)
            padded[:rows, :cols] = np.where(np.isnan(v), np.inf, v)
            # a block's bilinear surface also uses the first row/column of the next block
            padded[rows:, :cols] = padded[rows - 1:rows, :cols]
            padded[:, cols:] = padded[:, cols - 1:cols]
            core = padded[:-1, :-1].reshape(nbr, block, nbc, block).max(axis=(1, 3))
            edge_r = padded[block::block, :-1].reshape(nbr, nbc, block).max(axis=2)
            edge_c = padded[:-1, block::block].reshape(nbr, block, nbc).max(axis=1)
            m = np.maximum(core, np.maximum(edge_r, edge_c))
            m = np.maximum(m, padded[block::block, block::block])
            dil = np.pad(m, 1, constant_values=-np.inf)
            out = np.max([dil[1 + a:1 + a + nbr, 1 + b:1 + b + nbc] for a in (-1, 0, 1) for b in (-1, 0, 1)], axis=0)
            self._max_maps[key] = out
        return self._max_maps[key]

    def cell_size(self) -> float:
        """The DTM's pixel size in map units (the smaller of the two)."""
        t = self.grid.transform
        return float(min(np.hypot(t.a, t.d), np.hypot(t.b, t.e)))
