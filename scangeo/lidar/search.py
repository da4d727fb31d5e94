"""The patch search over all strips of a laser project, strip by strip (in worker processes or on a
Dask cluster on request: :func:`scangeo.parallel.run_tasks`).

Two methods (``[adjustment] patch_search``):

- ``rows`` (the default, Kager 2004): pass 1 reads every strip in time order through the row
  buffer (:mod:`scangeo.lidar.rowbuffer`) and keeps its candidate patches; pass 2 reads every strip
  again and fits it on the boxes of all strips' candidates (:mod:`scangeo.lidar.seeded`); a patch
  is a seed accepted in two or more strips.
- ``grid``: cells of one fixed grid common to all strips (:mod:`scangeo.lidar.patches`), the fixed-grid
  method; a patch is a cell planar in two or more strips.

Both then go through :func:`scangeo.lidar.patches.homologous` (compatible planes, thinning by
exposition). Pass 1 also fits the grid cells of every strip (the strip differences are measured on
them, whichever method found the tie patches) and the control and check patches of ground.csv.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from scangeo.errors import InputFileError
from scangeo.io.project import Project, StripConfig
from scangeo.lidar.cells import BoxStream, GridCellStream
from scangeo.lidar.control import GivenPatches
from scangeo.lidar.lasio import iter_returns
from scangeo.lidar.patches import PatchOptions, StripPatches
from scangeo.lidar.planes import Planes
from scangeo.lidar.rowbuffer import Candidates, RowBuffer
from scangeo.lidar.seeded import Seeds, fit_seeds, members
from scangeo.parallel import run_tasks
from scangeo.progress import ProgressCallback, no_progress

METHODS = ("rows", "grid")
#: below this many returns per scan line (on average) in any strip, the row buffer has no scan lines
#: to work on (a thinned or resampled cloud): the search falls back to the grid cells
MIN_RETURNS_PER_LINE = 20
log = logging.getLogger(__name__)


@dataclass
class StripFound:
    """What the search finds in one strip: its members of tie patches (``patches``; ``cells`` are
    grid cell keys or seed indices), its planar grid cells (strip differences), the given patches."""

    id: str
    count: int
    t_start: float
    t_end: float
    patches: StripPatches
    cells: StripPatches
    given: Planes | None
    given_ok: np.ndarray | None
    candidates: Candidates | None = None


def _pass1(args) -> StripFound:
    """One strip streamed once: the row buffer's candidates, the planar grid cells (strip differences)
    and the given patches' planes, holding a chunk and the open cells, never the strip."""
    strip, crs, options, prior, given, method = args
    buffer = RowBuffer(strip.id, options, prior) if method == "rows" else None
    grid = GridCellStream(strip.id, options, prior)
    boxes = BoxStream(given.centre, given.axes, given.half, options, prior) if given is not None else None
    count, t0, t1 = 0, np.inf, -np.inf
    for part, time, angle in iter_returns(strip.las, strip.point_source_id, crs):
        count += time.size
        t0, t1 = min(t0, float(time.min())), max(t1, float(time.max()))
        grid.feed(part, time)
        if boxes is not None:
            boxes.feed(part, time)
        if buffer is not None:
            buffer.feed(part, time, angle)
    if not count:
        which = "" if strip.point_source_id is None else f" with point_source_id {strip.point_source_id}"
        raise InputFileError(f"{', '.join(map(str, strip.las))}: no returns{which} for strip {strip.id}")
    cells = grid.finish()
    planes, ok = boxes.finish() if boxes is not None else (None, None)
    candidates = buffer.finish() if buffer is not None else None
    return StripFound(strip.id, count, t0, t1, cells, cells, planes, ok, candidates)


def _pass2(args):
    strip, crs, seeds, rows, options, prior, speed = args
    chunks = iter_returns(strip.las, strip.point_source_id, crs)
    return fit_seeds(strip.id, chunks, seeds, rows, options, prior, speed)


def find_all(
    project: Project,
    options: PatchOptions,
    prior: float,
    given: GivenPatches | None,
    workers: int = 1,
    callback: ProgressCallback = no_progress,
    method: str = "rows",
    scheduler: str | None = None,
) -> dict[str, StripFound]:
    """Both passes over every strip: in this process, in ``workers`` local processes, or on the Dask
    scheduler at ``scheduler`` (:func:`scangeo.parallel.run_tasks`; a task is one strip, and carries
    its file paths, not its returns)."""
    strips: list[StripConfig] = list(project.strips)
    steps = len(strips) * (2 if method == "rows" else 1)
    tasks = [(s, project.crs, options, prior, given, method) for s in strips]
    found_list = run_tasks(_pass1, tasks, workers, scheduler,
                           lambda n, t: callback(n, steps, f"patches of strip {t[0].id} (pass 1)"),
                           key=lambda t, i: f"lidar-pass1-{t[0].id}")
    found = {f.id: f for f in found_list}
    if method != "rows":
        return found
    thin = [f.id for f in found_list
            if f.candidates is not None and f.count < MIN_RETURNS_PER_LINE * f.candidates.lines]
    if thin:
        # thinned or resampled clouds have no scan lines left to buffer: the grid cells stand in
        log.warning("strip %s has fewer than %d returns per scan line: the grid cells are the patches",
                    thin[0], MIN_RETURNS_PER_LINE)
        for f in found_list:
            f.candidates = None
        return found
    candidates = {f.id: f.candidates for f in found_list if f.candidates is not None}
    seeds = Seeds.of(candidates)
    tasks2 = [
        (s, project.crs, seeds, seeds.inside(candidates[s.id].bounds), options, prior, candidates[s.id].speed)
        for s in strips
    ]
    fits = run_tasks(_pass2, tasks2, workers, scheduler,
                     lambda n, t: callback(len(strips) + n, steps, f"patches of strip {t[0].id} (pass 2)"),
                     key=lambda t, i: f"lidar-pass2-{t[0].id}")
    for sid, patches in members({f.strip: f for f in fits}, seeds).items():
        found[sid].patches = patches
    return found


def seed_name(found: dict[str, StripFound]) -> Callable[[int], str]:
    """Names of row-buffer patches: ``p{strip}_{k}``, the k-th candidate of the strip that seeded it."""
    owners = [(sid, f.candidates.size) for sid, f in found.items() if f.candidates is not None]
    starts = np.cumsum([0] + [n for _, n in owners])

    def name(seed: int) -> str:
        i = int(np.searchsorted(starts, seed, "right")) - 1
        return f"p{owners[i][0]}_{seed - int(starts[i])}"

    return name
