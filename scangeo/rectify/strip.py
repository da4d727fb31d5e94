"""Rectify one strip onto its output grid, in tiles, in two passes.

Pass 1 (:func:`map_cells`), per tile: DTM heights, the inverse map (refined per cell: exact at
every cell), the range to the sensor, the fold test; every tile's ranges go into the strip's
z-buffer. The per-cell results are kept in memory when they take at most a quarter of the memory
budget, else in memory-mapped work files beside the output.
Pass 2 (:func:`resample`), per tile: visibility against the complete z-buffer, the image lines the
tile needs (a rasterio window), ``cv2.remap`` of every band, nodata outside the swath, where the
DTM has none and where the ground is hidden; optional layers and the GLT.
Then (:func:`write_outputs`) the working GeoTIFF is copied into the final layout (COG) under a
hidden name and renamed: an interrupted run leaves nothing that looks finished. Given a
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
from dataclasses import dataclass, field
from pathlib import Path

import numba
import numpy as np
import rasterio
from rasterio.windows import Window

from scangeo import __version__
from scangeo.errors import GeometryError, InputFileError, RectifyOptionsError
from scangeo.progress import ProgressCallback, no_progress
from scangeo.rectify import occlusion
from scangeo.rectify.geolocation import GltWriter
from scangeo.rectify.geometry import MapStripGeometry, footprint_bounds, nadir_ground_pixel
from scangeo.rectify.geotiff import BandInfo, bands_of, describe, finalise, remove_partials, working_profile
from scangeo.rectify.inverse_map import InverseMapOptions, InverseMapStats, TileGrid, solve_every_cell
from scangeo.rectify.options import LAYERS, RectifyOptions
from scangeo.rectify.output_grid import OutputGrid, nice_resolution
from scangeo.rectify.refined_map import RefinableStrip, build_refined_map
from scangeo.rectify.resample import RESAMPLING, in_image, line_window, remap_bands, source_nodata_mask
from scangeo.threading_layer import choose_threading_layer

log = logging.getLogger(__name__)

#: largest tile of the refined inverse map (scangeo.rectify.refined_map), cells: no model across
#: the tile, so only the memory budget (the pass's tile) bounds it
REFINE_TILE = 1024
#: GDAL block cache during rectification, bytes (at most an eighth of the memory budget)
GDAL_CACHE = 32 * 2**20


def gdal_cache(options: RectifyOptions) -> int:
    return int(min(GDAL_CACHE, options.memory_budget_mb * 2**20 / 8))


@dataclass
class StripResult:
    """What rectifying a strip produced."""

    path: Path
    grid: OutputGrid
    layers_path: Path | None = None
    glt_path: Path | None = None
    stats: InverseMapStats = field(default_factory=InverseMapStats)
    valid_cells: int = 0
    hidden_cells: int = 0
    tile_size: int = 0
    seconds: float = 0.0
    inverse_map_method: str = ""
    pending: Future | None = field(default=None, repr=False, compare=False)

    def wait(self) -> StripResult:
        """Wait until the outputs are written (when a :class:`Finaliser` writes them); re-raises the
        error of that step."""
        if self.pending is not None:
            pending, self.pending = self.pending, None
            pending.result()
        return self

    def summary(self) -> dict:
        self.wait()
        return {
            "path": str(self.path),
            "grid": self.grid.to_dict(),
            "valid_cells": self.valid_cells,
            "hidden_cells": self.hidden_cells,
            "tile_size": self.tile_size,
            "inverse_map_exact_points": self.stats.exact_points,
            "inverse_map_max_error_px": self.stats.max_error_px,
            "inverse_map_method": self.inverse_map_method,
            "seconds": round(self.seconds, 3),
        }


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


def strip_grid(geometry: MapStripGeometry, options: RectifyOptions) -> OutputGrid:
    """The output grid of a strip: the given or the nadir resolution, the given or footprint bounds."""
    res = options.resolution or nice_resolution(nadir_ground_pixel(geometry))
    bounds = options.bounds or footprint_bounds(geometry)
    return OutputGrid.from_bounds(geometry.crs, bounds, res)


def choose_tile_size(
    options: RectifyOptions, geometry: MapStripGeometry, bands: int, itemsize: int, resolution: float,
    reserved: int = 0,
) -> int:
    """The largest tile (cells per side) whose working arrays fit the memory budget.

    The budget covers the data rectification holds (z-buffer, tile arrays, the image lines of a
    tile, GDAL's block cache), not the interpreter and its libraries.
    """
    if options.tile_size:
        return options.tile_size
    budget = options.memory_budget_mb * 2**20 - gdal_cache(options) - reserved
    if options.occlusion:
        budget -= geometry.lines * geometry.pixels * 4
    gsd = nadir_ground_pixel(geometry)
    for size in (2048, 1024, 512, 256, 128, 64):
        cells = size * size
        per_cell = 400 + 3 * bands * max(itemsize, 4)
        window_lines = 1.5 * size * resolution / max(gsd, 1e-9) + 8
        window = window_lines * geometry.pixels * bands * max(itemsize, 4)
        if cells * per_cell + window <= budget:
            return size
    raise RectifyOptionsError(
        f"rectify: a memory budget of {options.memory_budget_mb} MiB is too small for this strip "
        f"({geometry.lines} x {geometry.pixels} x {bands}); allow more with memory_budget_mb"
    )


def _orientation(geometry: MapStripGeometry, grid: OutputGrid) -> float:
    """Sign of det d(line, pixel)/d(row, col) on level ground at the strip centre."""
    l0, p0 = (geometry.lines - 1) / 2.0, (geometry.pixels - 1) / 2.0
    x, y, H = geometry.image_to_ground(np.array([l0]), np.array([p0]))
    if not np.isfinite(x[0]):
        raise GeometryError("rectify: the strip's centre pixel does not meet the DTM")
    r = grid.resolution
    line, pixel = geometry.ground_to_image(
        np.array([x[0], x[0] + r, x[0]]), np.array([y[0], y[0], y[0] - r]), np.full(3, H[0])
    )
    # columns: +col is +x, +row is -y
    det = (line[2] - line[0]) * (pixel[1] - pixel[0]) - (line[1] - line[0]) * (pixel[2] - pixel[0])
    return 1.0 if det > 0 else -1.0


def _output_nodata(options: RectifyOptions, src) -> float:
    if options.nodata is not None:
        return options.nodata
    if src.nodata is not None:
        return src.nodata
    return math.nan if np.issubdtype(np.dtype(src.dtypes[0]), np.floating) else 0


class _WorkArrays:
    """Per-cell results of pass 1: in memory when they fit the budget, else memory-mapped files."""

    SPECS = {"line": np.float64, "pixel": np.float32, "range": np.float32, "tolerance": np.float32}

    @classmethod
    def nbytes(cls, shape: tuple[int, int], extra: tuple[str, ...]) -> int:
        per_cell = sum(np.dtype(t).itemsize for t in cls.SPECS.values()) + 4 * len(extra)
        return shape[0] * shape[1] * per_cell

    def __init__(self, folder: Path, shape: tuple[int, int], extra: tuple[str, ...], in_memory: bool) -> None:
        self.arrays = {}
        specs = {**self.SPECS, **{name: np.float32 for name in extra}}
        for name, dtype in specs.items():
            if in_memory:
                self.arrays[name] = np.empty(shape, dtype)
            else:
                self.arrays[name] = np.lib.format.open_memmap(folder / f"{name}.npy", "w+", dtype, shape)

    def __getitem__(self, name: str) -> np.ndarray:
        return self.arrays[name]

    def close(self) -> None:
        self.arrays.clear()


def _tile_slices(w: Window) -> tuple[slice, slice]:
    return slice(w.row_off, w.row_off + w.height), slice(w.col_off, w.col_off + w.width)


@dataclass
class StripRun:
    """One strip's rectification in progress: what the steps share.

    ``work`` holds the per-cell results of :func:`map_cells` (image line and pixel, range to the
    sensor, its occlusion tolerance, optional layers) that :func:`resample` reads; ``zbuf`` the
    strip's z-buffer (None without occlusion).
    """

    geometry: MapStripGeometry
    grid: OutputGrid
    options: RectifyOptions
    src: rasterio.io.DatasetReader
    nodata: float
    work_dir: Path
    work: _WorkArrays
    zbuf: occlusion.ZBuffer | None
    result: StripResult

    @property
    def windows(self) -> list[Window]:
        """The output tiles of the resampling pass."""
        return list(self.grid.tiles(self.result.tile_size))

    @property
    def layers(self) -> tuple[str, ...]:
        return self.options.strip_layers


def start_run(geometry: MapStripGeometry, grid: OutputGrid, options: RectifyOptions, src: rasterio.io.DatasetReader,
              output: Path, work_dir: Path) -> StripRun:
    """Tile size, working arrays (in memory when they take at most a quarter of the budget, else
    memory-mapped files in ``work_dir``) and z-buffer of a strip."""
    dtype = np.dtype(src.dtypes[0])
    extra = tuple(n for n in ("view_zenith", "ground_pixel") if n in options.strip_layers)
    work_bytes = _WorkArrays.nbytes(grid.shape, extra)
    in_memory = work_bytes <= options.memory_budget_mb * 2**20 / 4
    tile = choose_tile_size(options, geometry, src.count, dtype.itemsize, grid.resolution,
                            reserved=work_bytes if in_memory else 0)
    return StripRun(
        geometry, grid, options, src, _output_nodata(options, src), work_dir,
        _WorkArrays(work_dir, grid.shape, extra, in_memory),
        occlusion.ZBuffer(geometry.lines, geometry.pixels) if options.occlusion else None,
        StripResult(output, grid, tile_size=tile),
    )


def tile_inverse_map(geometry: MapStripGeometry, tile: TileGrid, H: np.ndarray, options: InverseMapOptions,
                     seed: int = 0) -> tuple[np.ndarray, np.ndarray, InverseMapStats]:
    """(line, pixel, stats) of every cell of a tile: the refined map where the geometry can
    refine, else its ``ground_to_image`` at every cell; exact either way."""
    if isinstance(geometry, RefinableStrip):
        return build_refined_map(geometry, tile, H, options, seed=seed)
    return solve_every_cell(geometry.ground_to_image, tile, H)


def map_cells(run: StripRun, progress: ProgressCallback = no_progress) -> None:
    """Pass 1: the inverse map, the range to the sensor and the fold test of every cell, tile by
    tile, into ``run.work``; every tile's ranges into the z-buffer."""
    g = run.geometry
    # the projection centre at every line, one beyond each end (cells reach half a line out)
    tx, ty, tH = g.sensor_position(np.arange(-1, g.lines + 1, dtype=float))
    track = tuple(np.ascontiguousarray(t, dtype=float) for t in (tx, ty, tH))
    facing = _orientation(g, run.grid)
    run.result.inverse_map_method = "refine" if isinstance(g, RefinableStrip) else "exact"
    tiles = list(run.grid.tiles(min(run.result.tile_size, REFINE_TILE)))
    share = len(run.windows)  # pass 1 is the first half of the progress
    for i, w in enumerate(tiles):
        _map_tile(run, w, track, facing, seed=i)
        progress(share * (i + 1) / len(tiles), 2 * share, f"inverse map {run.result.path.stem}")
    stats = run.result.stats
    if stats.max_error_px > run.options.max_error_px:
        log.warning("%s: the inverse map's validation sample found %.3f px, above the tolerance of %.3f px",
                    run.result.path.name, stats.max_error_px, run.options.max_error_px)


def _tile_heights(geometry: MapStripGeometry, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    if isinstance(geometry, RefinableStrip):
        return np.asarray(geometry.height_on_lattice(x, y), dtype=float)
    return np.asarray(geometry.height(*np.meshgrid(x, y)), dtype=float)


def _map_tile(run: StripRun, w: Window, track: tuple[np.ndarray, ...], facing: float, seed: int) -> None:
    """Pass 1 of one tile: (line, pixel) of its cells, unseen beyond the image, ranges, folds."""
    g, grid = run.geometry, run.grid
    x = grid.x_of_col(np.arange(w.col_off, w.col_off + w.width))
    y = grid.y_of_row(np.arange(w.row_off, w.row_off + w.height))
    H = _tile_heights(g, x, y)
    line, pixel, stats = tile_inverse_map(g, TileGrid(x[0], y[0], grid.resolution), H, run.options.inverse_map,
                                          seed)
    run.result.stats.merge(stats)
    near = np.isfinite(line) & np.isfinite(pixel)
    with np.errstate(invalid="ignore"):
        near &= (line > -2) & (line < g.lines + 1) & (pixel > -2) & (pixel < g.pixels + 1)
    line[~near] = np.nan
    pixel[~near] = np.nan
    rng = np.empty(line.shape)
    sH = np.empty(line.shape)
    choose_threading_layer()
    _ranges(line, x, y, H, track[0], track[1], track[2], rng, sH)
    rs, cs = _tile_slices(w)
    work = run.work
    if run.zbuf is not None:
        rng_eff = np.where(occlusion.folded(line, pixel, facing), np.inf, rng)
        run.zbuf.add(line, pixel, rng_eff)
        work["tolerance"][rs, cs] = occlusion.range_tolerance(rng)
    else:
        rng_eff = rng
    work["line"][rs, cs] = line
    work["pixel"][rs, cs] = pixel
    work["range"][rs, cs] = rng_eff
    if "view_zenith" in work.arrays:
        with np.errstate(invalid="ignore"):
            work["view_zenith"][rs, cs] = np.degrees(np.arccos(np.clip((sH - H) / rng, -1, 1)))
    if "ground_pixel" in work.arrays:
        dl_dr, dl_dc, dp_dr, dp_dc = occlusion.image_jacobian(line, pixel)
        with np.errstate(invalid="ignore", divide="ignore"):
            det = np.abs(dl_dr * dp_dc - dl_dc * dp_dr)
            work["ground_pixel"][rs, cs] = np.where(det > 0, grid.resolution / np.sqrt(det), np.nan)


@numba.njit(parallel=True, cache=True)
def _ranges(line, x, y, H, tx, ty, tH, rng, sH):
    """Range from each cell (x[j], y[i], H) to the projection centre at its line, and the centre's
    height; the track is sampled at lines -1, 0, ..., lines (linear between, constant beyond, as
    ``np.interp``); NaN where the line is."""
    R, C = line.shape
    n = tx.shape[0]
    for i in numba.prange(R):
        for j in range(C):
            f = line[i, j] + 1.0
            if not np.isfinite(f) or not np.isfinite(H[i, j]):
                rng[i, j] = np.nan
                sH[i, j] = np.nan
                continue
            f = min(max(f, 0.0), n - 1.0)
            k = min(int(f), n - 2)
            a = f - k
            px = tx[k] + a * (tx[k + 1] - tx[k])
            py = ty[k] + a * (ty[k + 1] - ty[k])
            ph = tH[k] + a * (tH[k + 1] - tH[k])
            rng[i, j] = math.sqrt((x[j] - px) ** 2 + (y[i] - py) ** 2 + (H[i, j] - ph) ** 2)
            sH[i, j] = ph


@dataclass
class Resampled:
    """The working files of pass 2 (in ``run.work_dir``), not yet in their final layout."""

    image: Path
    layers: Path | None
    glt: GltWriter | None
    tags: dict[str, object]
    dtype: np.dtype


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
    with contextlib.ExitStack() as stack:
        dst = stack.enter_context(rasterio.open(out.image, "w", **working_profile(grid, src.count, dtype, run.nodata)))
        lay = None
        if out.layers is not None:
            profile = working_profile(grid, len(layers), np.float32, math.nan)
            lay = stack.enter_context(rasterio.open(out.layers, "w", **profile))
        for i, w in enumerate(windows):
            _resample_tile(run, w, dst, lay, out.glt)
            progress(len(windows) + i + 1, 2 * len(windows), f"resample {run.result.path.stem}")
        describe(dst, bands, out.tags)
    return out


def write_outputs(run: StripRun, resampled: Resampled) -> None:
    """The working files into their final layout under their final names: the layers, the GLT,
    the orthoimage last (its presence means the strip's outputs are complete)."""
    output, options, result = run.result.path, run.options, run.result
    if resampled.layers is not None:
        result.layers_path = output.with_name(output.stem + ".layers.tif")
        with rasterio.open(resampled.layers, "r+") as lay:
            layer_tags = {**resampled.tags, "layers": " ".join(run.layers)}
            if "time" in run.layers:
                layer_tags["time_origin_s"] = repr(time_origin(run.geometry))
            describe(lay, [BandInfo(n) for n in run.layers], layer_tags)
        finalise(resampled.layers, result.layers_path, options.geotiff, np.float32)
    if resampled.glt is not None:
        result.glt_path = resampled.glt.commit(output.with_suffix(".glt"))
    finalise(resampled.image, output, options.geotiff, resampled.dtype)


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


def _resample_tile(run: StripRun, w: Window, dst, lay, glt: GltWriter | None) -> None:
    """Pass 2 of one tile: visible cells resampled, nodata elsewhere; its layers and GLT."""
    g, src, work, result = run.geometry, run.src, run.work, run.result
    rs, cs = _tile_slices(w)
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
    lw = line_window(line, valid, g.lines, radius)
    if lw is None:
        out = np.full((src.count,) + line.shape, run.nodata, dtype=np.dtype(src.dtypes[0]))
    else:
        data = src.read(window=lw.window(g.pixels))
        out = remap_bands(data, line, pixel, lw, resampling)
        if src.nodata is not None:
            valid &= ~source_nodata_mask(data, src.nodata, line, pixel, lw, resampling)
        out[:, ~valid] = run.nodata
    result.valid_cells += int(valid.sum())
    dst.write(out, window=w)
    if lay is not None:
        lay.write(_layer_values(g, work, rs, cs, line, pixel, valid, run.layers), window=w)
    if glt is not None:
        glt.write(w, line, pixel, valid)


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
