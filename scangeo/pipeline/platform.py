"""The stages of ``scangeo run`` on a platform of line scanners and a laser scanner sharing flight lines.

The image stages (:mod:`scangeo.pipeline.stages`) with the laser's joined in, in order: check, match,
patches, clean, diagnose, compare, rectify, apply, report.

- ``check``: the image inputs as for an image project, and every laser strip's LAS/LAZ header;
- ``patches``: the laser strips' patch search (with the control and check patches of ``patches.csv``),
  once per run, ``results/patches/found.npz`` (:func:`scangeo.pipeline.laser.search_patches`);
- ``clean``, ``diagnose``: on the image points, as for an image project; a variants.toml the run writes
  gets two variants more (:data:`scangeo.strategy.platform.LINE_VARIANTS`: a position polynomial of degree
  1 and 2 on every flight line, which the laser's patches observe along the whole line);
- ``compare``: every variant adjusted **jointly** (:class:`scangeo.strategy.platform.JointRunner`): the
  images' tie and control points and the laser's tie and control patches on the same GPS/IMU corrections
  of the flight lines; the cross-validation, the recommendation, every variant's ``orientation.json`` and
  check-point residuals come from the joint solution, each variant's laser side goes into its
  ``report.json`` (``laser``). A variant the joint block cannot take (BE, ME) is a failed variant, its
  reason in the comparison;
- ``rectify``: the recommended variant's orthoimages (from its joint ``orientation.json``);
- ``apply``: the recommended variant adjusted jointly again, its corrected laser strips written as a laser
  project's apply stage writes them (``results/strips/ID.laz`` with STAC Items, ``results/differences.tif``);
- ``report``: ``results/report.html``, with the laser section of the recommended variant.
"""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

from scangeo.adjustment.variants import read_variants
from scangeo.atomic import write_text
from scangeo.errors import ProjectFileError
from scangeo.lidar.found_io import read_found
from scangeo.lidar.joint import PATCHES_FILE, laser_part, run_joint
from scangeo.lidar.las_header import check_las_file
from scangeo.pipeline.fingerprints import file_stamps
from scangeo.pipeline.laser import FOUND, LASER_STAGES, STRIPS, corrected_outputs, search_patches
from scangeo.pipeline.stages import Context, Stage, compare_variants, no_points, stage
from scangeo.progress import ProgressCallback, scaled
from scangeo.strategy.laser import laser_options
from scangeo.strategy.platform import LINE_VARIANTS, JointRunner
from scangeo.textfile import read_text


def _patches_file(ctx: Context) -> Path | None:
    path = ctx.root / PATCHES_FILE
    return path if path.exists() else None


def _laser_files(ctx: Context) -> list[Path]:
    """The laser strips' LAS/LAZ files and the control and check patches (patches.csv, when there)."""
    files = [Path(f) for s in ctx.project.laser_strips for f in s.las]
    return files + ([p] if (p := _patches_file(ctx)) else [])


def _check(ctx: Context, progress: ProgressCallback) -> tuple[dict[str, Any], list[Path]]:
    summary, outputs = stage("check").work(ctx, scaled(progress, 0.0, 0.8))
    laser_options(ctx.project)  # [adjustment] checked key by key
    strips = ctx.project.laser_strips
    returns = {}
    for k, s in enumerate(strips):
        progress(0.8 + 0.2 * k / len(strips), 1.0, f"check: laser strip {s.id}")
        returns[s.id] = sum(check_las_file(f).point_count for f in s.las)
    summary["laser_strips"] = returns
    progress(1, 1, "check: done")
    return summary, outputs


def _patches(ctx: Context, progress: ProgressCallback) -> tuple[dict[str, Any], list[Path]]:
    return search_patches(ctx.root, laser_part(ctx.project), _patches_file(ctx), progress)


def _diagnose(ctx: Context, progress: ProgressCallback) -> tuple[dict[str, Any], list[Path]]:
    """The image diagnosis; a variants.toml it writes gets the laser's variants too (``LINE_VARIANTS``)."""
    summary, outputs = stage("diagnose").work(ctx, progress)
    path = ctx.root / "variants.toml"
    if summary["variants"] == "written from the diagnosis":
        write_text(path, read_text(path, "a TOML file", ProjectFileError) + LINE_VARIANTS)
        summary["variants"] += ", with P1_LINES and P2_LINES (a position polynomial on every flight line)"
        summary["variants_sha256"] = file_stamps([path], ctx.root)["variants.toml"]["sha256"]
    return summary, outputs


def _compare(ctx: Context, progress: ProgressCallback) -> tuple[dict[str, Any], list[Path]]:
    runner = JointRunner(read_found(ctx.root / FOUND))
    summary, outputs = compare_variants(ctx, progress, runner)
    for name, figures in summary["variants"].items():
        laser = runner.laser.get(name)
        if laser is not None:
            figures["laser"] = {k: laser[k] for k in ("strip_differences_flat_rms_m", "check_patches_rms_m")}
    summary["joint"] = "every variant adjusted with the laser strips' patches (scangeo.lidar.joint)"
    return summary, outputs


def _apply(ctx: Context, progress: ProgressCallback) -> tuple[dict[str, Any], list[Path]]:
    name = ctx.records["compare"]["summary"]["recommended"]
    variant = read_variants(ctx.root / "variants.toml")[name]
    found = read_found(ctx.root / FOUND)
    joint = run_joint(ctx.project, variant, laser_options(ctx.project), found, progress, out=ctx.root / STRIPS)
    return corrected_outputs(ctx.root, joint.block.laser.project, name, joint.laser, joint.block.laser.found,
                             joint.laser.summary())


def _search_options(ctx: Context) -> dict[str, Any]:
    """The laser project's patch-search options (where the search runs does not change what it finds)."""
    return next(s for s in LASER_STAGES if s.name == "patches").options(ctx)


def _joined(base: Stage, **changes) -> Stage:
    """An image stage with the laser's files added to its inputs (and ``changes``)."""
    files = base.files
    return replace(base, files=lambda c: files(c) + _laser_files(c), **changes)


PLATFORM_STAGES: tuple[Stage, ...] = (
    _joined(stage("check"), work=_check,
            doc="every input file read and checked, as scangeo info, and every laser strip's LAS/LAZ header"),
    stage("match"),
    Stage("patches", 0.20, (), lambda c: c.base_files() + _laser_files(c), _search_options, _patches,
          "planar patches in every laser strip, tie patches between overlapping strips"),
    stage("clean"),
    replace(stage("diagnose"), work=_diagnose,
            doc="problem strips and breaks from an SE adjustment of the cleaned image measurements; variants.toml "
                "with the laser's P1_LINES and P2_LINES"),
    _joined(stage("compare"), after=("patches", "clean", "diagnose"), work=_compare,
            doc="every variant adjusted jointly with the laser's patches, compared, cross-validated; the "
                "recommended variant"),
    stage("rectify"),
    Stage("apply", 0.10, ("patches", "compare"), lambda c: c.base_files() + _laser_files(c)
          + [c.root / "variants.toml"], lambda c: {}, _apply,
          "the recommended variant's corrected laser strips (LAZ) with STAC items, the strip differences",
          no_points),
    _joined(stage("report"), after=("clean", "diagnose", "compare", "rectify", "apply")),
)

PLATFORM_NAMES = tuple(s.name for s in PLATFORM_STAGES)

__all__ = ["PLATFORM_NAMES", "PLATFORM_STAGES"]
