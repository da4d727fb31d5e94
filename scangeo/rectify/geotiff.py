"""GeoTIFF outputs: a profile with sane defaults, band descriptions, atomic COG finalisation.

A strip's orthoimage is written by :class:`scangeo.rectify.cog_writer.CogWriter` when
:meth:`GeoTiffProfile.scangeo_writes` (the default). Otherwise, and for the layers and the mosaic,
tiles are first written into an uncompressed tiled GeoTIFF beside the output (a hidden
``.NAME.partial-*`` file), its overviews computed beside it (:mod:`scangeo.rectify.overviews`), then
copied by GDAL's COG driver into a second hidden file (tiled, compressed, with those overviews,
cloud-optimised layout), which is renamed to the final name only when complete. A run killed at
any point leaves only hidden partial files, which the next run removes.
"""
from __future__ import annotations

import math
import os
import shutil
import uuid
from dataclasses import dataclass, replace
from pathlib import Path
from typing import ClassVar

import numpy as np
import rasterio
import rasterio.enums
import rasterio.shutil
from rasterio.windows import Window

from scangeo.atomic import commit
from scangeo.errors import RectifyOptionsError
from scangeo.io.schema import Rule, check, setting
from scangeo.rectify.cog_writer import BACKLOG_BYTES, CogWriter, gdal_in_tested_range
from scangeo.rectify.cog_writer import LEVEL as COG_LEVEL
from scangeo.rectify.output_grid import OutputGrid
from scangeo.rectify.overviews import with_overviews

_COMPRESSIONS = ("deflate", "zstd", "lzw", "none", "lerc-lossy")


def _thread_count(value: str | int) -> bool:
    """``ALL_CPUS`` or a number of 1 or more (an integer or its digits)."""
    text = str(value).strip()
    return text.upper() == "ALL_CPUS" or (text.isdigit() and int(text) >= 1)


_THREADS = Rule(_thread_count, "ALL_CPUS or a number >= 1")
_WRITERS = ("scangeo", "gdal")
#: A pixel-interleaved block holds at most this many bytes, uncompressed (:meth:`GeoTiffProfile.for_image`)
BLOCK_BYTES = 16 * 2**20
#: With ``overviews = "auto"`` an output whose larger side exceeds this many cells gets internal
#: overviews: a viewer (QGIS) zoomed out on a larger raster reads every cell without them, and a
#: cloud-optimised GeoTIFF's strict validation (rio-cogeo's) asks for them above 512 cells
#: (docs/rectify.md, the cost measured in docs/performance.md).
OVERVIEW_MIN_SIZE = 512


@dataclass(frozen=True)
class GeoTiffProfile:
    """How output GeoTIFFs are laid out (copied from rasterio's ``Profile`` idea).

    Parameters
    ----------
    blocksize : int
        Internal tile size, pixels (a multiple of 16).
    compress : str
        ``deflate`` (default, readable everywhere), ``zstd``, ``lzw`` or ``none``, all lossless; or
        ``lerc-lossy``: LERC, **lossy**, every value within ``lossy_max_error`` of the true one (and
        the rounding of the data type; written by GDAL's driver; the per-cell layers stay
        deflate; a cube of floats at an error of 0.01 took 0.38 of its size against deflate's 0.58,
        docs/performance.md).
    lossy_max_error : float or None
        With ``compress = "lerc-lossy"`` (and only then): the largest error a value may get, in the
        image's units (radiance, reflectance, DN).
    level : int or None
        Compression level, GDAL's ``LEVEL`` whichever writer writes (None: 1 for deflate and
        zstd, the fastest: on a 10,000-line,
        11-band uint16 Daedalus strip deflate 1 wrote 115 MB in 0.93 s against GDAL's default 6,
        116 MB in 1.20 s; zstd 1 117 MB in 0.48 s; docs/performance.md).
    predictor : bool
        Horizontal differencing for integers, floating-point predictor for floats.
    overviews : bool or str
        Internal overviews (averaged, halving until a level fits one block): ``"auto"``
        (default) for outputs whose larger side exceeds :data:`OVERVIEW_MIN_SIZE` cells, ``True``
        always, ``False`` never.
    cog : bool
        Cloud-optimised layout; else a plain tiled GeoTIFF (GDAL's GTiff driver).
    threads : str or int
        Compression threads (``ALL_CPUS`` or a number).
    writer : str
        Who compresses and lays out a COG. ``"scangeo"`` (default):
        :class:`~scangeo.rectify.cog_writer.CogWriter`, deflate level 1 by ISA-L as the tiles
        are made, for every case it covers (:meth:`scangeo_writes`: deflate or none, integers and
        floats); GDAL's COG driver for the rest. ``"gdal"``: GDAL's COG driver always
        (deflate by libdeflate after the tiles are written; the benchmark's 10,000-line 11-band
        strip took 7.18 CPU s per pipelined strip that way against 5.33, docs/performance.md).

    Raises
    ------
    RectifyOptionsError
        A field of the wrong type or out of range (checked as the ``[rectify.geotiff]`` keys are).
    """

    schema_error: ClassVar[type[Exception]] = RectifyOptionsError

    blocksize: int = setting(512, ge=16, multiple_of=16, unit="px", doc="internal tile size")
    compress: str = setting("deflate", choices=_COMPRESSIONS,
                            doc="compression (lerc-lossy: lossy, within lossy_max_error; the others lossless)")
    lossy_max_error: float | None = setting(None, gt=0, unit="image unit", default_doc="none (lossless)",
                                            doc="with compress = lerc-lossy: the largest error of a value")
    level: int | None = setting(None, ge=1, le=22, unit="1", default_doc="1 for deflate and zstd",
                                doc="compression level")
    predictor: bool = setting(True, doc="horizontal differencing (integers), floating-point predictor (floats)")
    overviews: bool | str = setting("auto", choices=("auto",),
                                    doc=f"internal overviews: auto (above {OVERVIEW_MIN_SIZE} cells), true, false")
    cog: bool = setting(True, doc="cloud-optimised layout (false: a plain tiled GeoTIFF)")
    threads: str | int = setting("ALL_CPUS", rule=_THREADS, unit="1", doc="compression threads")
    writer: str = setting("scangeo", choices=_WRITERS,
                          doc="who writes a COG: scangeo (deflate level 1 or none; the rest goes to GDAL) or gdal")

    def __post_init__(self) -> None:
        check(self)
        if (self.compress == "lerc-lossy") != (self.lossy_max_error is not None):
            raise RectifyOptionsError(
                "[rectify.geotiff] compress = \"lerc-lossy\" needs lossy_max_error (the largest error of a value, "
                f"image units) and lossy_max_error needs it; found compress = {self.compress!r}, lossy_max_error = "
                f"{self.lossy_max_error!r}")

    def lossless(self) -> GeoTiffProfile:
        """This profile for the outputs that must stay exact (the per-cell layers: times, angles,
        image coordinates): deflate where it is ``lerc-lossy``.

        Returns
        -------
        GeoTiffProfile
            This profile, or a copy with ``compress = "deflate"``.
        """
        return replace(self, compress="deflate", lossy_max_error=None) if self.compress == "lerc-lossy" else self

    def thread_count(self) -> int:
        """Compression threads as a number.

        Returns
        -------
        int
            ``threads``; for ``ALL_CPUS`` the machine's processor count.
        """
        if str(self.threads).upper() == "ALL_CPUS":
            return os.cpu_count() or 1
        return int(self.threads)

    def scangeo_writes(self, dtype) -> bool:
        """Whether scangeo's own COG writer writes an output of ``dtype`` with this profile.

        Parameters
        ----------
        dtype : numpy dtype or str
            The output's data type.

        Returns
        -------
        bool
            True for a COG, deflate at level 1 or no compression, integers or floats, under a GDAL
            the writer is tested with (:func:`~scangeo.rectify.cog_writer.gdal_in_tested_range`);
            False when GDAL's COG driver writes it.
        """
        if self.writer != "scangeo" or not self.cog or self.compress not in ("deflate", "none"):
            return False
        if self.compress == "deflate" and self.level not in (None, COG_LEVEL):
            return False
        return np.dtype(dtype).kind in "uif" and gdal_in_tested_range()

    def for_image(self, count: int, dtype, block_bytes: float = BLOCK_BYTES) -> GeoTiffProfile:
        """This profile for an output of ``count`` bands of ``dtype``.

        The block size is halved (to 64 at least) while a pixel-interleaved block holds more than
        ``block_bytes``, so that the blocks in memory (the COG writer's, GDAL's) stay bounded for cubes
        of hundreds of bands (182 bands of float32: 128-cell blocks of 12 MB instead of 512-cell ones
        of 191 MB).

        Parameters
        ----------
        count : int
            The output's bands.
        dtype : numpy dtype or str
            Their data type.
        block_bytes : float
            The most a block may hold, bytes (:data:`BLOCK_BYTES`).

        Returns
        -------
        GeoTiffProfile
            This profile, or a copy with a smaller ``blocksize``.
        """
        size = self.blocksize
        while size > 64 and count * size * size * np.dtype(dtype).itemsize > block_bytes:
            size //= 2
        return self if size == self.blocksize else replace(self, blocksize=size)

    def cog_writer(self, spool: Path, width: int, height: int, count: int, dtype, nodata, crs, transform,
                   factors: list[int], backlog_bytes: int = BACKLOG_BYTES) -> CogWriter:
        """scangeo's COG writer of an output with this profile (when :meth:`scangeo_writes`).

        Parameters
        ----------
        spool : Path
            Where the compressed blocks wait until the file is assembled.
        width, height, count : int
            The output's size (cells) and bands.
        dtype, nodata, crs, transform
            The output's data type, nodata value, CRS and affine transform.
        factors : list of int
            The overview decimation factors.
        backlog_bytes : int
            Blocks waiting for an encoder at most, bytes (a strip's memory budget bounds it).

        Returns
        -------
        CogWriter
            The writer.
        """
        return CogWriter(spool, width=width, height=height, count=count, dtype=dtype, nodata=nodata, crs=crs,
                         transform=transform, blocksize=self.blocksize, factors=factors, compress=self.compress,
                         level=self.level, predictor=self.predictor, threads=self.thread_count(),
                         backlog_bytes=backlog_bytes)

    def wants_overviews(self, width: int, height: int) -> bool:
        """Whether an output gets internal overviews.

        Parameters
        ----------
        width, height : int
            The output's size, cells.

        Returns
        -------
        bool
            ``overviews``, with ``"auto"`` decided by :data:`OVERVIEW_MIN_SIZE`.
        """
        if self.overviews == "auto":
            return max(width, height) > OVERVIEW_MIN_SIZE
        return bool(self.overviews)

    def creation_options(self, dtype: np.dtype, overviews: bool | None = None) -> dict:
        """GDAL creation options for the final file.

        Parameters
        ----------
        dtype : numpy dtype
            The output's data type (chooses the predictor).
        overviews : bool, optional
            The decision of :meth:`wants_overviews` (None: ``overviews is True``).

        Returns
        -------
        dict
            Creation option -> value, for GDAL's COG or GTiff driver.
        """
        overviews = self.overviews is True if overviews is None else overviews
        opts: dict = {"BIGTIFF": "IF_SAFER", "NUM_THREADS": self.threads, "COMPRESS": self.compress.upper()}
        if self.compress == "lerc-lossy":  # LERC alone: LERC + zstd took more CPU for the same size
            opts.update(COMPRESS="LERC", MAX_Z_ERROR=repr(float(self.lossy_max_error or 0.0)))
        elif self.compress != "none":
            level = self.level if self.level is not None else (1 if self.compress in ("deflate", "zstd") else None)
            if level is not None:
                opts["LEVEL" if self.cog else _level_key(self.compress)] = str(level)
            if self.predictor:
                floating = np.issubdtype(np.dtype(dtype), np.floating)
                if self.cog:
                    opts["PREDICTOR"] = "FLOATING_POINT" if floating else "STANDARD"
                else:
                    opts["PREDICTOR"] = "3" if floating else "2"
        # the overviews are the source's (scangeo.rectify.overviews computes them): GDAL only compresses
        if self.cog:
            opts["BLOCKSIZE"] = str(self.blocksize)
            opts["OVERVIEWS"] = "FORCE_USE_EXISTING" if overviews else "NONE"
        else:
            opts.update(TILED="YES", BLOCKXSIZE=str(self.blocksize), BLOCKYSIZE=str(self.blocksize))
            if overviews:
                opts["COPY_SRC_OVERVIEWS"] = "YES"
        return opts


def overview_factors(width: int, height: int, blocksize: int) -> list[int]:
    """Decimation factors 2, 4, 8, ... until the smallest level fits one ``blocksize`` block."""
    factors = []
    f = 2
    while max(width, height) / (f // 2) > blocksize:
        factors.append(f)
        f *= 2
    return factors


def _level_key(compress: str) -> str:
    return {"deflate": "ZLEVEL", "zstd": "ZSTD_LEVEL", "lzw": "ZLEVEL"}.get(compress, "ZLEVEL")


@dataclass(frozen=True)
class BandInfo:
    """A band's name and centre wavelength (with its unit, as the source states it)."""

    name: str
    wavelength: float | None = None
    wavelength_units: str | None = None

    def tags(self) -> dict[str, str]:
        out = {}
        if self.wavelength is not None:
            out["wavelength"] = repr(float(self.wavelength))
            out["wavelength_units"] = self.wavelength_units or "unknown"
        return out


def bands_of(src: rasterio.io.DatasetReader) -> list[BandInfo]:
    """Band names and wavelengths of a source image (descriptions and ENVI-style band tags)."""
    out = []
    for b in range(1, src.count + 1):
        tags = {k.lower(): v for k, v in src.tags(b).items()}
        name = src.descriptions[b - 1] or f"band {b}"
        wl = tags.get("wavelength")
        try:
            wavelength = float(wl) if wl is not None else None
        except ValueError:
            wavelength = None
        out.append(BandInfo(name, wavelength, tags.get("wavelength_units")))
    return out


def partial_path(final: Path, suffix: str = "") -> Path:
    """A hidden temporary name beside ``final`` that never looks like a finished output."""
    final = Path(final)
    return final.parent / f".{final.name}.partial-{os.getpid()}-{uuid.uuid4().hex[:8]}{suffix}"


def remove_partials(final: Path) -> int:
    """Delete partial files a killed run left beside ``final``; returns how many."""
    final = Path(final)
    n = 0
    if final.parent.is_dir():
        for p in final.parent.glob(f".{final.name}.partial-*"):
            if p.is_dir():
                shutil.rmtree(p, ignore_errors=True)
            else:
                p.unlink(missing_ok=True)
            n += 1
    return n


def working_profile(grid: OutputGrid, count: int, dtype, nodata) -> dict:
    """Profile of the uncompressed tiled working file the tiles are written into."""
    return {
        "driver": "GTiff",
        "width": grid.width,
        "height": grid.height,
        "count": count,
        "dtype": np.dtype(dtype).name,
        "crs": grid.crs,
        "transform": grid.transform,
        "nodata": nodata,
        "tiled": True,
        "blockxsize": 256,
        "blockysize": 256,
        "compress": "none",
        "BIGTIFF": "IF_SAFER",
        "interleave": "band",
    }


def describe(dst, bands: list[BandInfo], tags: dict[str, object]) -> None:
    """Write band descriptions, band tags and dataset tags into an open dataset."""
    for b, info in enumerate(bands, start=1):
        dst.set_band_description(b, info.name)
        band_tags = info.tags()
        if band_tags:
            dst.update_tags(b, **band_tags)
    dst.update_tags(**{k: str(v) for k, v in tags.items()})


def overviews_of(profile: GeoTiffProfile, width: int, height: int) -> list[int]:
    """The overview factors an output of ``width`` x ``height`` cells gets (none: [])."""
    factors = overview_factors(width, height, profile.blocksize)
    return factors if profile.wants_overviews(width, height) else []


def finalise(working: Path, final: Path, profile: GeoTiffProfile, dtype, levels_made: bool = False) -> None:
    """Copy the working file into the final layout under a hidden name, then rename it.

    ``levels_made``: the overview levels are beside ``working`` already
    (:class:`scangeo.rectify.overviews.LevelTiles` wrote them with the tiles)."""
    final = Path(final)
    tmp = partial_path(final, ".tif")
    driver = "COG" if profile.cog else "GTiff"
    with rasterio.open(working) as src:
        profile = profile.for_image(src.count, dtype)
        factors = overviews_of(profile, src.width, src.height)
        if profile.scangeo_writes(dtype):
            _write_cog(src, final, tmp, profile, factors)
            return
    # the overviews, averaged by scangeo beside the working file, reach GDAL through a VRT
    made: list[Path] = []
    overviews = bool(factors)
    try:
        made = with_overviews(Path(working), factors, made=levels_made) if overviews else []
        source = made[0] if made else Path(working)
        rasterio.shutil.copy(str(source), str(tmp), driver=driver, **profile.creation_options(dtype, overviews))
        commit(tmp, final)
    finally:
        for path in [tmp, *made]:
            path.unlink(missing_ok=True)


def _copy_description(src, dst) -> None:
    """Band descriptions, band tags and dataset tags of ``src`` into ``dst``."""
    for b in range(1, src.count + 1):
        if src.descriptions[b - 1]:
            dst.set_band_description(b, src.descriptions[b - 1])
        if src.tags(b):
            dst.update_tags(b, **src.tags(b))
    dst.update_tags(**src.tags())


def _write_cog(src, final: Path, tmp: Path, profile: GeoTiffProfile, factors: list[int]) -> None:
    """The working file ``src`` through :class:`~scangeo.rectify.cog_writer.CogWriter`, read in
    windows aligned on the blocks and on the coarsest overview factor."""
    step = math.lcm(profile.blocksize, max(factors, default=1))
    side = step * max(1, 2048 // step)
    writer = profile.cog_writer(partial_path(final, ".spool"), src.width, src.height, src.count, src.dtypes[0],
                                src.nodata, src.crs, src.transform, factors)
    try:
        for r in range(0, src.height, side):
            for c in range(0, src.width, side):
                window = Window(c, r, min(side, src.width - c), min(side, src.height - r))
                writer.write(src.read(window=window), window)
    except BaseException:
        writer.close()
        raise
    writer.finish(final, tmp, lambda dst: _copy_description(src, dst))
