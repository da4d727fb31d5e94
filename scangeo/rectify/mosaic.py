"""A mosaic of rectified strips: every cell from the strip that sees it closest to nadir.

The strips' grids share one origin and resolution (edges on multiples of the resolution), so a
strip is a window of the mosaic's grid. Each strip's ``NAME.layers.tif`` holds the view zenith
angle (the angle between the ray to the sensor and the vertical) of its visible cells; per cell the
strip with the smallest angle wins. Work is done in tiles; the result is written like a strip's
orthoimage (working file, COG copy under a hidden name, rename).
"""
from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

import numpy as np
import rasterio
from rasterio.windows import Window

from scangeo.errors import InputFileError
from scangeo.progress import ProgressCallback, no_progress
from scangeo.rectify.geotiff import GeoTiffProfile, describe, finalise, remove_partials, working_profile
from scangeo.rectify.output_grid import OutputGrid

TILE = 1024


def _grid_of(src) -> OutputGrid:
    t = src.transform
    return OutputGrid(src.crs.to_wkt(), float(t.a), float(t.c), float(t.f), src.width, src.height)


def _view_zenith_band(layers) -> int:
    names = (layers.tags().get("layers") or "").split()
    if "view_zenith" not in names:
        raise InputFileError(f"{layers.name}: no view_zenith layer (rectify with the mosaic option)")
    return names.index("view_zenith") + 1


def build_mosaic(
    orthos: list[Path],
    output: Path,
    profile: GeoTiffProfile = GeoTiffProfile(),  # noqa: B008 (a frozen profile)
    progress: ProgressCallback = no_progress,
) -> Path:
    """Mosaic the orthoimages ``orthos`` (with their ``.layers.tif``) into ``output``."""
    output = Path(output)
    remove_partials(output)
    srcs, lays = [], []
    try:
        for p in orthos:
            srcs.append(rasterio.open(p))
            lays.append(rasterio.open(Path(p).with_name(Path(p).stem + ".layers.tif")))
        grids = [_grid_of(s) for s in srcs]
        grid = OutputGrid.union(grids)
        offsets = [g.offset_in(grid) for g in grids]
        first = srcs[0]
        dtype, count, nodata = first.dtypes[0], first.count, first.nodata
        bands_vz = [_view_zenith_band(lay) for lay in lays]
        work = Path(tempfile.mkdtemp(dir=output.parent, prefix=f".{output.name}.partial-"))
        try:
            working = work / "mosaic.tif"
            tiles = list(grid.tiles(TILE))
            with rasterio.open(working, "w", **working_profile(grid, count, dtype, nodata)) as dst:
                for i, w in enumerate(tiles):
                    dst.write(_mosaic_tile(w, srcs, lays, grids, offsets, bands_vz, count, dtype, nodata), window=w)
                    progress(i + 1, len(tiles), "mosaic")
                for b in range(1, count + 1):
                    dst.set_band_description(b, first.descriptions[b - 1] or f"band {b}")
                    dst.update_tags(b, **first.tags(b))
                describe(dst, [], {**first.tags(), "strip": "mosaic", "strips": " ".join(Path(p).stem for p in orthos)})
            finalise(working, output, profile, dtype)
        finally:
            shutil.rmtree(work, ignore_errors=True)
    finally:
        for s in srcs + lays:
            s.close()
    return output


def _mosaic_tile(w, srcs, lays, grids, offsets, bands_vz, count, dtype, nodata) -> np.ndarray:
    out = np.full((count, w.height, w.width), nodata if nodata is not None else 0, dtype=dtype)
    best = np.full((w.height, w.width), np.inf, dtype=np.float32)
    for src, lay, g, (r0, c0), bvz in zip(srcs, lays, grids, offsets, bands_vz):
        # the part of this tile inside the strip's grid
        rs, cs = max(w.row_off, r0), max(w.col_off, c0)
        re, ce = min(w.row_off + w.height, r0 + g.height), min(w.col_off + w.width, c0 + g.width)
        if re <= rs or ce <= cs:
            continue
        win = Window(cs - c0, rs - r0, ce - cs, re - rs)
        vz = lay.read(bvz, window=win)
        sub = best[rs - w.row_off : re - w.row_off, cs - w.col_off : ce - w.col_off]
        take = np.isfinite(vz) & (vz < sub)
        if not take.any():
            continue
        data = src.read(window=win)
        target = out[:, rs - w.row_off : re - w.row_off, cs - w.col_off : ce - w.col_off]
        target[:, take] = data[:, take]
        sub[take] = vz[take]
    return out
