"""STAC Items of the orthoimages and of the corrected laser strips: one JSON file beside each file.

An item (STAC 1.1, written with pystac; docs/run.md) holds the raster's footprint as a WGS 84
polygon and bbox (the grid's edges, densified, so a projected grid's curved edges stay inside), one
``data`` asset (the GeoTIFF, by a relative href), the projection extension (``proj:code`` or
``proj:wkt2``, ``proj:shape``, ``proj:transform``, ``proj:bbox`` in the map CRS) and scangeo's own
properties: the project, the variant, the strip (absent for the mosaic), the orientation and sigma0
from the GeoTIFF's tags. The project has no calendar date (its time base is seconds of a GPS week or
day), so ``datetime`` is when the item was written and ``scangeo:time_span_s`` the strip's line times.

A platform's orthoimages (several sensors) also name ``scangeo:sensor`` and ``scangeo:flight_line``; a
strip with a co-registration layer (``NAME.coregistration.tif``, an adjusted variant:
:mod:`scangeo.rectify.coregistration_layer`) has it as the asset ``coregistration`` and its summary as
``scangeo:coregistration_reference`` (the strip it is registered to) and ``scangeo:coregistration_sigma_m``
(``median`` and ``max`` of the propagated 1-sigma relative ground displacement, metres, over the grid of
``coregistration.json``).
"""
from __future__ import annotations

import datetime
import json
from pathlib import Path

import numpy as np
import pystac
import rasterio
from pyproj import CRS, Transformer
from pystac.extensions.pointcloud import PhenomenologyType, PointcloudExtension, Schema, SchemaType
from pystac.extensions.projection import ProjectionExtension

from scangeo.atomic import write_text

#: An item's file name beside its raster: ``01.tif`` -> ``01.stac.json``.
SUFFIX = ".stac.json"


def item_path(raster: Path) -> Path:
    return raster.with_name(raster.stem + SUFFIX)


def _footprint(bounds, crs: CRS, samples: int = 11) -> tuple[dict, list[float]]:
    """The grid's outline in WGS 84 (lon, lat), ``samples`` points per edge, and its bbox."""
    xmin, ymin, xmax, ymax = bounds
    t = np.linspace(0.0, 1.0, samples)[:-1]
    dx, dy = (xmax - xmin) * t, (ymax - ymin) * t
    x = np.concatenate([xmin + dx, np.full_like(t, xmax), xmax - dx, np.full_like(t, xmin)])
    y = np.concatenate([np.full_like(t, ymin), ymin + dy, np.full_like(t, ymax), ymax - dy])
    lon, lat = Transformer.from_crs(crs, CRS.from_epsg(4326), always_xy=True).transform(x, y)
    ring = [[round(float(a), 8), round(float(b), 8)] for a, b in zip(lon, lat)]
    ring.append(ring[0])
    xs, ys = [p[0] for p in ring], [p[1] for p in ring]
    bbox = [min(xs), min(ys), max(xs), max(ys)]
    return {"type": "Polygon", "coordinates": [ring]}, bbox


def stac_item(raster: Path, project_name: str, variant: str, properties: dict | None = None) -> pystac.Item:
    """The STAC Item of one orthoimage or mosaic (module docstring)."""
    with rasterio.open(raster) as src:
        crs = CRS.from_user_input(src.crs.to_wkt())
        bounds, shape, transform, tags = src.bounds, [src.height, src.width], src.transform, src.tags()
    geometry, bbox = _footprint(bounds, crs)
    strip = tags.get("strip")
    props = {"scangeo:project": project_name, "scangeo:variant": variant,
             **({"scangeo:strip": strip} if strip else {}),
             **({"scangeo:orientation": tags["orientation"]} if tags.get("orientation") else {}),
             **({"scangeo:sigma0": float(tags["sigma0"])} if tags.get("sigma0") else {}),
             **({f"scangeo:{k}": tags[k] for k in ("sensor", "flight_line") if tags.get(k)}),
             **(properties or {})}
    now = datetime.datetime.now(datetime.UTC).replace(microsecond=0)
    name = f"{project_name}-{variant}-{raster.stem}"
    item = pystac.Item(name, geometry, bbox, now, props)
    item.common_metadata.created = now
    item.add_asset("data", pystac.Asset(f"./{raster.name}", title=f"{variant} {raster.stem}",
                                        media_type=pystac.MediaType.GEOTIFF, roles=["data"]))
    proj = ProjectionExtension.ext(item, add_if_missing=True)
    authority = crs.to_authority()
    proj.apply(code=":".join(authority) if authority else None, wkt2=None if authority else crs.to_wkt(),
               shape=shape, transform=[float(v) for v in list(transform)[:6]],
               bbox=[float(v) for v in bounds])
    return item


def write_stac_items(project_root: Path, variant: str, rasters: list[Path], time_spans: dict | None = None,
                     coregistration: dict | None = None) -> list[Path]:
    """Write ``NAME.stac.json`` beside every raster (atomically); returns the item files.

    time_spans : per strip id, the first and last line time (seconds of the project's time base).
    coregistration : per strip id, its co-registration layer's ``path``, ``reference``, ``median_m`` and
        ``max_m`` (``BatchResult.coregistration``).
    """
    out = []
    for raster in rasters:
        raster = Path(raster)
        extra: dict = {}
        if time_spans and raster.stem in time_spans:
            extra["scangeo:time_span_s"] = list(time_spans[raster.stem])
        co = (coregistration or {}).get(raster.stem)
        if co is not None:
            extra["scangeo:coregistration_reference"] = co["reference"]
            extra["scangeo:coregistration_sigma_m"] = {"median": co["median_m"], "max": co["max_m"]}
        item = stac_item(raster, Path(project_root).resolve().name, variant, extra)
        if co is not None:
            layer = Path(co["path"])
            item.add_asset("coregistration", pystac.Asset(
                f"./{layer.name}", media_type=pystac.MediaType.COG,
                title=f"{variant} {raster.stem}: 1-sigma relative ground displacement to strip {co['reference']} (m)",
                roles=["metadata"]))
        path = item_path(raster)
        write_text(path, json.dumps(item.to_dict(include_self_link=False), indent=1) + "\n")
        out.append(path)
    return out


def _schema_type(dtype) -> SchemaType:
    kind = np.dtype(dtype).kind
    return SchemaType.FLOATING if kind == "f" else (SchemaType.SIGNED if kind == "i" else SchemaType.UNSIGNED)


def pointcloud_item(path: Path, project_name: str, variant: str, crs: str, properties: dict | None = None
                    ) -> pystac.Item:
    """The STAC Item of one corrected laser strip (module docstring)."""
    import laspy  # start-up cost: laspy loads when a point cloud is described

    with laspy.open(str(path)) as f:
        h = f.header
        count = int(h.point_count)
        xmin, ymin, xmax, ymax = float(h.mins[0]), float(h.mins[1]), float(h.maxs[0]), float(h.maxs[1])
        dims = [(d.name, d.num_bits // 8 if d.num_bits else np.dtype(d.dtype).itemsize, d.dtype)
                for d in h.point_format.dimensions if d.dtype is not None]
    map_crs = CRS.from_user_input(crs)
    geometry, bbox = _footprint((xmin, ymin, xmax, ymax), map_crs)
    now = datetime.datetime.now(datetime.UTC).replace(microsecond=0)
    props = {"scangeo:project": project_name, "scangeo:variant": variant, "scangeo:strip": path.stem,
             **(properties or {})}
    item = pystac.Item(f"{project_name}-{variant}-{path.stem}", geometry, bbox, now, props)
    item.common_metadata.created = now
    laz = path.suffix.lower() == ".laz"
    item.add_asset("data", pystac.Asset(f"./{path.name}", title=f"{variant} {path.stem}",
                                        media_type="application/vnd.laszip" if laz else "application/vnd.las",
                                        roles=["data"]))
    pc = PointcloudExtension.ext(item, add_if_missing=True)
    pc.apply(count=count, type=PhenomenologyType.LIDAR, encoding="LASzip" if laz else "LAS",
             schemas=[Schema({"name": n, "size": int(size), "type": _schema_type(dt)}) for n, size, dt in dims])
    proj = ProjectionExtension.ext(item, add_if_missing=True)
    authority = map_crs.to_authority()
    proj.apply(code=":".join(authority) if authority else None, wkt2=None if authority else map_crs.to_wkt(),
               bbox=[xmin, ymin, xmax, ymax])
    return item


def write_pointcloud_items(project_root: Path, variant: str, files: list[Path], crs: str,
                           time_spans: dict | None = None) -> list[Path]:
    """Write ``NAME.stac.json`` beside every corrected strip (atomically); returns the item files.

    time_spans : per strip id, the GPS times of its first and last return (s).
    """
    out = []
    for path in map(Path, files):
        extra = {"scangeo:time_span_s": list(time_spans[path.stem])} if time_spans and path.stem in time_spans else {}
        item = pointcloud_item(path, Path(project_root).resolve().name, variant, crs, extra)
        target = item_path(path)
        write_text(target, json.dumps(item.to_dict(include_self_link=False), indent=1) + "\n")
        out.append(target)
    return out


__all__ = ["SUFFIX", "item_path", "pointcloud_item", "stac_item", "write_pointcloud_items", "write_stac_items"]
