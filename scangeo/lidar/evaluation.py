"""Apply an adjusted laser block: corrected strips, strip differences, check patches, tie discrepancies.

:func:`apply` corrects every strip's returns (streamed chunk by chunk; written as LAS/LAZ through
``scangeo.atomic`` when ``out`` is given) and finds the planar cells of the corrected strips for the
strip differences from the same chunks (memory: a chunk and the open cells, not the strip).
:func:`evaluate` gathers everything the report shows.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from scangeo.lidar.adjust import LaserBlock, anchor_points, corrector, map_unit
from scangeo.lidar.cells import GridCellStream
from scangeo.lidar.differences import Differences, common_rows, strip_differences
from scangeo.lidar.keys import Plane
from scangeo.lidar.lasio import iter_returns, write_corrected
from scangeo.lidar.patches import StripPatches
from scangeo.lidar.planes import ANCHORS
from scangeo.lsq.engine import Adjustment
from scangeo.progress import ProgressCallback, no_progress


def _options(block: LaserBlock):
    unit = block_unit(block)
    o = block.options
    popt = replace(
        o.patches, size=o.patch_size / unit, max_sigma=o.max_patch_sigma / unit, max_offset=o.max_offset / unit
    )
    return popt, block.project.laser.range_sigma_m / unit


def corrected_path(folder: Path, strip_id: str) -> Path:
    """The corrected strip's file: ``FOLDER/ID.laz``."""
    return Path(folder) / f"{strip_id}.laz"


def block_unit(block: LaserBlock) -> float:
    return 1.0 if block.mode == "trajectory" else map_unit(block.project.crs)


def apply(
    block: LaserBlock, values, out: Path | None = None, callback: ProgressCallback = no_progress
) -> dict[str, StripPatches]:
    """Correct every strip under ``values``, streamed chunk by chunk (written to ``out/ID.laz`` when
    given); the planar grid cells of the corrected strips (:class:`~scangeo.lidar.cells.GridCellStream`)."""
    popt, prior = _options(block)
    found = {}
    for k, strip in enumerate(block.project.strips):
        correct = corrector(block, strip.id, values)
        grid = GridCellStream(strip.id, popt, prior)
        if out is not None:
            out.mkdir(parents=True, exist_ok=True)

            def keep(xyz, t, correct=correct, grid=grid):
                new = correct(xyz, t)
                grid.feed(new, t)
                return new

            write_corrected(strip.las, strip.point_source_id, corrected_path(out, strip.id), keep)
        else:
            for xyz, t, _ in iter_returns(strip.las, strip.point_source_id, block.project.crs):
                grid.feed(correct(xyz, t), t)
        found[strip.id] = grid.finish()
        callback(k + 1, len(block.project.strips), f"corrected strip {strip.id}")
    return found


def check_patches(block: LaserBlock, values) -> dict[str, float]:
    """Mean normal distance of the surveyed points of each check patch to each strip's plane there."""
    g = block.given
    out: dict[str, float] = {}
    if g is None:
        return out
    for sid, a in block.anchors.items():
        pts = anchor_points(block, sid, values).reshape(-1, ANCHORS, 3)
        for k, p in enumerate(a["patch"][::ANCHORS]):
            if block.kinds[p] != "check":
                continue
            n = np.cross(pts[k, 0] - pts[k, 1], pts[k, 2] - pts[k, 3])
            n /= np.linalg.norm(n)
            pid = block.frames.ids[p]
            surveyed = block.to_work(g.xyz[g.point_patch == g.ids.index(pid)])
            out[f"{pid}:{sid}"] = float(np.mean((surveyed - pts[k, 0]) @ n))
    return out


def tie_discrepancies(block: LaserBlock, values) -> np.ndarray:
    """Per (tie patch, strip): the strip's anchor centroid along the patch normal minus the patch's mean."""
    parts, patches = [], []
    for sid, a in block.anchors.items():
        pts = anchor_points(block, sid, values).reshape(-1, ANCHORS, 3).mean(axis=1)
        p = a["patch"][::ANCHORS]
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
    points_before: dict = field(default_factory=dict)
    points_after: dict = field(default_factory=dict)

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
            "control_check_points_rms_m": {
                "before": _rms(self.points_before.values()) * u,
                "after": _rms(self.points_after.values()) * u,
                "count": len(self.points_after),
            },
            "check_patches": {k: [v * u, self.checks_after[k] * u] for k, v in self.checks_before.items()},
            "control_check_points": {k: [v * u, self.points_after[k] * u] for k, v in self.points_before.items()},
            "pairs_after": {
                k: {kk: (vv * u if kk != "cells" else vv) for kk, vv in v.items()}
                for k, v in self.after.per_pair().items()
            },
        }


def _difference_args(block: LaserBlock) -> tuple[float, float, float, float]:
    popt = _options(block)[0]
    return popt.size, popt.flat_deg, popt.max_angle_deg, popt.max_offset


def differences_before(block: LaserBlock) -> Differences:
    """The strip differences of the block's strips as found (before any correction): the same for every
    variant set up on the same patches with the same settings."""
    return strip_differences({s: f.cells for s, f in block.found.items()}, *_difference_args(block))


def evaluate(block: LaserBlock, result: Adjustment, after: dict[str, StripPatches],
             before: Differences | None = None) -> Evaluation:
    """The figures of the adjusted block; ``before``: :func:`differences_before` of a block on the same
    patches and settings (None: computed here)."""
    initial = block.parameters.values()
    final = result.parameters.values()
    before_d, after_d = common_rows(before if before is not None else differences_before(block),
                                    strip_differences(after, *_difference_args(block)))
    return Evaluation(
        before_d,
        after_d,
        check_patches(block, initial),
        check_patches(block, final),
        tie_discrepancies(block, initial),
        tie_discrepancies(block, final),
        block_unit(block),
        control_check_points(block, initial),
        control_check_points(block, final),
    )


def control_check_points(block: LaserBlock, values) -> dict[str, float]:
    """The check points of control and height patches (the paper's fourth roof point): their normal
    (height patches: vertical) distance from the adjusted plane of their patch."""
    g = block.given
    if g is None:
        return {}
    ids = block.frames.ids
    sel = [i for i in range(g.point_ids.size)
           if g.point_role[i] == "check" and g.role[g.point_patch[i]] != "check" and g.ids[g.point_patch[i]] in ids]
    if not sel:
        return {}
    patch = np.array([ids.index(g.ids[g.point_patch[i]]) for i in sel])
    uvd = np.array([np.asarray(values[Plane(ids[p])], float) for p in patch])
    f, n, _ = block.frames.distance(patch, block.to_work(g.xyz[sel]), uvd)
    vertical = np.array([g.role[g.point_patch[i]] == "height" for i in sel])
    f = np.where(vertical, f / n[:, 2], f)
    return {str(g.point_ids[i]): float(v) for i, v in zip(sel, f)}
