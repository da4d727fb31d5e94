"""A GDAL VRT that stacks the bands of a flight line's orthoimages: one dataset of every sensor's bands.

The orthoimages of a platform's flight line lie on one lattice (one CRS and resolution, cell edges on
multiples of the resolution: :mod:`scangeo.rectify.output_grid`), so each is a window of their union
grid. The VRT has that union grid and, strip after strip, every band of each orthoimage as a
``SimpleSource`` placed at the orthoimage's offset: no resampling, a cell of the VRT is the cell of
the orthoimage at the same map position. Cells outside a strip's grid hold its band's nodata value,
which every band keeps. Band descriptions name the sensor and the band (``vnir: 450 nm``); each
band's metadata gives ``sensor``, ``strip``, ``band`` and the wavelength when known. The orthoimages
are named relative to the VRT (it moves with its folder). Bands of different data types are
stacked in the type that holds them all (numpy's promotion: uint8 and uint16 give UInt16).
"""
from __future__ import annotations

import math
import os
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import rasterio

from scangeo.atomic import write_text
from scangeo.errors import GeometryError, InputFileError
from scangeo.rectify.output_grid import OutputGrid

#: numpy dtype name -> GDAL's data type name in a VRT
GDAL_TYPES = {"uint8": "Byte", "int8": "Int8", "uint16": "UInt16", "int16": "Int16", "uint32": "UInt32",
              "int32": "Int32", "uint64": "UInt64", "int64": "Int64", "float32": "Float32", "float64": "Float64"}


@dataclass(frozen=True)
class StackMember:
    """One orthoimage of the stack: its file, the sensor that recorded it and its strip id."""

    path: Path
    sensor: str
    strip: str


def _grid(src) -> OutputGrid:
    t = src.transform
    return OutputGrid(src.crs.to_wkt(), float(t.a), float(t.c), float(t.f), src.width, src.height)


def _nodata_text(value: float) -> str:
    return "nan" if math.isnan(value) else repr(float(value)) if not float(value).is_integer() else str(int(value))


def write_stack_vrt(path: Path, members: list[StackMember], tags: dict[str, str] | None = None) -> Path:
    """Write the VRT ``path`` stacking the bands of ``members`` on their union grid (module docstring).

    Parameters
    ----------
    path : Path
        The VRT to write (atomically), in the orthoimages' folder or above it.
    members : list of StackMember
        The orthoimages, in the order their bands are stacked.
    tags : dict, optional
        Dataset metadata (the flight line, the variant ...).

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    InputFileError
        No member, or orthoimages of different CRSs or resolutions, or not on one lattice.
    """
    path = Path(path)
    if not members:
        raise InputFileError(f"{path}: a band stack of no orthoimage")
    infos = []
    for m in members:
        with rasterio.open(m.path) as src:
            infos.append((m, _grid(src), list(src.dtypes), src.nodata, list(src.descriptions),
                          [src.tags(b) for b in range(1, src.count + 1)], src.block_shapes[0], src.crs))
    crs = infos[0][7]
    for m, _, _, _, _, _, _, c in infos[1:]:
        if c != crs:
            raise InputFileError(f"{m.path}: CRS {c} differs from {infos[0][0].path}'s {crs}: one stack needs one CRS")
    grid = OutputGrid.union([i[1] for i in infos])
    try:
        offsets = [i[1].offset_in(grid) for i in infos]
    except GeometryError as exc:  # other resolutions, or not on one lattice
        raise InputFileError(f"{path}: the orthoimages {', '.join(str(m.path.name) for m in members)} are not on one "
                             f"grid ({exc})") from exc
    dtype = np.result_type(*[d for i in infos for d in i[2]])
    root = ET.Element("VRTDataset", rasterXSize=str(grid.width), rasterYSize=str(grid.height))
    ET.SubElement(root, "SRS", dataAxisToSRSAxisMapping="1,2").text = crs.to_wkt()
    ET.SubElement(root, "GeoTransform").text = ", ".join(repr(float(v)) for v in grid.transform.to_gdal())
    if tags:
        _metadata(root, tags)
    band = 0
    for (m, g, dtypes, nodata, descriptions, band_tags, block, _), (row, col) in zip(infos, offsets):
        href = Path(os.path.relpath(Path(m.path).resolve(), path.parent.resolve())).as_posix()
        for b, (src_dtype, desc, btags) in enumerate(zip(dtypes, descriptions, band_tags), start=1):
            band += 1
            name = desc or f"band {b}"
            el = ET.SubElement(root, "VRTRasterBand", dataType=GDAL_TYPES[np.dtype(dtype).name], band=str(band))
            meta = {"sensor": m.sensor, "strip": m.strip, "band": name, "source_band": str(b),
                    **{k: v for k, v in btags.items() if k in ("wavelength", "wavelength_units")}}
            _metadata(el, meta)
            ET.SubElement(el, "Description").text = f"{m.sensor}: {name}" if m.sensor else name
            if nodata is not None:
                ET.SubElement(el, "NoDataValue").text = _nodata_text(nodata)
            source = ET.SubElement(el, "SimpleSource")
            ET.SubElement(source, "SourceFilename", relativeToVRT="1").text = href
            ET.SubElement(source, "SourceBand").text = str(b)
            ET.SubElement(source, "SourceProperties", RasterXSize=str(g.width), RasterYSize=str(g.height),
                          DataType=GDAL_TYPES[np.dtype(src_dtype).name], BlockXSize=str(block[1]),
                          BlockYSize=str(block[0]))
            ET.SubElement(source, "SrcRect", xOff="0", yOff="0", xSize=str(g.width), ySize=str(g.height))
            ET.SubElement(source, "DstRect", xOff=str(col), yOff=str(row), xSize=str(g.width), ySize=str(g.height))
    ET.indent(root)
    return write_text(path, ET.tostring(root, encoding="unicode") + "\n")


def _metadata(parent: ET.Element, items: dict[str, str]) -> None:
    md = ET.SubElement(parent, "Metadata")
    for k, v in items.items():
        ET.SubElement(md, "MDI", key=k).text = str(v)


__all__ = ["GDAL_TYPES", "StackMember", "write_stack_vrt"]
