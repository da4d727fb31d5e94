"""Rectify one strip onto its output grid, in tiles, in two passes.

Pass 1, per tile: DTM heights, the inverse map (exact on a coarse lattice, interpolated under
error control), the range to the sensor, the fold test; every tile's ranges go into the strip's
z-buffer. The per-cell results are kept in memory when they take at most a quarter of the memory
budget, else in memory-mapped work files beside the output.
Pass 2, per tile: visibility against the complete z-buffer, the image lines the tile needs (a
rasterio window), ``cv2.remap`` of every band, nodata outside the swath, where the DTM has none
and where the ground is hidden; optional layers and the GLT. The working GeoTIFF is then copied
into the final layout (COG) under a hidden name and renamed: an interrupted run leaves nothing
that looks finished.
"""
from __future__ import annotations

import logging
import math
import shutil
import tempfile
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numba
import numpy as np
import rasterio
from rasterio.windows import Window

from scangeo import __version__
from scangeo.errors import InputFileError, ScangeoError
from scangeo.progress import ProgressCallback, no_progress
from scangeo.rectify import occlusion
from scangeo.rectify.geometry import StripGeometry, footprint_bounds, nadir_ground_pixel
from scangeo.rectify.geolocation import GltWriter
from scangeo.rectify.geotiff import BandInfo, bands_of, describe, finalise, remove_partials, working_profile
from scangeo.rectify.inverse_map import InverseMapStats, TileGrid, build_inverse_map
from scangeo.rectify.options import LAYERS, RectifyOptions
from scangeo.rectify.refined_map import build_refined_map
from scangeo.rectify.output_grid import OutputGrid, nice_resolution
from scangeo.rectify.resample import RESAMPLING, in_image, line_window, remap_bands, source_nodata_mask

log = logging.getLogger(__name__)

#: largest tile of the inverse map, cells: its along-track baseline (scangeo.rectify.inverse_map)
#: models the attitude's effect across a tile's width, which stays simple over 640 m
INVERSE_TILE = 256
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

    def summary(self) -> dict:
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


def strip_grid(geometry: StripGeometry, options: RectifyOptions) -> OutputGrid:
    """The output grid of a strip: the given or the nadir resolution, the given or footprint bounds."""
    res = options.resolution or nice_resolution(nadir_ground_pixel(geometry))
    bounds = options.bounds or footprint_bounds(geometry)
    return OutputGrid.from_bounds(geometry.crs, bounds, res)


def choose_tile_size(
    options: RectifyOptions, geometry: StripGeometry, bands: int, itemsize: int, resolution: float,
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
    raise ScangeoError(
        f"rectify: a memory budget of {options.memory_budget_mb} MiB is too small for this strip "
        f"({geometry.lines} x {geometry.pixels} x {bands}); allow more with memory_budget_mb"
    )


def _orientation(geometry: StripGeometry, grid: OutputGrid) -> float:
    """Sign of det d(line, pixel)/d(row, col) on level ground at the strip centre."""
    l0, p0 = (geometry.lines - 1) / 2.0, (geometry.pixels - 1) / 2.0
    x, y, H = geometry.image_to_ground(np.array([l0]), np.array([p0]))
    if not np.isfinite(x[0]):
        raise ScangeoError("rectify: the strip's centre pixel does not meet the DTM")
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


def _pass1_tile(geometry, grid, w, options, track, orientation, zbuf, work, stats, seed):
    rows = np.arange(w.row_off, w.row_off + w.height)
    cols = np.arange(w.col_off, w.col_off + w.width)
    x, y = grid.x_of_col(cols), grid.y_of_row(rows)
    if hasattr(geometry, "height_on_lattice"):
        H = np.asarray(geometry.height_on_lattice(x, y), dtype=float)
    else:
        H = np.asarray(geometry.height(*np.meshgrid(x, y)), dtype=float)
    tile_grid = TileGrid(x[0], y[0], grid.resolution)
    if _refines(geometry, options):
        line, pixel, st = build_refined_map(geometry, tile_grid, H, options.inverse_map, seed=seed)
    else:
        along = (track[0][-1] - track[0][0], track[1][-1] - track[1][0])
        line, pixel, st = build_inverse_map(
            geometry.ground_to_image, tile_grid, H, (geometry.lines, geometry.pixels), options.inverse_map,
            seed=seed, along=along, height=geometry.height,
        )
    stats.merge(st)
    near = np.isfinite(line) & np.isfinite(pixel)
    with np.errstate(invalid="ignore"):
        near &= (line > -2) & (line < geometry.lines + 1) & (pixel > -2) & (pixel < geometry.pixels + 1)
    line[~near] = np.nan
    pixel[~near] = np.nan
    rng = np.empty(line.shape)
    sH = np.empty(line.shape)
    _ranges(line, x, y, H, *(np.ascontiguousarray(t, dtype=float) for t in track), rng, sH)
    rs, cs = _tile_slices(w)
    if options.occlusion:
        rng_eff = np.where(occlusion.folded(line, pixel, orientation), np.inf, rng)
        zbuf.add(line, pixel, rng_eff)
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


def _refines(geometry: StripGeometry, options: RectifyOptions) -> bool:
    """Whether the inverse map is refined per cell (the geometry can, and it is asked for)."""
    return options.inverse_map.method == "refine" and hasattr(geometry, "ground_to_image_near") and hasattr(
        geometry, "height_on_lattice")


def rectify_strip(
    geometry: StripGeometry,
    image: str | Path,
    output: str | Path,
    options: RectifyOptions = RectifyOptions(),
    grid: OutputGrid | None = None,
    tags: dict[str, object] | None = None,
    bands: list[BandInfo] | None = None,
    progress: ProgressCallback = no_progress,
) -> StripResult:
    """Rectify the strip image ``image`` onto ``grid`` and write the orthoimage ``output``.

    Parameters
    ----------
    geometry : the strip's geometry (orientation, sensor, DTM), map coordinates.
    image : the strip image, lines x pixels x bands (any GDAL raster).
    output : the orthoimage GeoTIFF to write; ``NAME.layers.tif`` and ``NAME.glt`` beside it
        when layers or the GLT are asked for.
    options : resolution, resampling, tolerance, memory budget, layers, GeoTIFF layout.
    grid : the output grid (default: :func:`strip_grid`).
    tags : metadata recorded in the GeoTIFF (variant, sigma0, fingerprint ...).
    bands : band names and wavelengths (default: from the image).
    progress : ``callback(done, total, message)``.
    """
    started = time.perf_counter()
    image, output = Path(image), Path(output)
    output.parent.mkdir(parents=True, exist_ok=True)
    remove_partials(output)
    grid = grid or strip_grid(geometry, options)
    layers = options.strip_layers
    try:
        with warnings.catch_warnings():  # a raw scanner image has no georeferencing
            warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)
            src_ctx = rasterio.open(image)
    except rasterio.errors.RasterioIOError as exc:
        raise InputFileError(f"{image}: cannot read the strip image ({exc})") from exc
    with rasterio.Env(GDAL_CACHEMAX=gdal_cache(options)), src_ctx as src:
        if (src.height, src.width) != (geometry.lines, geometry.pixels):
            raise InputFileError(
                f"{image}: image has {src.height} lines x {src.width} pixels, the strip's geometry "
                f"{geometry.lines} x {geometry.pixels}"
            )
        dtype = np.dtype(src.dtypes[0])
        nodata = _output_nodata(options, src)
        bands = bands or bands_of(src)
        extra = tuple(n for n in ("view_zenith", "ground_pixel") if n in layers)
        work_bytes = _WorkArrays.nbytes(grid.shape, extra)
        in_memory = work_bytes <= options.memory_budget_mb * 2**20 / 4
        tile = choose_tile_size(options, geometry, src.count, dtype.itemsize, grid.resolution,
                                reserved=work_bytes if in_memory else 0)
        result = StripResult(output, grid, tile_size=tile)
        windows = list(grid.tiles(tile))
        total = 2 * len(windows)
        work_dir = Path(tempfile.mkdtemp(dir=output.parent, prefix=f".{output.name}.partial-"))
        try:
            work = _WorkArrays(work_dir, grid.shape, extra, in_memory)
            zbuf = occlusion.ZBuffer(geometry.lines, geometry.pixels) if options.occlusion else None
            # the projection centre at every line, one beyond each end (cells reach half a line out)
            track = geometry.sensor_position(np.arange(-1, geometry.lines + 1, dtype=float))
            orientation = _orientation(geometry, grid)
            result.inverse_map_method = "refine" if _refines(geometry, options) else "lattice"
            inverse_tile = REFINE_TILE if result.inverse_map_method == "refine" else INVERSE_TILE
            inverse_tiles = list(grid.tiles(min(tile, inverse_tile)))
            for i, w in enumerate(inverse_tiles):
                _pass1_tile(geometry, grid, w, options, track, orientation, zbuf, work, result.stats, seed=i)
                progress(len(windows) * (i + 1) / len(inverse_tiles), total, f"inverse map {output.stem}")
            if result.stats.max_error_px > options.max_error_px:
                log.warning(
                    "%s: the inverse map's validation sample found %.3f px, above the tolerance of %.3f px "
                    "(inverse_map_method %s; 'refine' solves every cell exactly)", output.name,
                    result.stats.max_error_px, options.max_error_px, options.inverse_map_method)
            working = work_dir / "working.tif"
            layer_file = work_dir / "layers.tif" if layers else None
            glt = GltWriter(work_dir / "glt", grid) if options.glt else None
            with rasterio.open(working, "w", **working_profile(grid, src.count, dtype, nodata)) as dst:
                lay = (
                    rasterio.open(layer_file, "w", **working_profile(grid, len(layers), np.float32, math.nan))
                    if layer_file else None
                )
                try:
                    for i, w in enumerate(windows):
                        _pass2_tile(src, dst, lay, glt, geometry, w, options, layers, work, zbuf, nodata, result)
                        progress(len(windows) + i + 1, total, f"resample {output.stem}")
                finally:
                    if lay is not None:
                        lay.close()
                all_tags = _tags(tags, options, result)
                describe(dst, bands, all_tags)
            # the orthoimage last: its presence means the strip's outputs are complete
            if layer_file is not None:
                result.layers_path = output.with_name(output.stem + ".layers.tif")
                with rasterio.open(layer_file, "r+") as lay:
                    layer_tags = {**all_tags, "layers": " ".join(layers)}
                    if "time" in layers:
                        layer_tags["time_origin_s"] = repr(time_origin(geometry))
                    describe(lay, [BandInfo(n) for n in layers], layer_tags)
                finalise(layer_file, result.layers_path, options.geotiff, np.float32)
            if glt is not None:
                result.glt_path = glt.commit(output.with_suffix(".glt"))
            finalise(working, output, options.geotiff, dtype)
            work.close()
        finally:
            shutil.rmtree(work_dir, ignore_errors=True)
    result.seconds = time.perf_counter() - started
    log.info(
        "%s: %d x %d cells, %d valid, %d hidden, inverse map %d exact points, max error %.4f px, %.2f s",
        output.name, grid.width, grid.height, result.valid_cells, result.hidden_cells,
        result.stats.exact_points, result.stats.max_error_px, result.seconds,
    )
    return result


def _tags(tags, options: RectifyOptions, result: StripResult) -> dict[str, object]:
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


def _pass2_tile(src, dst, lay, glt, geometry, w, options, layers, work, zbuf, nodata, result):
    rs, cs = _tile_slices(w)
    line = np.asarray(work["line"][rs, cs])
    pixel = np.asarray(work["pixel"][rs, cs])
    valid = in_image(line, pixel, geometry.lines, geometry.pixels)
    if zbuf is not None:
        rng = np.asarray(work["range"][rs, cs])
        seen = occlusion.visible(rng, np.asarray(work["tolerance"][rs, cs]), zbuf.nearest(line, pixel))
        result.hidden_cells += int((valid & ~seen).sum())
        valid &= seen
    _, radius = RESAMPLING[options.resampling]
    lw = line_window(line, valid, geometry.lines, radius)
    dtype = np.dtype(src.dtypes[0])
    if lw is None:
        out = np.full((src.count,) + line.shape, nodata, dtype=dtype)
    else:
        data = src.read(window=lw.window(geometry.pixels))
        out = remap_bands(data, line, pixel, lw, options.resampling)
        if src.nodata is not None:
            valid &= ~source_nodata_mask(data, src.nodata, line, pixel, lw, options.resampling)
        out[:, ~valid] = nodata
    result.valid_cells += int(valid.sum())
    dst.write(out, window=w)
    if lay is not None:
        lay.write(_layer_values(geometry, work, rs, cs, line, pixel, valid, layers), window=w)
    if glt is not None:
        glt.write(w, line, pixel, valid)


def time_origin(geometry: StripGeometry) -> float:
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
