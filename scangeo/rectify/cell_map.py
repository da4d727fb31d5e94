"""Pass 1 of rectifying a strip, per tile: DTM heights, the inverse map (refined per cell: exact at
every cell), the range to the sensor, the fold test; every tile's ranges go into the strip's
z-buffer. The per-cell results go into the run's working arrays (:class:`~scangeo.rectify.strip_run.StripRun`).
"""
from __future__ import annotations

import logging
import math

import numba
import numpy as np
from rasterio.windows import Window

from scangeo.errors import GeometryError
from scangeo.progress import ProgressCallback, no_progress
from scangeo.rectify import occlusion
from scangeo.rectify.geometry import MapStripGeometry
from scangeo.rectify.inverse_map import InverseMapOptions, InverseMapStats, TileGrid, solve_every_cell
from scangeo.rectify.output_grid import OutputGrid
from scangeo.rectify.refined_map import RefinableStrip, build_refined_map
from scangeo.rectify.strip_run import StripRun, tile_slices
from scangeo.threading_layer import choose_threading_layer

log = logging.getLogger(__name__)

#: largest tile of the refined inverse map (scangeo.rectify.refined_map), cells: no model across
#: the tile, so only the memory budget (the pass's tile) bounds it
REFINE_TILE = 1024


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
    rng = np.empty(line.shape)
    sH = np.empty(line.shape)
    choose_threading_layer()
    _ranges(line, pixel, float(g.lines), float(g.pixels), x, y, H, track[0], track[1], track[2], rng, sH)
    rs, cs = tile_slices(w)
    work = run.work
    if run.zbuf is not None:
        rng_eff = np.where(occlusion.folded(line, pixel, facing), np.inf, rng)
        run.zbuf.add(line, pixel, rng_eff)
        work["tolerance"][rs, cs] = occlusion.range_tolerance(rng, line, pixel)
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
def _ranges(line, pixel, lines, pixels, x, y, H, tx, ty, tH, rng, sH):
    """Range from each cell (x[j], y[i], H) to the projection centre at its line, and the centre's
    height; the track is sampled at lines -1, 0, ..., lines (linear between, constant beyond, as
    ``np.interp``). A cell whose (line, pixel) is not within two pixels of the image is unseen: its
    line and pixel become NaN (in place), and so do its range and height; NaN where the line is."""
    R, C = line.shape
    n = tx.shape[0]
    for i in numba.prange(R):
        for j in range(C):
            ln, px = line[i, j], pixel[i, j]
            if not (np.isfinite(ln) and np.isfinite(px) and -2 < ln < lines + 1 and -2 < px < pixels + 1):
                line[i, j] = np.nan
                pixel[i, j] = np.nan
                rng[i, j] = np.nan
                sH[i, j] = np.nan
                continue
            f = ln + 1.0
            if not np.isfinite(H[i, j]):
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
