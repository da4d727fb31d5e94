"""Internal overviews computed by scangeo instead of GDAL, handed to GDAL's COG/GTiff copy.

GDAL's COG driver, asked to generate overviews, builds them into a temporary file and then copies
everything; measured on a 716 x 10,000 x 11 strip (760 x 10,010 cells of uint16) that doubled the
time of the final copy (3.7 s against 1.3 s without overviews, docs/performance.md). Here every
level is the average of the valid cells (nodata and NaN excluded) of 2 x 2 cells of the level
before it, computed by a compiled kernel over row chunks of the working file (memory bounded by a
chunk, not by the raster) and written uncompressed beside it. A VRT made by GDAL from the working
file (keeping its metadata, band descriptions and nodata) gets one ``<Overview>`` per level and
band, and the final copy reads the overviews from there (COG: ``OVERVIEWS=FORCE_USE_EXISTING``,
GTiff: ``COPY_SRC_OVERVIEWS=YES``); only compression remains for GDAL.

Level ``k`` (factor ``2**k``) has ``ceil(size / 2**k)`` cells per side, as GDAL's own; an
odd last row or column averages the cells it has. Integer types are rounded half up; a mean of
valid cells that rounds to the nodata value is moved one step towards the mean (it stays valid).

When the tiles of the resampling pass are aligned on the coarsest level (every tile's size a
multiple of its factor), :class:`LevelTiles` computes the levels from each tile as it is written,
so the working file is not read back for them (the same values: every 2 x 2 block of every level
lies inside one tile).
"""
from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numba
import numpy as np
import rasterio
import rasterio.shutil
from affine import Affine
from rasterio.windows import Window

#: Bytes of one chunk of the finer level read at a time.
CHUNK_BYTES = 64 * 2**20


@numba.njit(cache=True, nogil=True)
def _halve(src, out, nodata, use_nodata, integer):  # pragma: no cover - compiled
    """``out`` (bands, ceil(h/2), ceil(w/2)): the mean of the valid cells of each 2 x 2 block of
    ``src`` (bands, h, w); a cell is invalid when NaN or, with ``use_nodata``, equal to ``nodata``.

    Serial on purpose: it runs in the finaliser's thread while the next strip's parallel kernels
    run in the main thread, and numba's ``workqueue`` layer must not be entered from two threads;
    without the GIL, so that the main thread's Python code goes on meanwhile."""
    nb, h, w = src.shape
    oh, ow = out.shape[1], out.shape[2]
    for k in range(nb * oh):
        b = k // oh
        r = k % oh
        for c in range(ow):
            s = 0.0
            n = 0
            for dr in range(2):
                rr = 2 * r + dr
                if rr >= h:
                    continue
                for dc in range(2):
                    cc = 2 * c + dc
                    if cc >= w:
                        continue
                    v = float(src[b, rr, cc])
                    if v != v or (use_nodata and v == nodata):
                        continue
                    s += v
                    n += 1
            if n == 0:
                out[b, r, c] = nodata
            elif integer:
                m = math.floor(s / n + 0.5)
                if use_nodata and m == nodata:  # valid cells give a valid cell: one step towards their mean
                    m = nodata - 1 if s / n < nodata else nodata + 1
                out[b, r, c] = m
            else:
                out[b, r, c] = s / n


def halve(src: np.ndarray, nodata: float | None) -> np.ndarray:
    """One overview level of ``src`` (bands, rows, cols): mean of the valid cells of 2 x 2 blocks."""
    nb, h, w = src.shape
    out = np.empty((nb, (h + 1) // 2, (w + 1) // 2), dtype=src.dtype)
    integer = bool(np.issubdtype(src.dtype, np.integer))
    fill = float(nodata) if nodata is not None else (0.0 if integer else math.nan)
    _halve(src, out, fill, nodata is not None and not math.isnan(float(nodata)), integer)
    return out


def _level_profile(src: rasterio.io.DatasetReader, width: int, height: int) -> dict:
    """The finer level's own profile (tiled, its bands, type and nodata) at half its cells per side,
    uncompressed."""
    return {**src.profile, "width": width, "height": height, "transform": src.transform @ Affine.scale(2.0),
            "compress": "none", "BIGTIFF": "IF_SAFER"}


def write_level(finer: Path, coarser: Path) -> None:
    """The next overview level (half the cells per side) of the raster ``finer`` into ``coarser``,
    in row chunks."""
    with rasterio.open(finer) as src:
        width, height = (src.width + 1) // 2, (src.height + 1) // 2
        row_bytes = src.width * src.count * np.dtype(src.dtypes[0]).itemsize
        rows = max(2, min(src.height, CHUNK_BYTES // max(row_bytes, 1)) // 2 * 2)
        with rasterio.open(coarser, "w", **_level_profile(src, width, height)) as dst:
            for r0 in range(0, src.height, rows):
                n = min(rows, src.height - r0)
                data = src.read(window=Window(0, r0, src.width, n))
                dst.write(halve(data, src.nodata), window=Window(0, r0 // 2, width, (n + 1) // 2))


def level_path(working: Path, factor: int) -> Path:
    """The file of the overview level ``factor`` beside ``working``."""
    return working.with_name(f"{working.stem}.ovr{factor}.tif")


class LevelTiles:
    """The overview levels ``factors`` (2, 4, 8 ...) of a raster being written tile by tile, each
    tile's levels written as the tile is (:meth:`write`, the signature of a rasterio dataset's):
    the working file is not read back for them.

    Every tile's offsets and size (but at the raster's last row and column) must be multiples of
    the largest factor (:meth:`aligned`), so that every 2 x 2 block of every level lies inside one
    tile; the levels are then those :func:`write_level` computes from the whole raster.
    """

    def __init__(self, working: Path, profile: dict, factors: list[int]) -> None:
        self.paths = [level_path(Path(working), f) for f in factors]
        self.nodata = profile.get("nodata")
        self._dst = []
        width, height, transform = profile["width"], profile["height"], profile["transform"]
        try:
            for path in self.paths:
                width, height, transform = (width + 1) // 2, (height + 1) // 2, transform @ Affine.scale(2.0)
                self._dst.append(rasterio.open(path, "w", **{**profile, "width": width, "height": height,
                                                             "transform": transform}))
        except BaseException:
            self.close()
            raise

    @staticmethod
    def aligned(tile_size: int, factors: list[int]) -> bool:
        return bool(factors) and tile_size % max(factors) == 0

    def write(self, data: np.ndarray, window: Window) -> None:
        """The levels of the tile ``data`` (bands, rows, cols) at ``window`` of the full raster."""
        row, col = int(window.row_off), int(window.col_off)
        for dst in self._dst:
            data = halve(data, self.nodata)
            row, col = row // 2, col // 2
            dst.write(data, window=Window(col, row, data.shape[2], data.shape[1]))

    def close(self) -> None:
        for dst in self._dst:
            dst.close()
        self._dst = []


def with_overviews(working: Path, factors: list[int], made: bool = False) -> list[Path]:
    """A VRT of ``working`` whose bands carry the overview levels ``factors`` (2, 4, 8 ...),
    each computed from the one before and written beside ``working`` (``made``: they are there
    already, :class:`LevelTiles` wrote them); returns the VRT's path followed by the level files
    (the caller removes them all after the copy)."""
    working = Path(working)
    levels: list[Path] = []
    finer = working
    for factor in factors:
        coarser = level_path(working, factor)
        if not made:
            write_level(finer, coarser)
        levels.append(coarser)
        finer = coarser
    vrt = working.with_suffix(".vrt")
    rasterio.shutil.copy(str(working), str(vrt), driver="VRT")
    tree = ET.parse(vrt)
    for band in tree.getroot().iter("VRTRasterBand"):
        for level in levels:
            ov = ET.SubElement(band, "Overview")
            ET.SubElement(ov, "SourceFilename", relativeToVRT="0").text = str(level)
            ET.SubElement(ov, "SourceBand").text = band.get("band")
    tree.write(vrt)
    return [vrt, *levels]
