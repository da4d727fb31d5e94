"""Pass 2 of rectifying a strip, per tile: visibility against the complete z-buffer, the image lines
the tile needs (a rasterio window), ``cv2.remap`` of every band, nodata outside the swath, where the
DTM has none and where the ground is hidden; the optional layers and the GLT of the tile.
"""
from __future__ import annotations

import numpy as np
from rasterio.windows import Window

from scangeo.rectify import occlusion
from scangeo.rectify.geolocation import GltWriter
from scangeo.rectify.geometry import MapStripGeometry
from scangeo.rectify.options import LAYERS
from scangeo.rectify.resample import RESAMPLING, in_image, line_window, remap_bands, source_nodata_mask
from scangeo.rectify.strip_run import StripRun, tile_slices


def resample_tile(run: StripRun, w: Window, dst, lay, glt: GltWriter | None, co=None) -> None:
    """Pass 2 of one tile: visible cells resampled, nodata elsewhere; its layers, GLT and co-registration
    layer (``co``, with ``run.coregistration``)."""
    g, src, work, result = run.geometry, run.src, run.work, run.result
    rs, cs = tile_slices(w)
    line = np.asarray(work["line"][rs, cs])
    pixel = np.asarray(work["pixel"][rs, cs])
    valid = in_image(line, pixel, g.lines, g.pixels)
    if run.zbuf is not None:
        rng = np.asarray(work["range"][rs, cs])
        seen = occlusion.visible(rng, np.asarray(work["tolerance"][rs, cs]), run.zbuf.nearest(line, pixel))
        result.hidden_cells += int((valid & ~seen).sum())
        valid &= seen
    resampling = run.options.resampling
    _, radius = RESAMPLING[resampling]
    lw = line_window(line, valid, g.lines, radius, pixel, g.pixels)
    if lw is None:
        out = np.full((src.count,) + line.shape, run.nodata, dtype=np.dtype(src.dtypes[0]))
    else:
        data = run.reader.read(lw.window(g.pixels))
        out = remap_bands(data, line, pixel, lw, resampling)
        if src.nodata is not None:
            valid &= ~source_nodata_mask(data, src.nodata, line, pixel, lw, resampling)
        # by flat index: the unseen cells are few, a boolean mask would visit every cell of every band
        out.reshape(out.shape[0], -1)[:, np.flatnonzero(~valid)] = run.nodata
    result.valid_cells += int(valid.sum())
    dst.write(out, window=w)
    if lay is not None:
        lay.write(_layer_values(g, work, rs, cs, line, pixel, valid, run.layers), window=w)
    if glt is not None:
        glt.write(w, line, pixel, valid)
    if co is not None and run.coregistration is not None:
        values = run.coregistration.values(line, pixel)
        co.write(np.where(valid, values, np.float32(np.nan))[None], window=w)


def time_origin(geometry: MapStripGeometry) -> float:
    """Time of the first line's centre pixel: the time layer holds seconds after it (float32)."""
    return float(np.asarray(geometry.time(np.array([0.0]), np.array([(geometry.pixels - 1) / 2.0])))[0])


def _layer_values(geometry, work, rs, cs, line, pixel, valid, layers) -> np.ndarray:
    out = np.full((len(layers),) + line.shape, np.nan, dtype=np.float32)
    for k, name in enumerate(layers):
        if name == "scan_angle":
            values = np.full(line.shape, np.nan)
            values[valid] = np.degrees(geometry.scan_angle(pixel[valid]))
        elif name == "time":
            values = np.full(line.shape, np.nan)
            values[valid] = geometry.time(line[valid], pixel[valid]) - time_origin(geometry)
        elif name == "image_line":
            values = line
        elif name == "image_pixel":
            values = pixel
        elif name in LAYERS:
            values = np.asarray(work[name][rs, cs])
        out[k] = np.where(valid, values, np.nan)
    return out
