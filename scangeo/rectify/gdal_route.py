"""The GDAL route, for comparison: warp a strip with geolocation arrays (rasterio ``reproject``).

GDAL's geolocation-array transformer inverts the image -> ground mapping given as per-pixel map
coordinates (an IGM) and warps the image onto a grid. It is the usual baseline for rectifying
line-scanner imagery; scangeo's benchmark and tests compare against it on the same grid.

Convention: ``reproject(src_geoloc_array=...)`` takes the arrays as the map coordinates of the
pixels' *top-left corners* (GDAL's pixel-is-area), so they are computed at ``(line - 0.5,
pixel - 0.5)``; arrays of pixel centres shift the result by half a pixel.
"""
from __future__ import annotations

import numpy as np
from rasterio.crs import CRS
from rasterio.warp import Resampling, reproject

from scangeo.rectify.geometry import MapStripGeometry
from scangeo.rectify.output_grid import OutputGrid

_RESAMPLING = {"nearest": Resampling.nearest, "bilinear": Resampling.bilinear, "cubic": Resampling.cubic}


def corner_geolocation(geometry: MapStripGeometry, chunk_lines: int = 512) -> tuple[np.ndarray, np.ndarray]:
    """Map x, y (lines, pixels) of the pixels' top-left corners on the DTM (image -> ground)."""
    x = np.empty((geometry.lines, geometry.pixels))
    y = np.empty_like(x)
    pixels = np.arange(geometry.pixels, dtype=float) - 0.5
    for start in range(0, geometry.lines, chunk_lines):
        stop = min(start + chunk_lines, geometry.lines)
        ll, pp = np.meshgrid(np.arange(start, stop, dtype=float) - 0.5, pixels, indexing="ij")
        gx, gy, _ = geometry.image_to_ground(ll.ravel(), pp.ravel())
        x[start:stop] = gx.reshape(ll.shape)
        y[start:stop] = gy.reshape(ll.shape)
    return x, y


def warp_with_geolocation(
    image: np.ndarray,
    x: np.ndarray,
    y: np.ndarray,
    grid: OutputGrid,
    resampling: str = "bilinear",
    nodata: float = 0,
    threads: int = 2,
) -> np.ndarray:
    """Warp ``image`` (bands, lines, pixels) onto ``grid`` with geolocation arrays (corner x, y)."""
    out = np.full((image.shape[0], grid.height, grid.width), nodata, dtype=image.dtype)
    crs = CRS.from_user_input(grid.crs)
    reproject(
        image, out, src_crs=crs, src_geoloc_array=np.stack([x, y]), dst_transform=grid.transform,
        dst_crs=crs, resampling=_RESAMPLING[resampling], src_nodata=None, dst_nodata=nodata,
        num_threads=threads,
    )
    return out
