"""Matching tasks: one overlap of two strips (tie points) or one strip against a reference (control).

A task is picklable (paths and settings only); :func:`run_task` turns it into candidate points in
whatever process runs it: in-process, in a process pool or on a Dask cluster, as rectification's
strip tasks do. Per cell, the strips (and the reference) are rectified onto one chip grid; the
best-textured cells of the master chip (Shi-Tomasi corners: well localised in both directions) are
the candidates; each candidate's template is matched into every other chip by correlation and
least-squares matching (:mod:`scangeo.match.correlate`); each matched ground position is carried
back into the strip's raw (line, pixel) with the exact ground -> image on the DTM.
"""
from __future__ import annotations

import logging
from collections import Counter
from dataclasses import dataclass, field

import cv2
import numpy as np

from scangeo.filecache import FileCache
from scangeo.io.project import Project
from scangeo.match.correlate import match_template, prepare, smooth
from scangeo.match.options import MatchOptions
from scangeo.match.overlaps import Cell
from scangeo.match.reference import Reference
from scangeo.match.strips import Chip, ChipGrid, MatchStrip
from scangeo.orientation import reuse
from scangeo.orientation.file import FILE_NAME

log = logging.getLogger(__name__)

#: candidates tried per wanted point of a cell
CANDIDATES_PER_POINT = 8
#: a chip whose grey values vary less than this (standard deviation) has no texture to match
FLAT = 1e-3


@dataclass(frozen=True)
class MatchTask:
    """One overlap (``kind = "tie"``: strips[0] is the master) or one strip (``"control"``)."""

    kind: str
    project: str
    variant: str
    strips: tuple[str, ...]  # the overlap's two strips, then further strips of triple overlaps
    cells: tuple[Cell, ...]
    options: MatchOptions
    resolution: float
    reference: str | None = None
    name: str = ""


@dataclass
class Measured:
    """A point matched in one cell: master position and, per strip, its raw measurement."""

    cell: int
    x: float  # master position, map units
    y: float
    # strip -> (x, y, line, pixel, image pixels per chip cell, correlation, LSM sigma in chip cells)
    strips: dict[str, tuple[float, float, float, float, float, float, float]] = field(default_factory=dict)
    sigma: dict[str, float] = field(default_factory=dict)  # strip -> sigma_px (set after the consistency test)


@dataclass
class TaskResult:
    kind: str
    name: str
    strips: tuple[str, ...]
    points: list[Measured]
    rejected: Counter
    candidates: int
    cells: int
    cells_without_points: int


def margin_cells(options: MatchOptions) -> int:
    return options.template_px // 2 + options.search_px + 4


def _candidates(master: np.ndarray, usable: np.ndarray, count: int, min_distance: float) -> np.ndarray:
    """(n, 2) (col, row) of the strongest corners of ``master`` inside ``usable``, strongest first."""
    finite = np.isfinite(master)
    if not usable.any() or not finite.any():
        return np.empty((0, 2), int)
    image = np.where(finite, master, float(master[finite].mean())).astype(np.float32)
    found = cv2.goodFeaturesToTrack(image, maxCorners=count, qualityLevel=0.001, minDistance=min_distance,
                                    mask=usable.astype(np.uint8), blockSize=5)
    if found is None:
        return np.empty((0, 2), int)
    return np.rint(found.reshape(-1, 2)).astype(int)


def match_cell(master: np.ndarray, targets: dict[str, Chip], inner: np.ndarray, options: MatchOptions,
               wanted: int, required: str | None, rejected: Counter) -> list[tuple[int, int, dict]]:
    """Match the best corners of ``master`` inside ``inner`` into the target chips.

    Returns up to ``wanted`` points as (col, row, {strip: Match}); a point needs a match in
    ``required`` (the overlap's second strip) or, without it, in any target. ``rejected`` counts
    failed candidates by reason.
    """
    h = options.template_px // 2
    reach = h + options.search_px + 2
    usable = np.isfinite(master)
    for chip in targets.values():
        usable &= np.isfinite(chip.image)
    usable = cv2.erode(usable.astype(np.uint8), np.ones((2 * reach + 1, 2 * reach + 1), np.uint8)) > 0
    usable &= inner
    for sid, chip in targets.items():
        if sid == required and usable.any() and float(np.nanstd(chip.image[usable])) < FLAT:
            rejected[f"no texture in strip {sid}"] += 1  # water, cloud, a saturated image
            return []
    master = smooth(master, options.smooth_cells)
    prepared = {sid: prepare(smooth(chip.image, options.smooth_cells)) for sid, chip in targets.items()}
    out: list[tuple[int, int, dict]] = []
    candidates = _candidates(master, usable, CANDIDATES_PER_POINT * wanted, 0.5 * options.template_px)
    if len(candidates) == 0:
        rejected["no texture" if required is None or float(np.nanstd(master[inner])) < FLAT
                 else "no corner"] += 1
    for col, row in candidates:
        if len(out) >= wanted:
            break
        template = master[row - h:row + h + 1, col - h:col + h + 1]
        if not np.isfinite(template).all():
            rejected["no data"] += 1
            continue
        matches = {}
        for sid, prep in prepared.items():
            m, reason = match_template(template, prep, col, row, options.search_px, options.min_correlation,
                                       options.max_second_peak, options.max_sigma_px)
            if m is None:
                if sid == required or required is None:
                    rejected[reason] += 1
                continue
            matches[sid] = m
        if (required is not None and required not in matches) or not matches:
            continue
        out.append((int(col), int(row), matches))
    return out


def _measure(point_cell: int, grid: ChipGrid, col: int, row: int, matches: dict, chips: dict[str, Chip],
             strips: dict[str, MatchStrip], options: MatchOptions) -> Measured:
    x, y = grid.to_map(col, row)
    m = Measured(point_cell, float(x), float(y))
    for sid, match in matches.items():
        tx, ty = grid.to_map(match.x, match.y)
        scale = chips[sid].scale_at(int(round(match.x)), int(round(match.y)))
        # (line, pixel) filled in by _back_project, for all points of a task at once
        m.strips[sid] = (float(tx), float(ty), np.nan, np.nan, float(scale), float(match.correlation),
                         float(match.sigma))
    return m


def _back_project(points: list[Measured], strips: dict[str, MatchStrip]) -> None:
    """Every matched ground position into its strip's raw (line, pixel): exact ground -> image on the DTM."""
    for sid, strip in strips.items():
        todo = [(p, p.strips[sid]) for p in points if sid in p.strips and np.isnan(p.strips[sid][2])]
        if not todo:
            continue
        line, pixel = strip.image_of(np.array([m[0] for _, m in todo]), np.array([m[1] for _, m in todo]))
        for (p, m), ln, px in zip(todo, line, pixel):
            p.strips[sid] = (m[0], m[1], float(ln), float(px), *m[4:])
    for p in points:
        p.strips = {sid: m for sid, m in p.strips.items() if np.isfinite(m[2]) and np.isfinite(m[3])}


#: strips of the last tasks in this process (a worker runs several tasks of one project), keyed by the
#: stamps of every file a strip is read from
_STRIPS: FileCache[MatchStrip] = FileCache("match strips", 4)


def clear_caches() -> None:
    """Forget the strips, projects and orientations of earlier tasks (files may have changed)."""
    _STRIPS.clear()
    reuse.clear()


def _strip(project: Project, task: MatchTask, sid: str) -> MatchStrip:
    s = project.strip(sid)
    files = [project.root / "project.toml", getattr(project, "dtm_path", None), s.image, s.trajectory, s.line_times,
             project.root / "results" / task.variant / FILE_NAME]
    key = (task.project, task.variant, sid, task.options.bands, task.options.smooth_cells)
    return _STRIPS.get(key, files, lambda: MatchStrip(project, task.variant, sid, task.options,
                                                      orientation=reuse.orientation_of(project, task.variant)))


def _inner(grid: ChipGrid, cell: Cell) -> np.ndarray:
    """Chip cells inside the cell's box (half-open: a point on a shared edge belongs to one cell)."""
    xs, ys = grid.xs(), grid.ys()
    return ((ys > cell.ymin) & (ys <= cell.ymax))[:, None] & ((xs >= cell.xmin) & (xs < cell.xmax))[None, :]


def run_task(task: MatchTask) -> TaskResult:
    """Match one task's cells (in whatever process runs this)."""
    project = reuse.project_of(task.project)  # shared by the tasks of this process
    options = task.options
    strips = {sid: _strip(project, task, sid) for sid in task.strips}
    margin = margin_cells(options)
    rejected: Counter = Counter()
    points: list[Measured] = []
    candidates = empty = 0
    reference = None
    if task.kind == "control":
        reference = Reference(task.reference or "", project.crs, options.reference_bands)
    try:
        for cell in task.cells:
            grid = ChipGrid.around(cell.xmin, cell.ymin, cell.xmax, cell.ymax, task.resolution, margin)
            H = strips[task.strips[0]].heights(grid)
            if task.kind == "tie":
                wanted = options.per_cell
                master_chip = strips[task.strips[0]].chip(grid, H)
                master = master_chip.image
                chips = {sid: strips[sid].chip(grid, H) for sid in (task.strips[1], *cell.others) if sid in strips}
                required: str | None = task.strips[1]
            else:
                assert reference is not None
                wanted = max(1, int(np.ceil(options.control_per_strip / max(len(task.cells), 1))))
                master = reference.chip(grid)
                chips = {task.strips[0]: strips[task.strips[0]].chip(grid, H)}
                required = task.strips[0]
            before = sum(rejected.values())
            found = match_cell(master, chips, _inner(grid, cell), options, wanted, required, rejected)
            candidates += len(found) + sum(rejected.values()) - before
            if not found:
                empty += 1
            all_chips = dict(chips)
            if task.kind == "tie":
                all_chips[task.strips[0]] = master_chip
            for col, row, matches in found:
                m = _measure(cell.index, grid, col, row, matches, all_chips, strips, options)
                if task.kind == "tie":  # the master's measurement: the chip cell's own raw position
                    ln, px = master_chip.line[row, col], master_chip.pixel[row, col]
                    first = next(iter(m.strips.values()))
                    m.strips = {task.strips[0]: (m.x, m.y, float(ln), float(px), master_chip.scale_at(col, row),
                                                 1.0, first[6]), **m.strips}
                points.append(m)
    finally:
        if reference is not None:
            reference.close()
    _back_project(points, strips)
    need = 2 if task.kind == "tie" else 1
    points = [p for p in points if len(p.strips) >= need]
    return TaskResult(task.kind, task.name, task.strips, points, rejected, candidates, len(task.cells), empty)
