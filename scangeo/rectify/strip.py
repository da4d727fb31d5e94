"""Rectify one strip onto its output grid, in tiles, in two passes.

Pass 1 (:func:`~scangeo.rectify.cell_map.map_cells`), per tile: DTM heights, the inverse map,
the range to the sensor, the fold test, the z-buffer. The per-cell results are kept in memory when
they take at most a quarter of the memory budget, else in memory-mapped work files beside the
output (:mod:`scangeo.rectify.strip_run`).
Pass 2 (:func:`resample`; per tile :func:`~scangeo.rectify.cell_values.resample_tile`): visibility,
the image lines, ``cv2.remap`` of every band, nodata where nothing is seen; optional layers and the
GLT, into working GeoTIFFs.
Then (:func:`write_outputs`) the image is written in its final layout (COG) under a hidden name and
renamed: an interrupted run leaves nothing that looks finished. By default pass 2 hands its tiles to
a :class:`~scangeo.rectify.cog_writer.CogWriter`, which compresses every block in worker threads
as it is complete and only assembles the file at the end; otherwise (``[rectify.geotiff]
writer = "gdal"``, zstd, lzw, floats with a predictor) the tiles go into an uncompressed working
GeoTIFF that GDAL's COG driver copies. Given a
:class:`Finaliser`, that last step (compression, overviews) runs in its background thread while the
caller goes on with the next strip's passes; :meth:`StripResult.wait` waits for it.
"""
from __future__ import annotations

import contextlib
import logging
import math
import shutil
import tempfile
import time
import warnings
from collections.abc import Callable, Iterator, Mapping
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import rasterio
from rasterio.windows import Window

from scangeo.errors import InputFileError
from scangeo.progress import ProgressCallback, no_progress
from scangeo.rectify.cell_map import map_cells
from scangeo.rectify.cell_values import resample_tile, time_origin
from scangeo.rectify.cog_writer import BACKLOG_BYTES, CogWriter
from scangeo.rectify.coregistration_layer import BAND as COREGISTRATION_BAND
from scangeo.rectify.coregistration_layer import CoregistrationGrid, layer_path
from scangeo.rectify.geolocation import GltWriter
from scangeo.rectify.geometry import MapStripGeometry
from scangeo.rectify.geotiff import (
    BLOCK_BYTES,
    BandInfo,
    bands_of,
    describe,
    finalise,
    overviews_of,
    partial_path,
    remove_partials,
    working_profile,
)
from scangeo.rectify.options import RectifyOptions
from scangeo.rectify.output_grid import OutputGrid
from scangeo.rectify.overviews import LevelTiles
from scangeo.rectify.strip_run import StripResult, StripRun, gdal_cache, start_run, strip_grid, tile_slices
from scangeo.version import __version__

log = logging.getLogger(__name__)


class Finaliser:
    """One background thread that writes strips' outputs in their final layout (:func:`write_outputs`:
    the COG copy with its compression and overviews), in the order given, while the caller computes
    the next strip. It runs GDAL only, no numba kernel (numba's ``workqueue`` threading layer must not
    be entered from two threads at once). Use as a context manager: leaving it waits for every strip.
    """

    def __init__(self) -> None:
        self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="scangeo-finalise")

    def submit(self, job: Callable[[], None]) -> Future:
        return self._pool.submit(job)

    def close(self) -> None:
        self._pool.shutdown(wait=True)

    def __enter__(self) -> Finaliser:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


@dataclass
class Resampled:
    """The working files of pass 2 (in ``run.work_dir``), not yet in their final layout."""

    image: Path
    layers: Path | None
    glt: GltWriter | None
    tags: dict[str, object]
    dtype: np.dtype
    #: the image's overview levels were written beside it with the tiles (LevelTiles)
    levels_made: bool = False
    #: the image's blocks, encoded as they were written (then ``image`` is not written)
    cog: CogWriter | None = None
    bands: list[BandInfo] | None = None
    #: the co-registration layer's working file (with ``run.coregistration``)
    coregistration: Path | None = None


class _Tee:
    """Pass 2's destination that writes each tile into the working file and its overview levels."""

    def __init__(self, dst, levels: LevelTiles) -> None:
        self.dst, self.levels = dst, levels

    def write(self, data: np.ndarray, window: Window) -> None:
        self.dst.write(data, window=window)
        self.levels.write(data, window)


def resample(run: StripRun, bands: list[BandInfo], tags: Mapping[str, object] | None = None,
             progress: ProgressCallback = no_progress) -> Resampled:
    """Pass 2: every tile's visible cells resampled from the image lines it needs into a working
    GeoTIFF; the optional layers and the GLT beside it."""
    src, grid, layers = run.src, run.grid, run.layers
    dtype = np.dtype(src.dtypes[0])
    out = Resampled(
        run.work_dir / "working.tif", run.work_dir / "layers.tif" if layers else None,
        GltWriter(run.work_dir / "glt", grid) if run.options.glt else None, _tags(tags, run.options, run.result),
        dtype,
    )
    windows = run.windows
    # blocks of at most 16 MiB and a 32nd of the memory budget (the COG writer holds a few per level)
    budget = run.options.memory_budget_mb * 2**20
    gp = run.options.geotiff.for_image(src.count, dtype, min(BLOCK_BYTES, budget / 32))
    tiles: CogWriter | _Tee | rasterio.io.DatasetWriter
    with contextlib.ExitStack() as stack:
        factors = overviews_of(gp, grid.width, grid.height)
        aligned = not factors or LevelTiles.aligned(run.result.tile_size, factors)
        if aligned and gp.scangeo_writes(dtype):
            # the encoders' backlog within the strip's memory budget (an eighth, as GDAL's block cache)
            backlog = int(min(BACKLOG_BYTES, budget / 8))
            out.cog = gp.cog_writer(run.work_dir / "blocks.spool", grid.width, grid.height, src.count, dtype,
                                    run.nodata, grid.crs, grid.transform, factors, backlog)
            stack.push(lambda exc_type, *_: out.cog.close() if exc_type is not None and out.cog else None)
            tiles, out.bands = out.cog, list(bands)
        else:
            profile = working_profile(grid, src.count, dtype, run.nodata)
            dst = stack.enter_context(rasterio.open(out.image, "w", **profile))
            stack.callback(describe, dst, bands, out.tags)  # before the file closes
            tiles = dst
            if factors and aligned:
                # the overview levels from the tiles as they are written: no second read of the file
                levels = LevelTiles(out.image, profile, factors)
                stack.callback(levels.close)
                tiles, out.levels_made = _Tee(dst, levels), True
        lay = co = None
        if out.layers is not None:
            profile = working_profile(grid, len(layers), np.float32, math.nan)
            lay = stack.enter_context(rasterio.open(out.layers, "w", **profile))
        if run.coregistration is not None:
            out.coregistration = run.work_dir / "coregistration.tif"
            co = stack.enter_context(rasterio.open(out.coregistration, "w",
                                                   **working_profile(grid, 1, np.float32, math.nan)))
        for i, w in enumerate(windows):
            resample_tile(run, w, tiles, lay, out.glt, co)
            progress(len(windows) + i + 1, 2 * len(windows), f"resample {run.result.path.stem}")
    return out


def _tags(tags: Mapping[str, object] | None, options: RectifyOptions, result: StripResult) -> dict[str, object]:
    out: dict[str, object] = {
        "TIFFTAG_SOFTWARE": f"scangeo {__version__}",
        "scangeo_version": __version__,
        "resampling": options.resampling,
        "inverse_map_max_error_px": f"{result.stats.max_error_px:.5f}",
        "inverse_map_tolerance_px": options.max_error_px,
        "inverse_map_method": result.inverse_map_method,
        "occlusion": str(options.occlusion).lower(),
    }
    out.update(tags or {})
    return out


def write_outputs(run: StripRun, resampled: Resampled) -> None:
    """The working files into their final layout under their final names: the layers, the GLT,
    the orthoimage last (its presence means the strip's outputs are complete)."""
    output, options = run.result.path, run.options
    try:
        _write_side_outputs(run, resampled)
    except BaseException:
        if resampled.cog is not None:
            resampled.cog.close()
        raise
    if resampled.cog is not None:
        bands, tags = resampled.bands or [], resampled.tags
        resampled.cog.finish(output, partial_path(output, ".tif"), lambda dst: describe(dst, bands, tags))
    else:
        finalise(resampled.image, output, options.geotiff, resampled.dtype, resampled.levels_made)


def _write_side_outputs(run: StripRun, resampled: Resampled) -> None:
    """The layers and the GLT under their final names."""
    output, options, result = run.result.path, run.options, run.result
    if resampled.layers is not None:
        result.layers_path = output.with_name(output.stem + ".layers.tif")
        with rasterio.open(resampled.layers, "r+") as lay:
            layer_tags = {**resampled.tags, "layers": " ".join(run.layers)}
            if "time" in run.layers:
                layer_tags["time_origin_s"] = repr(time_origin(run.geometry))
            describe(lay, [BandInfo(n) for n in run.layers], layer_tags)
        finalise(resampled.layers, result.layers_path, options.geotiff.lossless(), np.float32)
    if resampled.glt is not None:
        result.glt_path = resampled.glt.commit(output.with_suffix(".glt"))
    co = run.coregistration
    if resampled.coregistration is not None and co is not None:
        with rasterio.open(resampled.coregistration, "r+") as dst:
            describe(dst, [BandInfo(COREGISTRATION_BAND)],
                     {**resampled.tags, "coregistration_reference": co.reference, "flight_line": co.flight_line,
                      "unit": "m", "coregistration_grid": f"{co.sigma.shape[0]} x {co.sigma.shape[1]}"})
        result.coregistration_path = layer_path(output)
        finalise(resampled.coregistration, result.coregistration_path, options.geotiff.lossless(), np.float32)


@contextlib.contextmanager
def open_strip_image(image: Path, geometry: MapStripGeometry) -> Iterator[rasterio.io.DatasetReader]:
    """The strip image, checked against the geometry's lines and pixels."""
    try:
        with warnings.catch_warnings():  # a raw scanner image has no georeferencing
            warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)
            src = rasterio.open(image)
    except rasterio.errors.RasterioIOError as exc:
        raise InputFileError(f"{image}: cannot read the strip image ({exc})") from exc
    with src:
        if (src.height, src.width) != (geometry.lines, geometry.pixels):
            raise InputFileError(
                f"{image}: image has {src.height} lines x {src.width} pixels, the strip's geometry "
                f"{geometry.lines} x {geometry.pixels}"
            )
        try:  # the last line is the first casualty of a truncated file (an interrupted copy)
            src.read(window=Window(0, src.height - 1, src.width, 1))
        except rasterio.errors.RasterioIOError as exc:
            raise InputFileError(f"{image}: cannot read line {src.height - 1}; a truncated file? ({exc})") from exc
        yield src


def work_folder(output: Path) -> Path:
    """A hidden folder beside ``output`` for the working files (the caller removes it)."""
    return Path(tempfile.mkdtemp(dir=output.parent, prefix=f".{output.name}.partial-"))


def rectify_strip(
    geometry: MapStripGeometry,
    image: str | Path,
    output: str | Path,
    options: RectifyOptions | None = None,
    grid: OutputGrid | None = None,
    tags: Mapping[str, object] | None = None,
    bands: list[BandInfo] | None = None,
    progress: ProgressCallback = no_progress,
    finaliser: Finaliser | None = None,
    coregistration: CoregistrationGrid | None = None,
) -> StripResult:
    """Rectify the strip image ``image`` onto ``grid`` and write the orthoimage ``output``.

    The steps: :func:`map_cells` (pass 1: the refined inverse map, ranges, z-buffer),
    :func:`resample` (pass 2: visibility, the image lines, ``cv2.remap``, layers, GLT) and
    :func:`write_outputs` (final layout, orthoimage last).

    Parameters
    ----------
    geometry : the strip's geometry (orientation, sensor, DTM), map coordinates.
    image : the strip image, lines x pixels x bands (any GDAL raster).
    output : the orthoimage GeoTIFF to write; ``NAME.layers.tif`` and ``NAME.glt`` beside it
        when layers or the GLT are asked for.
    options : resolution, resampling, tolerance, memory budget, layers, GeoTIFF layout (default:
        ``RectifyOptions()``).
    grid : the output grid (default: :func:`strip_grid`).
    tags : metadata recorded in the GeoTIFF (variant, sigma0, fingerprint ...).
    bands : band names and wavelengths (default: from the image).
    progress : ``callback(done, total, message)``.
    finaliser : when given, the last step (:func:`write_outputs`) runs in its thread and this
        returns after pass 2; ``result.wait()`` waits for the outputs (and raises its error).
    coregistration : the strip's relative displacement to its reference on a grid of its image; when given,
        ``NAME.coregistration.tif`` beside the output holds it interpolated at every visible cell (metres,
        float32, NaN nodata: :mod:`scangeo.rectify.coregistration_layer`).
    """
    started = time.perf_counter()
    options = options or RectifyOptions()
    image, output = Path(image), Path(output)
    output.parent.mkdir(parents=True, exist_ok=True)
    remove_partials(output)
    grid = grid or strip_grid(geometry, options)
    work_dir = work_folder(output)
    try:
        with rasterio.Env(GDAL_CACHEMAX=gdal_cache(options)), open_strip_image(image, geometry) as src:
            run = start_run(geometry, grid, options, src, output, work_dir)
            run.coregistration = coregistration
            map_cells(run, progress)
            resampled = resample(run, bands or bands_of(src), tags, progress)
        run.work.close()  # pass 2's inputs are no longer needed: free them before the last step
        run.zbuf = None
    except BaseException:
        shutil.rmtree(work_dir, ignore_errors=True)
        raise

    def finish() -> None:
        try:
            with rasterio.Env(GDAL_CACHEMAX=gdal_cache(options)):
                write_outputs(run, resampled)
        finally:
            shutil.rmtree(work_dir, ignore_errors=True)
        result = run.result
        result.seconds = time.perf_counter() - started
        log.info(
            "%s: %d x %d cells, %d valid, %d hidden, inverse map %d exact points, max error %.4f px, %.2f s",
            output.name, grid.width, grid.height, result.valid_cells, result.hidden_cells,
            result.stats.exact_points, result.stats.max_error_px, result.seconds,
        )

    if finaliser is None:
        finish()
    else:
        run.result.pending = finaliser.submit(finish)
    return run.result


@dataclass
class StripArray:
    """A strip rectified in memory (:func:`rectify_strip_array`).

    Parameters
    ----------
    values : (bands, rows, cols) ndarray
        The orthoimage, of the image's dtype on ``grid`` (row 0 north); ``nodata`` where no pixel is
        seen (outside the swath, no DTM, hidden ground).
    grid : OutputGrid
        The output grid: CRS, resolution (map units), width, height, transform.
    nodata : float
        The nodata value.
    valid_cells, hidden_cells : int
        Cells with a value; cells of ground hidden by terrain.
    """

    values: np.ndarray
    grid: OutputGrid
    nodata: float
    valid_cells: int
    hidden_cells: int


class _ArrayTiles:
    """Pass 2's destination when the orthoimage stays in memory: tiles written into ``values``."""

    def __init__(self, values: np.ndarray) -> None:
        self.values = values

    def write(self, data: np.ndarray, window: Window) -> None:
        rs, cs = tile_slices(window)
        self.values[:, rs, cs] = data


def rectify_strip_array(
    geometry: MapStripGeometry,
    image: str | Path,
    options: RectifyOptions | None = None,
    grid: OutputGrid | None = None,
    progress: ProgressCallback = no_progress,
) -> StripArray:
    """Rectify the strip image ``image`` onto ``grid`` into an array: the passes of
    :func:`rectify_strip` (same values cell by cell), no file written; layers, GLT and IGM are
    not made. The whole orthoimage is held in memory (bands x rows x cols of the image's dtype);
    pass 1's working arrays go to a temporary folder only when they exceed a quarter of
    ``options.memory_budget_mb``.
    """
    options = options or RectifyOptions()
    image = Path(image)
    grid = grid or strip_grid(geometry, options)
    with tempfile.TemporaryDirectory(prefix="scangeo-rectify-") as work, \
            rasterio.Env(GDAL_CACHEMAX=gdal_cache(options)), open_strip_image(image, geometry) as src:
        run = start_run(geometry, grid, options, src, image, Path(work))
        map_cells(run, progress)
        values = np.empty((src.count, grid.height, grid.width), dtype=np.dtype(src.dtypes[0]))
        tiles = _ArrayTiles(values)
        windows = run.windows
        for i, w in enumerate(windows):
            resample_tile(run, w, tiles, None, None)
            progress(len(windows) + i + 1, 2 * len(windows), f"resample {image.stem}")
        run.work.close()
    return StripArray(values, grid, run.nodata, run.result.valid_cells, run.result.hidden_cells)
