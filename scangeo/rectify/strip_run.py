"""One strip's rectification in progress: its output grid, tile size within the memory budget,
working arrays and z-buffer (:class:`StripRun`), and what it produced (:class:`StripResult`).

The passes (:mod:`scangeo.rectify.cell_map`, :mod:`scangeo.rectify.cell_values`) and
:func:`scangeo.rectify.strip.rectify_strip` share these.
"""
from __future__ import annotations

import logging
import math
from concurrent.futures import Future
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import rasterio
from rasterio.windows import Window

from scangeo.errors import RectifyOptionsError
from scangeo.rectify import occlusion
from scangeo.rectify.coregistration_layer import CoregistrationGrid
from scangeo.rectify.geometry import MapStripGeometry, footprint_bounds, nadir_ground_pixel
from scangeo.rectify.inverse_map import InverseMapStats
from scangeo.rectify.options import RectifyOptions
from scangeo.rectify.output_grid import OutputGrid, nice_resolution
from scangeo.rectify.raw_image import GdalReader, RawCube, image_reader

log = logging.getLogger(__name__)

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
    #: the co-registration layer (a platform's strip with a reference, :mod:`scangeo.rectify.coregistration_layer`)
    coregistration_path: Path | None = None
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
        extra = {} if self.coregistration_path is None else {"coregistration": str(self.coregistration_path)}
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
            **extra,
        }


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
        f"rectify: a memory budget of {options.memory_budget_mb:g} MiB is too small for this strip "
        f"({geometry.lines} x {geometry.pixels} x {bands}); allow more with memory_budget_mb"
    )


def _output_nodata(options: RectifyOptions, src) -> float:
    if options.nodata is not None:
        return options.nodata
    if src.nodata is not None:
        return src.nodata
    return math.nan if np.issubdtype(np.dtype(src.dtypes[0]), np.floating) else 0


class WorkArrays:
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


def tile_slices(w: Window) -> tuple[slice, slice]:
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
    work: WorkArrays
    zbuf: occlusion.ZBuffer | None
    result: StripResult
    #: the relative displacement to interpolate at the cells (None: no co-registration layer)
    coregistration: CoregistrationGrid | None = None
    #: ``read(window)`` of the image's bands: raw for a plain ENVI cube, else GDAL (``raw_image``)
    reader: RawCube | GdalReader = field(init=False)

    def __post_init__(self) -> None:
        self.reader = image_reader(self.src)

    @property
    def windows(self) -> list[Window]:
        """The output tiles of the resampling pass."""
        return list(self.grid.tiles(self.result.tile_size))

    @property
    def layers(self) -> tuple[str, ...]:
        return self.options.layers


def start_run(geometry: MapStripGeometry, grid: OutputGrid, options: RectifyOptions, src: rasterio.io.DatasetReader,
              output: Path, work_dir: Path) -> StripRun:
    """Tile size, working arrays (in memory when they take at most a quarter of the budget, else
    memory-mapped files in ``work_dir``) and z-buffer of a strip."""
    dtype = np.dtype(src.dtypes[0])
    extra = tuple(n for n in ("view_zenith", "ground_pixel") if n in options.layers)
    work_bytes = WorkArrays.nbytes(grid.shape, extra)
    in_memory = work_bytes <= options.memory_budget_mb * 2**20 / 4
    tile = choose_tile_size(options, geometry, src.count, dtype.itemsize, grid.resolution,
                            reserved=work_bytes if in_memory else 0)
    return StripRun(
        geometry, grid, options, src, _output_nodata(options, src), work_dir,
        WorkArrays(work_dir, grid.shape, extra, in_memory),
        occlusion.ZBuffer(geometry.lines, geometry.pixels) if _occlusion_test(options, geometry, grid) else None,
        StripResult(output, grid, tile_size=tile),
    )


def _occlusion_test(options: RectifyOptions, geometry: MapStripGeometry, grid: OutputGrid) -> bool:
    """Whether the strip needs the fold test and the z-buffer: asked for, and its terrain could
    hide ground (:func:`scangeo.rectify.occlusion.could_hide`; when it cannot, every cell is visible
    and the tests would change nothing)."""
    if not options.occlusion:
        return False
    if occlusion.could_hide(geometry, grid.bounds):
        return True
    log.debug("%s: the terrain is less steep than every ray: no ground can be hidden, no occlusion test",
              geometry)
    return False
