"""The true orthoimage: the scene's bands on the output grid (north-up, map CRS), as the images see it.

Values are the same digital numbers as the rendered images (without sensor noise), evaluated at
the centres of the output grid's cells, so a rectified image can be compared cell by cell.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
from affine import Affine

from scangeo.atomic import atomic_path
from scangeo.progress import no_progress
from scangeo.simulate.scene import BANDS, N_BANDS, dn_to_uint16, to_dn
from scangeo.simulate.terrain import Extent


def ortho_grid(extent: Extent, resolution_m: float) -> tuple[Affine, int, int]:
    """Transform, rows, cols of the output grid: cells aligned to multiples of the resolution."""
    xmin = np.floor(extent.xmin / resolution_m) * resolution_m
    ymax = np.ceil(extent.ymax / resolution_m) * resolution_m
    cols = int(np.ceil((extent.xmax - xmin) / resolution_m))
    rows = int(np.ceil((ymax - extent.ymin) / resolution_m))
    return Affine(resolution_m, 0.0, xmin, 0.0, -resolution_m, ymax), rows, cols


def write_truth_ortho(path: Path, scene, extent: Extent, resolution_m: float, crs, rows_per_chunk: int = 256,
                      progress=no_progress) -> None:
    """Write all bands of the scene on the output grid as a tiled, compressed GeoTIFF (atomically)."""
    import rasterio
    from rasterio.windows import Window

    transform, rows, cols = ortho_grid(extent, resolution_m)
    profile = dict(driver="GTiff", width=cols, height=rows, count=N_BANDS, dtype="uint16", crs=crs,
                   transform=transform, tiled=True, blockxsize=256, blockysize=256, compress="deflate",
                   predictor=2, interleave="band")
    xs = transform.c + (np.arange(cols) + 0.5) * transform.a
    with atomic_path(path) as tmp, rasterio.open(tmp, "w", **profile) as dst:
        for b, (name, lo, hi) in enumerate(BANDS, start=1):
            dst.set_band_description(b, f"{name} {lo}-{hi} um")
        for r0 in range(0, rows, rows_per_chunk):
            r1 = min(r0 + rows_per_chunk, rows)
            ys = transform.f + (np.arange(r0, r1) + 0.5) * transform.e
            X, Y = np.meshgrid(xs, ys)
            dn = dn_to_uint16(to_dn(scene.values(X.ravel(), Y.ravel())))
            dst.write(np.moveaxis(dn.reshape(r1 - r0, cols, N_BANDS), -1, 0), window=Window(0, r0, cols, r1 - r0))
            progress(r1, rows, "truth orthoimage")
