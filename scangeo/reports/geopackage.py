"""Check-point residual vectors as a GeoPackage for GIS (QGIS): ``PROJECT/results/residuals.gpkg``.

Per variant two layers in the project CRS:

* ``check_<VARIANT>`` (points): one feature per check-point measurement (a check point measured in
  two strips gives two features) at the point's given map coordinates, with the attributes
  ``point, strip, variant, line, pixel`` (as measured), ``residual_line`` and ``residual_pixel``
  (model - measured: along track in lines, across track in pixels), ``w_line, w_pixel``, ``flagged``
  (1: failed its test or could not be projected), ``dx_m, dy_m`` (the ground error vector of the
  adjusted orientation at the point, map axes) and ``ground_error_m`` (its length);
* ``vectors_<VARIANT>`` (lines): the same vectors drawn from the point, exaggerated ``exaggeration``
  times (attribute of the layer's features), for a quick look without styling.

Written with pyogrio (GDAL's GPKG driver) to a temporary name and renamed.
"""
from __future__ import annotations

import struct
from pathlib import Path

import numpy as np

from scangeo.atomic import atomic_path
from scangeo.reports.residual_vectors import ResidualVectors


def _wkb_points(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    return np.array([struct.pack("<BIdd", 1, 1, float(a), float(b)) for a, b in zip(x, y)], dtype=object)


def _wkb_lines(x0, y0, x1, y1) -> np.ndarray:
    return np.array([struct.pack("<BII4d", 1, 2, 2, float(a), float(b), float(c), float(d))
                     for a, b, c, d in zip(x0, y0, x1, y1)], dtype=object)


def _fields(v: ResidualVectors) -> tuple[list[str], list[np.ndarray]]:
    names = ["point", "strip", "variant", "line", "pixel", "residual_line", "residual_pixel", "w_line", "w_pixel",
             "flagged", "dx_m", "dy_m", "ground_error_m"]
    data = [v.point.astype(str).astype(object), v.strip.astype(str).astype(object),
            np.full(len(v), v.variant, dtype=object), v.line, v.pixel, v.d_line, v.d_pixel, v.w_line, v.w_pixel,
            v.flagged.astype(np.int32), v.dx_m, v.dy_m, np.hypot(v.dx_m, v.dy_m)]
    return names, data


def write_geopackage(path, vectors: list[ResidualVectors], crs: str, exaggeration: float = 100.0) -> Path:
    """Write the residual vectors of every variant to a GeoPackage (layers as in the module doc)."""
    import pyproj
    from pyogrio.raw import write as ogr_write

    path = Path(path)
    wkt = pyproj.CRS.from_user_input(crs).to_wkt()
    with atomic_path(path) as tmp:
        for v in vectors:
            names, data = _fields(v)
            ogr_write(tmp, _wkb_points(v.x, v.y), data, names, layer=f"check_{v.variant}", driver="GPKG",
                      geometry_type="Point", crs=wkt)
            ok = np.isfinite(v.dx_m) & np.isfinite(v.dy_m)
            ex = np.full(int(ok.sum()), float(exaggeration))
            ogr_write(tmp, _wkb_lines(v.x[ok], v.y[ok], v.x[ok] + exaggeration * v.dx_m[ok],
                                      v.y[ok] + exaggeration * v.dy_m[ok]),
                      [d[ok] for d in data] + [ex], names + ["exaggeration"], layer=f"vectors_{v.variant}",
                      driver="GPKG", geometry_type="LineString", crs=wkt)
    return path


__all__ = ["write_geopackage"]
