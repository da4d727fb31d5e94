"""Stand-in DTMs of an imported line: a surface through the GCPs' heights, or a plane at a given height.

PARGE projects name their DEM but do not carry it; a drone line over water has the sea surface as
its terrain. The adjustment of a line with full control needs no DTM (every GCP has its height);
rectification and the report's footprints do. The GCP surface is linear between the GCPs (a
Delaunay triangulation) and takes the nearest GCP's height outside them; the plane is the height
given. Band description and metadata say what each is, so nobody takes it for a DEM.
"""
from __future__ import annotations

import numpy as np
import rasterio
from affine import Affine
from scipy.interpolate import LinearNDInterpolator, NearestNDInterpolator

from scangeo.atomic import atomic_path

#: Cell size of the stand-ins (m): finer than the GCPs' spacing (tens of metres), coarse enough to be small.
CELL_M = 5.0

LABEL = "not a DEM: heights interpolated from the GCPs by scangeo import"


def _grid(box: tuple[float, float, float, float], cell: float):
    x0, y0 = np.floor(box[0] / cell) * cell, np.floor(box[1] / cell) * cell
    x1, y1 = np.ceil(box[2] / cell) * cell, np.ceil(box[3] / cell) * cell
    cols, rows = max(int(round((x1 - x0) / cell)), 2), max(int(round((y1 - y0) / cell)), 2)
    xs = x0 + (np.arange(cols) + 0.5) * cell
    ys = y1 - (np.arange(rows) + 0.5) * cell
    return Affine(cell, 0, x0, 0, -cell, y1), np.meshgrid(xs, ys)


def _write(path, z: np.ndarray, transform: Affine, crs_wkt: str, label: str) -> None:
    rows, cols = z.shape
    profile = dict(driver="GTiff", width=cols, height=rows, count=1, dtype="float32", crs=crs_wkt,
                   transform=transform, nodata=-9999.0, tiled=True, blockxsize=256, blockysize=256,
                   compress="deflate")
    with atomic_path(path) as tmp, rasterio.open(tmp, "w", **profile) as dst:
        dst.write(z.astype("float32"), 1)
        dst.set_band_description(1, label)
        dst.update_tags(SCANGEO_DTM=label)


def write_gcp_dtm(path, xyz: np.ndarray, box: tuple[float, float, float, float], crs_wkt: str) -> str:
    """Write the surface through the GCPs (map x, y, orthometric z) over ``box`` (map xmin, ymin, xmax,
    ymax); returns a sentence saying what it is."""
    transform, (gx, gy) = _grid(box, CELL_M)
    if len(xyz) < 3:
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
    _write(path, z, transform, crs_wkt, LABEL)
    return text


def write_plane_dtm(path, height_m: float, box: tuple[float, float, float, float], crs_wkt: str, why: str) -> str:
    """Write a horizontal plane at ``height_m`` (orthometric) over ``box``; ``why`` says what it stands for."""
    span = max(box[2] - box[0], box[3] - box[1])
    transform, (gx, _) = _grid(box, max(CELL_M, span / 200.0))
    label = f"not a DEM: a plane at {height_m:g} m, {why}"
    _write(path, np.full(gx.shape, height_m), transform, crs_wkt, label)
    return label


__all__ = ["CELL_M", "LABEL", "write_gcp_dtm", "write_plane_dtm"]
