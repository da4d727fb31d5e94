"""The stages of ``scangeo run`` on a laser project, in order: check, patches, clean, compare, apply, report.

The same machinery as the image stages (:mod:`scangeo.pipeline.stages`: a :class:`Stage` names its files,
options and the stages it reads; fingerprints, resume and the manifest are :mod:`scangeo.pipeline.run`'s):

- ``check``: project.toml, every LAS/LAZ header (checked against its file), every trajectory and ground.csv;
- ``patches``: the patch search over every strip (the laser's match), ``results/patches/found.npz``;
- ``clean``: the most flexible model with data snooping; the patch observations it rejects are set
  aside for every later adjustment (``results/cleaning/``);
- ``compare``: every variant of variants.toml (default: the paper's models per strip, per mission,
  for the block) on the same patches; the recommended one (``results/comparison.json``, ``results/NAME/``);
- ``apply``: the recommended variant's corrected strips as LAZ (``results/strips/ID.laz``) with a STAC
  Item each, the strip differences before and after (``results/differences.tif``);
- ``report``: ``results/report.html``.
"""
from __future__ import annotations

import json
import logging
from dataclasses import asdict
from pathlib import Path
from typing import Any

from scangeo.adjustment.variants import laser_variants
from scangeo.errors import InputFileError
from scangeo.io.project import Project
from scangeo.lidar.adjust import find_patches
from scangeo.lidar.control import read_patch_ground
from scangeo.lidar.evaluation import Evaluation, corrected_path
from scangeo.lidar.found_io import read_found, write_found
from scangeo.lidar.las_header import check_las_file
from scangeo.lidar.search import StripFound
from scangeo.pipeline.fingerprints import relative_name
from scangeo.pipeline.stages import Context, Stage
from scangeo.progress import ProgressCallback
from scangeo.reports.laser import DIFFERENCES, write_differences, write_laser_report
from scangeo.reports.stac import write_pointcloud_items
from scangeo.strategy.laser import (
    adjust_laser_variant,
    after_m,
    clean_laser,
    compare_laser,
    ground_file,
    laser_options,
    read_cleaning,
    write_cleaning,
    write_laser_comparison,
)

log = logging.getLogger(__name__)

FOUND = Path("results") / "patches" / "found.npz"
STRIPS = Path("results") / "strips"


def _project_files(ctx: Context) -> list[Path]:
    """project.toml, the strips' LAS/LAZ files and trajectories, ground.csv (when there is one)."""
    p = ctx.project
    files = [ctx.root / "project.toml"]
    for s in p.strips:
        files += list(s.las) + ([s.trajectory] if s.has_trajectory else [])
    return files + ([ctx.root / "ground.csv"] if (ctx.root / "ground.csv").exists() else [])


def _variants_file(ctx: Context) -> list[Path]:
    path = ctx.root / "variants.toml"
    return [path] if path.exists() else []


def _check(ctx: Context, progress: ProgressCallback) -> tuple[dict[str, Any], list[Path]]:
    p = ctx.project
    laser_options(p)  # [adjustment] checked key by key
    strips: dict[str, Any] = {}
    for k, s in enumerate(p.strips):
        progress(k, len(p.strips), f"check: strip {s.id}")
        returns = sum(check_las_file(f).point_count for f in s.las)
        if s.has_trajectory:
            p.stream(s.id)  # read, checked
        strips[s.id] = {"returns": returns, "trajectory": s.has_trajectory, "mission": s.mission}
    ground = ground_file(p)
    patches = 0
    if ground is not None:
        patches = len(read_patch_ground(ground).ids)
    laser_variants(ctx.root)  # variants.toml checked key by key
    progress(1, 1, "check: done")
    return {"crs": p.crs, "strips": strips, "ground_patches": patches}, []


def _patches(ctx: Context, progress: ProgressCallback) -> tuple[dict[str, Any], list[Path]]:
    return search_patches(ctx.root, ctx.project, ground_file(ctx.project), progress)


def search_patches(root: Path, project: Project, ground: Path | None,
                   progress: ProgressCallback) -> tuple[dict[str, Any], list[Path]]:
    """The patch search over every strip of the laser ``project`` (with the control and check patches of
    ``ground``), written to ``root/results/patches/found.npz``; the stage's summary and output."""
    found = find_patches(project, laser_options(project), ground, progress)
    path = write_found(root / FOUND, found)
    summary = {"strips": {sid: {"returns": f.count, "planar_cells": int(f.cells.cells.size),
                                "patches": int(f.patches.cells.size)} for sid, f in found.items()}}
    return summary, [path]


def _found(ctx: Context):
    return read_found(ctx.root / FOUND)


def _clean(ctx: Context, progress: ProgressCallback) -> tuple[dict[str, Any], list[Path]]:
    cleaning = clean_laser(ctx.project, _found(ctx), progress)
    outputs = write_cleaning(ctx.root, cleaning)
    return {"rejected": len(cleaning.rejected), "sigma0_before": cleaning.sigma0_before,
            "sigma0_after": cleaning.sigma0_after}, outputs


def _compare(ctx: Context, progress: ProgressCallback) -> tuple[dict[str, Any], list[Path]]:
    c = compare_laser(ctx.project, found=_found(ctx), exclude=read_cleaning(ctx.root), callback=progress)
    if c.recommended is None:
        raise InputFileError(f"{ctx.root}: no variant of {c.variants_file} could be adjusted: "
                             + "; ".join(f"{n}: {e}" for n, e in c.errors.items()))
    outputs = write_laser_comparison(ctx.root, c)
    # metres, as every JSON of scangeo (the comparison table's columns are in cm)
    variants: dict[str, dict[str, Any]] = {
        name: {"sigma0": r.sigma0, "strip_differences_flat_rms_m": after_m(r, "strip_differences_flat_rms_m"),
               "check_patches_rms_m": after_m(r, "check_patches_rms_m"), "rejected": len(r.rejections)}
        for name, r in c.results.items()}
    variants.update({n: {"error": e} for n, e in c.errors.items()})
    return {"recommended": c.recommended, "why": c.why, "variants": variants}, outputs


def _apply(ctx: Context, progress: ProgressCallback) -> tuple[dict[str, Any], list[Path]]:
    name = ctx.records["compare"]["summary"]["recommended"]
    _, variants = laser_variants(ctx.root)
    folder = ctx.root / STRIPS
    done = adjust_laser_variant(ctx.project, variants[name], _found(ctx), read_cleaning(ctx.root), folder, progress)
    return corrected_outputs(ctx.root, ctx.project, name, done.evaluation, done.block.found,
                             done.result.evaluation or {})


def corrected_outputs(root: Path, project: Project, name: str, ev: Evaluation, found: dict[str, StripFound],
                      figures: dict[str, Any]) -> tuple[dict[str, Any], list[Path]]:
    """What the apply stage writes beside the corrected strips (``results/strips/ID.laz`` of the laser
    ``project``, written by the adjustment): the strip differences before and after
    (``results/differences.tif``), a STAC Item per strip; the stage's summary (``figures``: the
    evaluation's, metres) and outputs."""
    folder = root / STRIPS
    grid = write_differences(root / DIFFERENCES, ev.before, ev.after, project.crs) if ev.before.dz.size else None
    files = [corrected_path(folder, s.id) for s in project.strips]
    spans = {sid: [f.t_start, f.t_end] for sid, f in found.items()}
    items = write_pointcloud_items(root, name, files, project.crs, spans)
    summary = {"variant": name, "folder": relative_name(folder, root),
               "strips": [relative_name(f, root) for f in files],
               "stac_items": [relative_name(p, root) for p in items],
               "strip_differences_rms_m": figures.get("strip_differences_rms_m"),
               "strip_differences_flat_rms_m": figures.get("strip_differences_flat_rms_m"),
               "check_patches_rms_m": figures.get("check_patches_rms_m")}
    return json.loads(json.dumps(summary, default=float)), [*files, *items, *([grid] if grid else [])]


def _report(ctx: Context, progress: ProgressCallback) -> tuple[dict[str, Any], list[Path]]:
    path, figures = write_laser_report(ctx.root)
    progress(1, 1, "report: done")
    return {"html": relative_name(path, ctx.root), "figures": figures}, [path]


def _no_options(ctx: Context) -> dict[str, Any]:
    return {}


def _search_options(ctx: Context) -> dict[str, Any]:
    o = asdict(laser_options(ctx.project))
    o.pop("workers"), o.pop("scheduler")  # where the search runs does not change what it finds
    return o


LASER_STAGES: tuple[Stage, ...] = (
    Stage("check", 0.02, (), _project_files, _no_options, _check,
          "project.toml, every LAS/LAZ header, trajectory and ground.csv read and checked"),
    Stage("patches", 0.45, (), _project_files, _search_options, _patches,
          "planar patches in every strip, tie patches between overlapping strips"),
    Stage("clean", 0.10, ("patches",), lambda c: _project_files(c) + _variants_file(c), _no_options, _clean,
          "blunders found by the most flexible model with data snooping, set aside for every later adjustment"),
    Stage("compare", 0.20, ("patches", "clean"), lambda c: _project_files(c) + _variants_file(c), _no_options,
          _compare, "every variant adjusted on the same patches, compared; the recommended variant"),
    Stage("apply", 0.20, ("compare",), lambda c: _project_files(c) + _variants_file(c), _no_options, _apply,
          "the recommended variant's corrected strips (LAZ) with STAC items, the strip differences"),
    Stage("report", 0.03, ("clean", "compare", "apply"), _project_files, _no_options, _report,
          "the HTML report"),
)

LASER_NAMES = tuple(s.name for s in LASER_STAGES)


__all__ = ["FOUND", "LASER_NAMES", "LASER_STAGES", "STRIPS", "corrected_outputs", "search_patches"]
