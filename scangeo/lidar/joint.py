"""The joint adjustment of a platform's laser and image strips: one block, the flight lines' corrections shared.

A laser scanner and a line scanner on one GPS/IMU (NEON's configuration) record their strips on the same
flight lines. The image block (:func:`scangeo.adjustment.block.build_block`) owns the flight lines'
orientation splines and the GPS/IMU models of the variant (``Correction(model)``, models named by the
flight line) with every line scanner's mounting and calibration; the laser's tie patches, control
patches and anchors (:func:`scangeo.lidar.adjust.build` on :func:`laser_part`) observe the same models:
a laser strip's anchors are georeferenced from the flight line's measured GPS/IMU plus the correction
functions of the flight line's models and the laser's own calibration (``Boresight(laser)``,
``LeverArm(laser)``, ``RangeOffset(laser)``, ``ScanIndex(laser)``). Both kinds of observation then
determine one set of trajectory corrections in one adjustment (:func:`adjust_joint`): a drift the laser's
patches see corrects the images, and the images' control holds the laser.

The image strips follow the flight line's spline, which the GPS/IMU observes through the corrections
(``gpsimu = s - c + v``); the laser uses the GPS/IMU plus the corrections directly (``s = gpsimu + c``):
the same trajectory to within the GPS/IMU's sigmas. The laser's patches are those of ``patches.csv``
(the laser projects' ground format, docs/formats.md), the images' points those of ground.csv.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from scangeo.adjustment.block import Block, build_block
from scangeo.adjustment.keys import Ground
from scangeo.adjustment.priors import snooping_options
from scangeo.adjustment.results import CheckResiduals, VariantResult, evaluate_checks, read_measurements
from scangeo.adjustment.variants import Variant
from scangeo.errors import LidarError
from scangeo.io.project import FlightLine, LaserSensor, Project
from scangeo.lidar.adjust import LaserBlock, build
from scangeo.lidar.evaluation import Evaluation, apply, evaluate
from scangeo.lidar.options import LaserOptions
from scangeo.lidar.patches import TiePatch
from scangeo.lidar.search import StripFound
from scangeo.lsq.engine import Adjustment, adjust
from scangeo.lsq.parameters import Parameters
from scangeo.lsq.solver import SolverOptions
from scangeo.progress import ProgressCallback, no_progress, scaled

#: the laser's control and check patches of a platform project
PATCHES_FILE = "patches.csv"


@dataclass
class JointBlock:
    """The joint problem: the image block, the laser block on the image block's GPS/IMU models, and the
    union of their unknowns (the shared correction coefficients once) and observation groups."""

    image: Block
    laser: LaserBlock
    parameters: Parameters
    groups: list


@dataclass
class JointResult:
    """A joint adjustment: the image side as a :class:`~scangeo.adjustment.results.VariantResult` (adjusted
    orientation, check residuals) and the laser side's evaluation (strip differences, check patches)."""

    block: JointBlock
    adjustment: Adjustment
    images: VariantResult
    laser: Evaluation


def laser_part(project: Project) -> Project:
    """The laser strips of a platform as a project of their own: its one laser scanner (its id kept), the
    laser strips and their flight lines (with those strips only).

    Raises
    ------
    LidarError
        No laser scanner, or more than one (not yet supported), or a laser strip on a flight line that no
        image strip shares.
    """
    lasers = [sid for sid, s in project.sensors.items() if isinstance(s, LaserSensor)]
    if len(lasers) != 1:
        raise LidarError(f"{project.file}: a joint laser and image adjustment needs one laser scanner, found "
                         f"{len(lasers)} ({', '.join(lasers) or 'none'})")
    strips = project.laser_strips
    imaged = {s.flight_line for s in project.image_strips}
    alone = [s.id for s in strips if s.flight_line not in imaged]
    if alone:
        raise LidarError(f"{project.file} strip {alone[0]}: its flight line {project.strip(alone[0]).flight_line} "
                         "has no image strip; the joint adjustment corrects the flight lines the images share")
    lines = {s.flight_line: dataclasses.replace(project.flight_lines[s.flight_line],
                                                strips=tuple(x.id for x in strips if x.flight_line == s.flight_line))
             for s in strips}
    return dataclasses.replace(project, sensors={lasers[0]: project.sensors[lasers[0]]}, strips=strips,
                               flight_lines=lines, relative_mountings=())


def _flight_line(lines: dict[str, FlightLine], strip: str) -> str:
    return next(fid for fid, f in lines.items() if strip in f.strips)


def build_joint(project: Project, variant: Variant, options: LaserOptions | None = None,
                patches: Path | None = None, found: dict[str, StripFound] | None = None,
                callback: ProgressCallback = no_progress, ties: list[TiePatch] | None = None,
                exclude: frozenset[tuple[str, str]] = frozenset()) -> JointBlock:
    """The image block of ``variant`` and the laser block on its GPS/IMU models, as one problem.

    Parameters
    ----------
    project : Project
        A platform with line scanners and one laser scanner sharing flight lines.
    variant : Variant
        The strategy of both (its models, priors, calibration unknowns, data snooping).
    options : LaserOptions, optional
        The patch search (default: the project's ``[adjustment]`` table).
    patches : Path, optional
        The laser's control and check patches (default: ``patches.csv`` of the project, if there).
    found : dict, optional
        The laser strips' patches of an earlier search (None: search now).
    callback : callable
        Progress of the patch search.
    ties : list of TiePatch, optional
        The tie patches of ``found`` (:func:`scangeo.lidar.adjust.tie_patches`; the same for every variant,
        computed once by a caller that adjusts several; None: found here).
    exclude : frozenset of (str, str)
        ``(laser strip, patch)`` observations left out (set aside by a cleaning).

    Returns
    -------
    JointBlock
        The unknowns and observation groups of both, the shared ones once.
    """
    if variant.strategy in ("BE", "ME"):
        raise LidarError(f"variant {variant.name}: the joint adjustment takes per flight line models (DG, SE, P, "
                         "S), not BE or ME")
    points, ground = read_measurements(project)
    image = build_block(project, variant, points, ground)
    view = laser_part(project)
    if options is None:
        options = LaserOptions.from_table(project.adjustment, str(project.file))
    if patches is None and (project.root / PATCHES_FILE).exists():
        patches = project.root / PATCHES_FILE
    lines = {s.id: _flight_line(view.flight_lines, s.id) for s in view.strips}
    laser = build(view, options, variant, patches, callback, found=found, exclude=exclude, ties=ties,
                  models=image.models, lines=lines)
    params = Parameters()
    for b in image.parameters:
        params.insert(b)
    for b in laser.parameters:
        if b.key not in params:  # the shared correction coefficients: the image block's, with the same priors
            params.insert(b)
    return JointBlock(image, laser, params, image.groups + laser.groups)


def adjust_joint(block: JointBlock, callback: ProgressCallback = no_progress) -> Adjustment:
    """Adjust the joint block with the variant's solver settings and data snooping."""
    v = block.image.variant
    return adjust(block.parameters, block.groups, SolverOptions(max_iterations=v.max_iterations, backend=v.backend),
                  snooping_options(v), callback, point_key=Ground)


def run_joint(project: Project | str | Path, variant: Variant, options: LaserOptions | None = None,
              found: dict[str, StripFound] | None = None, callback: ProgressCallback = no_progress,
              ties: list[TiePatch] | None = None, exclude: frozenset[tuple[str, str]] = frozenset(),
              out: Path | None = None) -> JointResult:
    """Build, adjust and evaluate the joint block of ``variant`` (:func:`build_joint`, :func:`adjust_joint`):
    the image side's check residuals and the laser strips' differences and check patches before and after;
    ``out``: the corrected laser strips written there as ``ID.laz`` (:func:`scangeo.lidar.evaluation.apply`)."""
    project = Project.from_user_input(project)
    block = build_joint(project, variant, options, found=found, callback=scaled(callback, 0.0, 0.4), ties=ties,
                        exclude=exclude)
    adjustment = adjust_joint(block, scaled(callback, 0.4, 0.7))
    images = image_side(block, adjustment)
    after = apply(block.laser, adjustment.parameters.values(), out, scaled(callback, 0.7, 1.0))
    return JointResult(block, adjustment, images, evaluate(block.laser, adjustment, after))


def image_side(block: JointBlock, adjustment: Adjustment) -> VariantResult:
    """The image side of an adjusted joint block: the adjusted orientation and the check points' residuals
    (the laser's strips are not corrected: :func:`scangeo.lidar.evaluation.apply` does that)."""
    images = VariantResult(block.image, adjustment, CheckResiduals(*(np.zeros(0),) * 5), 0.0,
                           list(block.image.notes) + list(block.laser.notes))
    images.checks = evaluate_checks(block.image, images.geometry)
    return images


__all__ = ["JointBlock", "JointResult", "PATCHES_FILE", "adjust_joint", "build_joint", "image_side", "laser_part",
           "run_joint"]
