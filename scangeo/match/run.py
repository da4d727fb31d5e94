"""Measure tie and control points of a project: :func:`match_project` (``scangeo match``).

1. Every strip's footprint; the overlap of every pair of strips, cut into cells
   (:mod:`scangeo.match.overlaps`); a strip without any overlap is reported and skipped.
2. One task per overlap (tie points; triple overlaps: the cell's further strips are matched too)
   and one per strip and reference orthoimage (control points), run in this process, in local
   processes (``workers``) or on a Dask scheduler (:mod:`scangeo.match.tasks`).
3. Outliers removed per pair of strips by local affine RANSAC (:mod:`scangeo.match.consistency`),
   which also gives the precision from the matches' consistency.
4. Ids (``<prefix>T_<a>_<b>_<n>`` ties, ``<prefix>C_<strip>_<n>`` control and check), control
   heights from the reference DTM, a share of the control held back as ``check``; the rows written
   into points.csv and ground.csv (:mod:`scangeo.match.output`) and the match report beside them.
"""
from __future__ import annotations

import logging
import math
import time
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from scangeo.atomic import write_csv
from scangeo.dtm import DTM
from scangeo.errors import GeometryError, ProjectFileError
from scangeo.io.project import Project
from scangeo.match.consistency import local_affine_inliers, precision_from_loo
from scangeo.match.options import MatchOptions
from scangeo.match.output import GROUND_COLUMNS, POINT_COLUMNS, merge_rows, write_json
from scangeo.match.overlaps import find_overlaps, strip_cells
from scangeo.match.reference import Reference
from scangeo.match.strips import MatchStrip
from scangeo.match.tasks import MatchTask, TaskResult, clear_caches, margin_cells, run_task
from scangeo.orientation.file import load_orientation
from scangeo.parallel import run_tasks
from scangeo.progress import ProgressCallback, no_progress
from scangeo.rectify.geometry import nadir_ground_pixel
from scangeo.rectify.output_grid import nice_resolution

log = logging.getLogger(__name__)

#: The match report, under PROJECT/ (``report_path``), and the two tables beside it.
REPORT = Path("results") / "match_report.json"
CELLS = "match_cells.csv"
POINTS_CSV = "match_points.csv"
#: Where scangeo match wrote its report before it went under results/ (read when the new one is absent).
EARLIER_REPORT = Path("match_report.json")


def report_path(root: Path, existing: bool = False) -> Path:
    """``PROJECT/results/match_report.json``; with ``existing``, the report an earlier match left: that
    one, or ``PROJECT/match_report.json`` where an older scangeo wrote it."""
    path = Path(root) / REPORT
    if existing and not path.exists() and (Path(root) / EARLIER_REPORT).exists():
        return Path(root) / EARLIER_REPORT
    return path


@dataclass
class MatchResult:
    """What :func:`match_project` measured and wrote.

    Parameters
    ----------
    points_file : Path
        ``PROJECT/points.csv`` (its matched rows replaced).
    ground_file : Path
        ``PROJECT/ground.csv`` (its matched control and check rows replaced).
    report_file : Path
        ``PROJECT/results/match_report.json``; ``match_cells.csv`` and ``match_points.csv`` beside it.
    report : dict
        What the report file holds: per overlap and per reference the cells, points and rejections;
        the summary.
    point_rows, ground_rows : list of dict
        The rows matched (columns of points.csv, ground.csv).
    seconds : float
        Wall-clock time of the run.
    """

    points_file: Path
    ground_file: Path
    report_file: Path
    report: dict = field(default_factory=dict)
    point_rows: list[dict] = field(default_factory=list)
    ground_rows: list[dict] = field(default_factory=list)
    seconds: float = 0.0


def _filter(result: TaskResult, master: str | None, res: float, options: MatchOptions) -> dict:
    """Drop outlier measurements in place; per target strip: counts and the consistency precision."""
    stats: dict = {}
    targets = sorted({s for p in result.points for s in p.strips if s != master})
    for t in targets:
        have = [p for p in result.points if t in p.strips]
        src = np.array([[p.x, -p.y] for p in have]) / res
        dst = np.array([[p.strips[t][0], -p.strips[t][1]] for p in have]) / res
        inlier, loo = local_affine_inliers(src, dst, options.ransac_px, options.neighbours)
        for p, ok in zip(have, inlier):
            if not ok:
                del p.strips[t]
        lsm = np.array([p.strips[t][6] for p in have if t in p.strips])
        shift = np.linalg.norm(dst - src, axis=1)
        stats[t] = {"matched": len(have), "outliers": int((~inlier).sum()),
                    "median_shift_cells": float(np.median(shift)) if shift.size else float("nan"),
                    "precision_cells": precision_from_loo(loo, options.neighbours),
                    "lsm_sigma_cells": float(np.sqrt(np.mean(lsm**2))) if lsm.size else float("nan")}
    need = 2 if master is not None else 1
    result.points = [p for p in result.points if len(p.strips) >= need]
    for p in result.points:
        p.sigma = {}
        for sid, m in p.strips.items():
            precision = stats.get(sid if sid != master else next((t for t in p.strips if t != master), sid), {})
            prec = precision.get("precision_cells", float("nan"))
            prec = prec if np.isfinite(prec) else 0.0
            # LSM's sigma sees only noise; the consistency adds what resampling and the scene's own
            # differences add; the relative error is shared by the two measurements of a pair
            p.sigma[sid] = max(options.min_sigma_px, m[4] * float(np.hypot(m[6], prec)) / np.sqrt(2.0))
    return stats


def _plan(project: Project, strips: dict[str, MatchStrip], references: list[Reference], variant: str,
          options: MatchOptions, res: float, report: dict) -> list[MatchTask]:
    margin = margin_cells(options)
    overlaps, footprint = find_overlaps(strips, res, options.per_overlap, options.per_cell, margin)
    report["footprints"] = {sid: list(b) for sid, b in footprint.items()}
    paired = {s for o in overlaps for s in (o.a, o.b)}
    report["strips_without_overlap"] = [sid for sid in strips if sid not in paired]
    for sid in report["strips_without_overlap"]:
        log.warning("strip %s overlaps no other strip: no tie points for it", sid)
    tasks = []
    for o in overlaps:
        others = tuple(sorted({s for c in o.cells for s in c.others}))
        tasks.append(MatchTask("tie", str(project.root), variant, (o.a, o.b, *others), o.cells, options, res,
                               name=o.name))
        report["overlaps"][o.name] = {"strips": [o.a, o.b], "area_km2": o.area / 1e6, "cells": len(o.cells),
                                      "triple_strips": list(others)}
    for ref in references:
        rb = ref.info.bounds
        for sid, s in strips.items():
            b = footprint[sid]
            box = (max(b[0], rb[0]), max(b[1], rb[1]), min(b[2], rb[2]), min(b[3], rb[3]))
            entry = {"reference": ref.info.path, "strip": sid, "cells": 0}
            report["control"][f"{sid}@{Path(ref.info.path).name}"] = entry
            if box[2] <= box[0] or box[3] <= box[1] or options.control_per_strip == 0:
                log.warning("reference %s does not cover strip %s: no control points there", ref.info.path, sid)
                continue
            cells = strip_cells(s, box, res, math.ceil(options.control_per_strip / options.per_cell), margin)
            entry["cells"] = len(cells)
            if cells:
                tasks.append(MatchTask("control", str(project.root), variant, (sid,), tuple(cells), options, res,
                                       reference=ref.info.path, name=f"{sid}@{Path(ref.info.path).name}"))
    return tasks


def match_project(project_path: str | Path | Project, variant: str = "DG", references: Sequence[str | Path] = (),
                  reference_dtm: str | Path | None = None, reference_dtm_sigma: float | None = None,
                  options: MatchOptions | None = None, workers: int = 1, scheduler: str | None = None,
                  write: bool = True, progress: ProgressCallback = no_progress) -> MatchResult:
    """Measure tie points (and control points against reference orthoimages) of a project.

    Parameters
    ----------
    project_path : the project folder (or its project.toml).
    variant : whose orientation predicts where to look (``DG``: the GPS/IMU as measured).
    references : reference orthoimages for control (any raster with a CRS).
    reference_dtm : heights of the control points (default: the project's DTM).
    reference_dtm_sigma : its accuracy, m (default: the project's ``dtm_sigma_m``).
    options : matching settings (default: :class:`MatchOptions`).
    workers, scheduler : local processes, or the address of a Dask scheduler, for the tasks.
    write : write points.csv, ground.csv and the report (else only return them).
    progress : ``callback(done, total, message)`` in tasks.
    """
    started = time.perf_counter()
    options = options or MatchOptions()
    project = Project.from_user_input(project_path)
    ids = [s.id for s in project.strips if s.image is not None]
    if not ids:
        raise ProjectFileError(f"{project.root / 'project.toml'}: no strip has an image to match on")
    orientation = load_orientation(project, variant)  # once: it holds every strip
    strips = {sid: MatchStrip(project, variant, sid, options, orientation=orientation) for sid in ids}
    res = options.resolution or nice_resolution(nadir_ground_pixel(strips[ids[0]].geometry))
    refs = [Reference(r, project.crs, options.reference_bands) for r in references]
    result = MatchResult(project.root / "points.csv", project.root / "ground.csv", report_path(project.root))
    report: dict = {"variant": variant, "resolution": res, "options": options.__dict__ | {},
                    "overlaps": {}, "control": {}, "references": [r.info.__dict__ for r in refs]}
    try:
        tasks = _plan(project, strips, refs, variant, options, res, report)
    finally:
        for r in refs:
            r.close()
    if not tasks:
        raise GeometryError(f"{project.root}: no strips overlap and no reference covers a strip: nothing to match "
                           f"(strips: {', '.join(ids)})")
    results = run_match_tasks(tasks, workers, scheduler, progress)
    dtm = project.dtm if reference_dtm is None else DTM.open(reference_dtm, project.map_frame)
    sigma_z = project.dtm_sigma if reference_dtm_sigma is None else reference_dtm_sigma
    ref_res = {r.info.path: r.info.resolution for r in refs}
    rng = np.random.default_rng(options.seed)
    for task, res_t in zip(tasks, results):
        if task.kind == "tie":
            _tie_rows(task, res_t, res, options, report, result)
        else:
            _control_rows(task, res_t, res, options, dtm, sigma_z, ref_res[task.reference or ""], rng, report,
                          result)
    if not refs and write:
        _keep_control(report_path(project.root, existing=True), report)
    _summary(report, result, res)
    result.seconds = time.perf_counter() - started
    report["seconds"] = round(result.seconds, 2)
    if write:
        prefixes = (options.tie_prefix, options.control_prefix) if refs else (options.tie_prefix,)
        merge_rows(result.points_file, POINT_COLUMNS, prefixes, result.point_rows)
        if result.ground_rows or result.ground_file.exists():
            merge_rows(result.ground_file, GROUND_COLUMNS, prefixes, result.ground_rows)
        result.report_file.parent.mkdir(parents=True, exist_ok=True)
        write_json(result.report_file, report)
        _write_cells(result.report_file.with_name(CELLS), report)
    result.report = report
    return result


def _keep_control(path: Path, report: dict) -> None:
    """A run without a reference keeps the control rows: keep their part of the earlier report too."""
    import json

    try:
        old = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return
    report["control"] = old.get("control", {})
    report["references"] = old.get("references", [])
    kept = [p for p in old.get("positions", []) if p[2] in ("control", "check")]
    report.setdefault("_positions", []).extend(kept)


def _counts(res_t: TaskResult) -> dict:
    return {"cells": res_t.cells, "cells_without_points": res_t.cells_without_points,
            "candidates": res_t.candidates, "rejected": dict(res_t.rejected)}


def _tie_rows(task: MatchTask, res_t: TaskResult, res: float, options: MatchOptions, report: dict,
              result: MatchResult) -> None:
    a, b = task.strips[0], task.strips[1]
    stats = _filter(res_t, a, res, options)
    entry = report["overlaps"][task.name]
    entry.update(_counts(res_t))
    entry["consistency"] = stats
    per_cell = Counter(p.cell for p in res_t.points)
    entry["points"] = len(res_t.points)
    entry["points_per_cell"] = [per_cell.get(c.index, 0) for c in task.cells]
    entry["cell_centres"] = [[0.5 * (c.xmin + c.xmax), 0.5 * (c.ymin + c.ymax)] for c in task.cells]
    entry["triples"] = sum(len(p.strips) > 2 for p in res_t.points)
    if not res_t.points:
        log.warning("overlap %s: no tie point (%d candidates: %s)", task.name, res_t.candidates,
                    ", ".join(f"{k} {v}" for k, v in res_t.rejected.items()) or "no texture")
    for n, p in enumerate(res_t.points, start=1):
        pid = f"{options.tie_prefix}{a}_{b}_{n:04d}"
        for sid, m in p.strips.items():
            result.point_rows.append(_point_row(pid, sid, m, p.sigma[sid]))
        report.setdefault("_positions", []).append([p.x, p.y, "tie", len(p.strips), pid])


def _point_row(pid: str, sid: str, m, sigma: float) -> dict:
    return {"point": pid, "strip": sid, "line": f"{m[2]:.4f}", "pixel": f"{m[3]:.4f}", "sigma_px": f"{sigma:.3g}"}


def _control_rows(task: MatchTask, res_t: TaskResult, res: float, options: MatchOptions, dtm: DTM,
                  sigma_z: float, ref_res: float, rng: np.random.Generator, report: dict,
                  result: MatchResult) -> None:
    sid = task.strips[0]
    stats = _filter(res_t, None, res, options)
    entry = report["control"][task.name]
    entry.update(_counts(res_t))
    entry["consistency"] = stats
    xs = np.array([p.x for p in res_t.points])
    ys = np.array([p.y for p in res_t.points])
    z = np.asarray(dtm.height_at_map(xs, ys), float) if len(xs) else np.empty(0)
    keep = np.isfinite(z)
    if (~keep).any():
        entry["rejected"]["no reference DTM height"] = int((~keep).sum())
    points = [p for p, k in zip(res_t.points, keep) if k]
    z = z[keep]
    n_check = int(round(options.check_share * len(points)))
    check = set(rng.choice(len(points), n_check, replace=False).tolist()) if n_check else set()
    sigma_xy = max(0.3 * ref_res, 0.01)
    entry["points"] = len(points)
    entry["check"] = n_check
    for n, p in enumerate(points):
        pid = f"{options.control_prefix}{sid}_{Path(task.reference or '').stem}_{n + 1:04d}"
        role = "check" if n in check else "control"
        result.ground_rows.append({"point": pid, "x": f"{p.x:.4f}", "y": f"{p.y:.4f}", "z": f"{z[n]:.4f}",
                                   "sigma_xy": f"{sigma_xy:.3g}", "sigma_z": f"{sigma_z:.3g}", "role": role})
        result.point_rows.append(_point_row(pid, sid, p.strips[sid], p.sigma[sid]))
        report.setdefault("_positions", []).append([p.x, p.y, role, 1, pid])


def _summary(report: dict, result: MatchResult, res: float) -> None:
    ties = [o for o in report["overlaps"].values() if "points" in o]
    rejected = sum(sum(o["rejected"].values()) for o in [*ties, *report["control"].values()] if "rejected" in o)
    candidates = sum(o.get("candidates", 0) for o in [*ties, *report["control"].values()])
    outliers = sum(s["outliers"] for o in [*ties, *report["control"].values()]
                   for s in o.get("consistency", {}).values())
    precision = [s["precision_cells"] for o in ties for s in o.get("consistency", {}).values()
                 if np.isfinite(s["precision_cells"])]
    report["summary"] = {
        "tie_points": sum(o["points"] for o in ties),
        "control_points": sum(o.get("points", 0) - o.get("check", 0) for o in report["control"].values()),
        "check_points": sum(o.get("check", 0) for o in report["control"].values()),
        "measurements": len(result.point_rows),
        "candidates": candidates,
        "rejected_share": (rejected + outliers) / candidates if candidates else 0.0,
        "outliers": outliers,
        "tie_precision_cells": float(np.sqrt(np.mean(np.square(precision)))) if precision else None,
    }
    report["positions"] = report.pop("_positions", [])


def _write_cells(path: Path, report: dict) -> None:
    rows = []
    for name, o in report["overlaps"].items():
        for (x, y), n in zip(o.get("cell_centres", []), o.get("points_per_cell", [])):
            rows.append([name, f"{x:.1f}", f"{y:.1f}", n])
    write_csv(path, ["overlap", "x", "y", "points"], rows)
    write_csv(path.with_name(POINTS_CSV), ["point", "kind", "x", "y", "strips"],
              ([p[4], p[2], f"{p[0]:.3f}", f"{p[1]:.3f}", p[3]] for p in report["positions"]))


def run_match_tasks(tasks: list[MatchTask], workers: int, scheduler: str | None, progress: ProgressCallback
                    ) -> list[TaskResult]:
    """Run tasks in this process, a process pool or on a Dask scheduler (:mod:`scangeo.parallel`);
    results in task order."""
    clear_caches()  # files may have changed since an earlier run in this process
    total = len(tasks)
    progress(0, total, "match")
    return run_tasks(run_task, tasks, workers=workers, scheduler=scheduler,
                     on_done=lambda n, t: progress(n, total, f"match {t.name}"),
                     key=lambda t, i: f"match-{t.kind}-{t.name}-{i}")
