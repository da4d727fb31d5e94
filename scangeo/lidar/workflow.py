"""``scangeo lidar adjust`` as one call: :func:`adjust_laser` (set up, adjust, correct the strips,
evaluate, report), returning a :class:`~scangeo.lidar.result.LaserResult`."""

from __future__ import annotations

import json
from pathlib import Path

from scangeo.adjustment.keys import Boresight, LeverArm, ScanIndex
from scangeo.atomic import write_text
from scangeo.lidar.adjust import LaserBlock, LaserOptions, build, run
from scangeo.lidar.evaluation import Evaluation, apply, block_unit, evaluate
from scangeo.lidar.keys import Plane, RangeOffset
from scangeo.lidar.project import LaserProject
from scangeo.lidar.report import write_difference_figure, write_difference_grid, write_html
from scangeo.lidar.result import LaserResult, Regularised, Rejection, estimates, tilt_tests
from scangeo.lsq.engine import Adjustment
from scangeo.progress import ProgressCallback, no_progress, scaled


def laser_result(
    block: LaserBlock, result: Adjustment, evaluation: Evaluation | None, variant: str = ""
) -> LaserResult:
    """The typed result of an adjusted block."""
    st = result.statistics
    keys = [m.key for m in block.models] + [Boresight(), LeverArm(), RangeOffset(), ScanIndex()]
    planes = [Plane(i) for i, kind in zip(block.frames.ids, block.kinds) if kind != "check"]
    return LaserResult(
        mode=block.mode,
        mode_description=(
            "trajectory: GPS/IMU correction polynomials, calibration, tie planes"
            if block.mode == "trajectory"
            else "points (provisional solution, no trajectory): XYZ correction polynomials in time per strip"
        ),
        strips={
            s: {"returns": f.count, "t_start": f.t_start, "t_end": f.t_end, "planar_cells": int(f.cells.cells.size),
                "patches": int(f.patches.cells.size)}
            for s, f in block.found.items()
        },
        patches={k: int(sum(1 for x in block.kinds if x == k)) for k in ("tie", "control", "height", "check")},
        sigma0=st.sigma0,
        accounting=st.accounting.as_dict(),
        converged=result.solution.converged,
        estimates=estimates(result, keys, block_unit(block)),
        tilts=tilt_tests(result, planes),
        regularised=[Regularised(r.key, r.component, r.sigma, r.reason) for r in result.solution.regularisation],
        rejections=[Rejection(r.group, r.id, r.w, r.round) for r in result.rejections],
        notes=list(block.notes),
        evaluation=evaluation.summary() if evaluation is not None else None,
        variant=variant,
        options={"models": block.options.models, "position_degree": block.options.position_degree,
                 "attitude_degree": block.options.attitude_degree, "patch_search": block.options.patch_search},
    )


def write_results(path: Path, data: dict) -> None:
    write_text(path, json.dumps(data, indent=1, default=float))


def adjust_laser(
    project_path,
    out: Path | None,
    ground: Path | None = None,
    callback: ProgressCallback = no_progress,
    write_strips: bool = True,
    **overrides,
) -> LaserResult:
    """The whole of ``scangeo lidar adjust``: set up, adjust, correct the strips, evaluate, report.

    ``ground`` defaults to the project's ``ground.csv`` when present; ``overrides`` replace
    ``[adjustment]`` options (None: keep). Writes ``out/results.json`` (:meth:`LaserResult.to_dict`),
    the corrected strips, the strip differences and ``report.html`` when ``out`` is given.
    """
    project = LaserProject.load(project_path)
    options = LaserOptions.from_table(project.adjustment, str(project.root / "project.toml"), **overrides)
    if ground is None and (project.root / "ground.csv").exists():
        ground = project.root / "ground.csv"
    block = build(project, options, ground, scaled(callback, 0.0, 0.4))
    result = run(block, scaled(callback, 0.4, 0.7))
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
    after = apply(
        block,
        result.parameters.values(),
        out if (out is not None and write_strips) else None,
        scaled(callback, 0.7, 0.95),
    )
    evaluation = evaluate(block, result, after)
    typed = laser_result(block, result, evaluation)
    typed.folder = out
    if out is not None:
        results = typed.to_dict()
        unit_name = "m" if block_unit(block) == 1.0 else "map units"
        figure = None
        if evaluation.before.dz.size:
            write_difference_grid(out / "differences.tif", evaluation.before, evaluation.after, project.crs)
            write_difference_figure(out / "differences.png", evaluation.before, evaluation.after, unit_name)
            figure = "differences.png"
        write_results(out / "results.json", results)
        write_html(out / "report.html", results, figure)
    callback(1.0, 1.0, "lidar adjust done")
    return typed
