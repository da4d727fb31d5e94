"""Apply an adjusted laser block: corrected strips, strip differences, check patches, results.json.

:func:`apply` corrects every strip's returns (streamed; written as LAS/LAZ under a temporary name
and renamed when ``out`` is given) and finds the planar cells of the corrected strips for the strip
differences. :func:`evaluate` gathers everything the report shows.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from scangeo.adjustment.keys import Boresight, LeverArm, RangeOffset, ScanIndex
from scangeo.atomic import write_text
from scangeo.lidar.adjust import LaserBlock, anchor_points, corrector, map_unit, read_cloud
from scangeo.lidar.differences import Differences, common_rows, strip_differences
from scangeo.lidar.lasio import StripCloud, write_corrected
from scangeo.lidar.patches import StripPatches, find_strip_patches
from scangeo.lsq.engine import Adjustment
from scangeo.orientation.models import Correction
from scangeo.progress import ProgressCallback, no_progress


def _options(block: LaserBlock):
    from dataclasses import replace

    unit = block_unit(block)
    o = block.options
    popt = replace(
        o.patches, size=o.patch_size / unit, max_sigma=o.max_patch_sigma / unit, max_offset=o.max_offset / unit
    )
    return popt, block.project.sensor.range_sigma_m / unit


def block_unit(block: LaserBlock) -> float:
    return 1.0 if block.mode == "trajectory" else map_unit(block.project.crs)


def apply(
    block: LaserBlock, values, out: Path | None = None, callback: ProgressCallback = no_progress
) -> dict[str, StripPatches]:
    """Correct every strip under ``values``; write them to ``out/strips`` when given; planar cells after."""
    popt, prior = _options(block)
    found = {}
    for k, strip in enumerate(block.project.strips):
        correct = corrector(block, strip.id, values)
        if out is not None:
            (out / "strips").mkdir(parents=True, exist_ok=True)
            parts: list[tuple[np.ndarray, np.ndarray]] = []

            def keep(xyz, t, correct=correct, parts=parts):
                new = correct(xyz, t)
                parts.append((new, t))
                return new

            write_corrected(
                strip.las, strip.point_source_id, out / "strips" / f"{strip.id}{strip.las[0].suffix.lower()}", keep
            )
            cloud = StripCloud(strip.id, np.concatenate([p for p, _ in parts]), np.concatenate([t for _, t in parts]))
        else:
            cloud = read_cloud(block, strip.id)
            cloud = StripCloud(strip.id, correct(cloud.xyz, cloud.time), cloud.time)
        found[strip.id] = find_strip_patches(cloud, popt, prior)
        callback(k + 1, len(block.project.strips), f"corrected strip {strip.id}")
    return found


def check_patches(block: LaserBlock, values) -> dict[str, float]:
    """Mean normal distance of the surveyed points of each check patch to each strip's plane there."""
    g = block.given
    out: dict[str, float] = {}
    if g is None:
        return out
    for sid, a in block.anchors.items():
        pts = anchor_points(block, sid, values).reshape(-1, 3, 3)
        for k, p in enumerate(a["patch"][::3]):
            if block.kinds[p] != "check":
                continue
            n = np.cross(pts[k, 1] - pts[k, 0], pts[k, 2] - pts[k, 0])
            n /= np.linalg.norm(n)
            pid = block.frames.ids[p]
            surveyed = block.to_work(g.xyz[g.point_patch == g.ids.index(pid)])
            out[f"{pid}:{sid}"] = float(np.mean((surveyed - pts[k, 0]) @ n))
    return out


def tie_discrepancies(block: LaserBlock, values) -> np.ndarray:
    """Per (tie patch, strip): the strip's anchor centroid along the patch normal minus the patch's mean."""
    parts, patches = [], []
    for sid, a in block.anchors.items():
        pts = anchor_points(block, sid, values).reshape(-1, 3, 3).mean(axis=1)
        p = a["patch"][::3]
        parts.append(np.einsum("ij,ij->i", pts - block.frames.c0[p], block.frames.n0[p]))
        patches.append(p)
    d, patch = np.concatenate(parts), np.concatenate(patches)
    tie = np.array([block.kinds[p] == "tie" for p in patch])
    d, patch = d[tie], patch[tie]
    mean = np.bincount(patch, d, len(block.kinds)) / np.maximum(np.bincount(patch, minlength=len(block.kinds)), 1)
    return d - mean[patch]


def _rms(v) -> float:
    v = np.asarray(list(v), float)
    return float(np.sqrt(np.mean(v**2))) if v.size else float("nan")


@dataclass
class Evaluation:
    before: Differences
    after: Differences
    checks_before: dict
    checks_after: dict
    ties_before: np.ndarray
    ties_after: np.ndarray
    unit: float

    def summary(self) -> dict:
        u = self.unit
        return {
            "strip_differences_rms_m": {
                "before": self.before.rms() * u,
                "after": self.after.rms() * u,
                "cells": int(self.before.dz.size),
            },
            "strip_differences_flat_rms_m": {"before": self.before.rms(True) * u, "after": self.after.rms(True) * u},
            "check_patches_rms_m": {
                "before": _rms(self.checks_before.values()) * u,
                "after": _rms(self.checks_after.values()) * u,
                "count": len(self.checks_after),
            },
            "tie_patch_discrepancies_rms_m": {"before": _rms(self.ties_before) * u, "after": _rms(self.ties_after) * u},
            "pairs_after": {
                k: {kk: (vv * u if kk != "cells" else vv) for kk, vv in v.items()}
                for k, v in self.after.per_pair().items()
            },
        }


def evaluate(block: LaserBlock, result: Adjustment, after: dict[str, StripPatches]) -> Evaluation:
    initial = block.parameters.values()
    final = result.parameters.values()
    popt = _options(block)[0]
    args = (popt.size, popt.flat_deg, popt.max_angle_deg, popt.max_offset)
    before, after_d = common_rows(
        strip_differences({s: f.cells for s, f in block.found.items()}, *args), strip_differences(after, *args)
    )
    return Evaluation(
        before,
        after_d,
        check_patches(block, initial),
        check_patches(block, final),
        tie_discrepancies(block, initial),
        tie_discrepancies(block, final),
        block_unit(block),
    )


def parameter_table(block: LaserBlock, result: Adjustment) -> list[dict]:
    """Every free correction and calibration unknown with sigma and significance (metres, degrees)."""
    st = result.statistics
    rows = []
    keys = [m.key for m in block.models] + [Boresight(), LeverArm(), RangeOffset(), ScanIndex()]
    unit = block_unit(block)
    for key in keys:
        block_p = result.parameters[key]
        if not block_p.free.any():
            continue
        for c in st.significance(key):
            angular = isinstance(key, (Boresight, ScanIndex)) or (
                isinstance(key, Correction) and c.component[:-1] in ("roll", "pitch", "heading")
            )
            f = np.degrees(1.0) if angular else (1.0 if isinstance(key, (LeverArm, RangeOffset)) else unit)
            rows.append(
                {
                    "key": key.label,
                    "component": c.component,
                    "value": c.value * f,
                    "sigma": c.sigma * f,
                    "unit": "deg" if angular else "m",
                    "t": c.t,
                    "significant": c.significant,
                }
            )
    return rows


def results_dict(block: LaserBlock, result: Adjustment, evaluation: Evaluation | None) -> dict:
    st = result.statistics
    reg = [
        {"key": r.key.label, "component": r.component, "sigma": r.sigma, "reason": r.reason}
        for r in result.solution.regularisation
    ]
    return {
        "mode": block.mode,
        "mode_description": (
            "trajectory: GPS/IMU correction polynomials, calibration, tie planes"
            if block.mode == "trajectory"
            else "points (provisional solution, no trajectory): XYZ correction polynomials in time per strip"
        ),
        "strips": {
            s: {"returns": f.count, "t_start": f.t_start, "t_end": f.t_end, "planar_cells": int(f.cells.cells.size),
                "patches": int(f.patches.cells.size)}
            for s, f in block.found.items()
        },
        "patches": {k: int(sum(1 for x in block.kinds if x == k)) for k in ("tie", "control", "check")},
        "sigma0": st.sigma0,
        "accounting": st.accounting.as_dict(),
        "converged": result.solution.converged,
        "parameters": parameter_table(block, result),
        "regularisation": reg,
        "rejections": [{"group": r.group, "patch": r.id, "w": r.w, "round": r.round} for r in result.rejections],
        "notes": block.notes,
        "evaluation": evaluation.summary() if evaluation is not None else None,
    }


def write_results(path: Path, data: dict) -> None:
    write_text(path, json.dumps(data, indent=1, default=float))


def adjust_project(
    project_path,
    out: Path | None,
    ground: Path | None = None,
    callback: ProgressCallback = no_progress,
    write_strips: bool = True,
    **overrides,
) -> dict:
    """The whole of ``scangeo lidar adjust``: set up, adjust, correct the strips, evaluate, report.

    ``ground`` defaults to the project's ``ground.csv`` when present; ``overrides`` replace
    ``[adjustment]`` options. Returns the results (also written to ``out/results.json``).
    """
    from scangeo.lidar.adjust import LaserOptions, build, run
    from scangeo.lidar.project import LaserProject
    from scangeo.lidar.report import write_difference_figure, write_difference_grid, write_html
    from scangeo.progress import scaled

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
    results = results_dict(block, result, evaluation)
    if out is not None:
        unit_name = "m" if block_unit(block) == 1.0 else "map units"
        figure = None
        if evaluation.before.dz.size:
            write_difference_grid(out / "differences.tif", evaluation.before, evaluation.after, project.crs)
            write_difference_figure(out / "differences.png", evaluation.before, evaluation.after, unit_name)
            figure = "differences.png"
        write_results(out / "results.json", results)
        write_html(out / "report.html", results, figure)
    callback(1.0, 1.0, "lidar adjust done")
    return results
