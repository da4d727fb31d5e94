"""ENVI-style geolocation products for interoperability: the IGM and the GLT.

* **IGM** (input geometry): for every image pixel, the map coordinates where its ray meets the DTM
  (image -> ground): 3 bands ``x, y, H`` (map CRS, orthometric metres), float64, lines x pixels,
  BSQ; -9999 where the ray misses the DTM. File ``NAME.igm`` with header ``NAME.igm.hdr``.
* **GLT** (geometry lookup table): for every output cell, the image pixel that fills it
  (nearest, from the inverse map): 2 bands ``sample, line``, int32, **1-based** as ENVI has it, 0
  where no pixel sees the cell (outside the swath, no DTM, hidden). ENVI's negative values (cells
  filled by a neighbour) do not occur: the lookup is computed for every cell from ground to image.
  Georeferenced on the output grid. File ``NAME.glt`` with header ``NAME.glt.hdr``.

Both are written in a hidden work folder and moved into place header first, data last.
"""
from __future__ import annotations

import re
import shutil
import tempfile
import warnings
from pathlib import Path

import numpy as np
import rasterio
from rasterio.errors import NotGeoreferencedWarning
from rasterio.windows import Window

from scangeo.atomic import commit
from scangeo.progress import ProgressCallback, no_progress
from scangeo.rectify.geometry import MapStripGeometry
from scangeo.rectify.geotiff import remove_partials
from scangeo.rectify.output_grid import OutputGrid

IGM_NODATA = -9999.0
_DESCRIPTION = re.compile(r"description = \{[^}]*\}")


def _commit_envi(data: Path, final: Path) -> Path:
    """Move an ENVI file written by GDAL (``X.img`` + ``X.hdr``) to ``final`` + ``final.hdr``.

    GDAL's header describes the file by the path it wrote (the temporary one); the header moved into
    place names the final file instead (its name only, so a moved project's headers stay true)."""
    header = data.with_suffix(".hdr")
    text = header.read_text(encoding="latin-1")
    name = final.name.replace("{", "(").replace("}", ")")  # braces delimit ENVI values
    text, n = _DESCRIPTION.subn(lambda _: f"description = {{{name}}}", text, count=1)
    if not n:
        text = text.replace("ENVI\n", f"ENVI\ndescription = {{{name}}}\n", 1)
    header.write_text(text, encoding="latin-1")
    commit(header, final.with_name(final.name + ".hdr"))  # the header first: the data file appears last
    return commit(data, final)


class GltWriter:
    """Writes a GLT tile by tile into ``folder``; :meth:`commit` moves it into place."""

    def __init__(self, folder: Path, grid: OutputGrid) -> None:
        folder.mkdir(parents=True, exist_ok=True)
        self.path = folder / "glt.img"
        self.dst = rasterio.open(
            self.path, "w", driver="ENVI", width=grid.width, height=grid.height, count=2,
            dtype="int32", crs=grid.crs, transform=grid.transform, nodata=0,
        )
        self.dst.set_band_description(1, "sample (1-based)")
        self.dst.set_band_description(2, "line (1-based)")

    def write(self, window: Window, line: np.ndarray, pixel: np.ndarray, valid: np.ndarray) -> None:
        out = np.zeros((2,) + line.shape, dtype=np.int32)
        out[0][valid] = np.rint(pixel[valid]).astype(np.int32) + 1
        out[1][valid] = np.rint(line[valid]).astype(np.int32) + 1
        self.dst.write(out, window=window)

    def commit(self, final: Path) -> Path:
        self.dst.close()
        return _commit_envi(self.path, Path(final))


def write_igm(
    geometry: MapStripGeometry, output: str | Path, chunk_lines: int = 256, progress: ProgressCallback = no_progress
) -> Path:
    """Write the IGM of a strip (image -> ground for every pixel centre) to ``output``."""
    output = Path(output)
    output.parent.mkdir(parents=True, exist_ok=True)
    remove_partials(output)
    work = Path(tempfile.mkdtemp(dir=output.parent, prefix=f".{output.name}.partial-"))
    try:
        path = work / "igm.img"
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", NotGeoreferencedWarning)
            dst = rasterio.open(
                path, "w", driver="ENVI", width=geometry.pixels, height=geometry.lines, count=3,
                dtype="float64", nodata=IGM_NODATA,
            )
        with dst:
            for b, name in enumerate(("x (map)", "y (map)", "H (orthometric, m)"), start=1):
                dst.set_band_description(b, name)
            dst.update_tags(coordinate_system_wkt=str(geometry.crs))
            pixels = np.arange(geometry.pixels, dtype=float)
            for start in range(0, geometry.lines, chunk_lines):
                n = min(chunk_lines, geometry.lines - start)
                ll, pp = np.meshgrid(np.arange(start, start + n, dtype=float), pixels, indexing="ij")
                xyz = np.stack(geometry.image_to_ground(ll.ravel(), pp.ravel())).reshape(3, n, -1)
                xyz = np.where(np.isfinite(xyz).all(axis=0), xyz, IGM_NODATA)
                dst.write(xyz, window=Window(0, start, geometry.pixels, n))
                progress(start + n, geometry.lines, f"IGM {output.stem}")
        return _commit_envi(path, output)
    finally:
        shutil.rmtree(work, ignore_errors=True)
