"""A stand-in DTM for an imported line whose DEM is not at hand: a surface through the GCPs' heights.

PARGE projects name their DEM but do not carry it. The adjustment of a line with full control needs
no DTM (every GCP has its height); rectification and the report's footprints do. The stand-in is
linear between the GCPs (a Delaunay triangulation) and takes the nearest GCP's height outside
them; its band description and metadata say what it is, so nobody takes it for a DEM.
"""
from __future__ import annotations

import numpy as np
import rasterio
from affine import Affine
from scipy.interpolate import LinearNDInterpolator, NearestNDInterpolator

from scangeo.atomic import atomic_path

#: Cell size of the stand-in (m): finer than the GCPs' spacing (tens of metres), coarse enough to be small.
CELL_M = 5.0

LABEL = "not a DEM: heights interpolated from the GCPs by scangeo import parge"


def write_gcp_dtm(path, xyz: np.ndarray | None, box: tuple[float, float, float, float], crs_wkt: str,
                  flat_height: float = 0.0) -> str:
    """Write the stand-in DTM over ``box`` (map xmin, ymin, xmax, ymax); returns a sentence saying what it is.

    ``xyz``: the GCPs' map coordinates and heights; None writes a plane at ``flat_height``.
    """
    x0, y0 = np.floor(box[0] / CELL_M) * CELL_M, np.floor(box[1] / CELL_M) * CELL_M
    x1, y1 = np.ceil(box[2] / CELL_M) * CELL_M, np.ceil(box[3] / CELL_M) * CELL_M
    cols, rows = int(round((x1 - x0) / CELL_M)), int(round((y1 - y0) / CELL_M))
    xs = x0 + (np.arange(cols) + 0.5) * CELL_M
    ys = y1 - (np.arange(rows) + 0.5) * CELL_M
    gx, gy = np.meshgrid(xs, ys)
    if xyz is None or len(xyz) == 0:
        z = np.full(gx.shape, flat_height)
        text = f"a plane at {flat_height:.1f} m ({LABEL.split(':')[0]}: no GCPs)"
    elif len(xyz) < 3:
        z = np.full(gx.shape, float(np.mean(xyz[:, 2])))
        text = f"a plane at the GCPs' mean height {z.flat[0]:.1f} m ({LABEL})"
    else:
        nearest = NearestNDInterpolator(xyz[:, :2], xyz[:, 2])
        try:
            z = LinearNDInterpolator(xyz[:, :2], xyz[:, 2])(gx, gy)
        except Exception:  # collinear GCPs (scipy's Qhull error): nearest heights only
            z = np.full(gx.shape, np.nan)
        z = np.where(np.isfinite(z), z, nearest(gx, gy))
        text = f"{LABEL} ({len(xyz)} GCPs, {CELL_M:g} m cells)"
    profile = dict(driver="GTiff", width=cols, height=rows, count=1, dtype="float32", crs=crs_wkt,
                   transform=Affine(CELL_M, 0, x0, 0, -CELL_M, y1), nodata=-9999.0, tiled=True, blockxsize=256,
                   blockysize=256, compress="deflate")
    with atomic_path(path) as tmp, rasterio.open(tmp, "w", **profile) as dst:
        dst.write(z.astype("float32"), 1)
        dst.set_band_description(1, LABEL)
        dst.update_tags(SCANGEO_DTM=LABEL)
    return text


__all__ = ["CELL_M", "LABEL", "write_gcp_dtm"]
