"""A platform of line scanners and a laser scanner in the comparison: every variant adjusted jointly.

On a platform whose laser strips share the flight lines of image strips (a lidar beside a
spectrometer), :func:`scangeo.strategy.comparison.compare_project` adjusts each variant with
:class:`JointRunner` instead of :func:`~scangeo.adjustment.results.run_variant`: the joint adjustment of
:mod:`scangeo.lidar.joint` (the images' tie and control points and the laser's tie and control patches
observe the same GPS/IMU corrections of the flight lines, in one adjustment). Everything the comparison
reads from a variant comes from that one solution: the image strips' check-point residuals, the
cross-validation's held-out control, the true error of a simulation, the written ``orientation.json``
(which rectify uses). A variant the joint block cannot take (BE, ME: a model across flight lines) fails
with its reason and stands in the comparison as a failed variant.

The laser strips' patches are searched once (the ``patches`` stage of ``scangeo run``) and their tie
patches found once per runner; each variant's laser side (:func:`laser_summary`: the strip differences
on flat cells before and after, per laser strip too, the check patches, the laser's mounting and
scanner calibration with their precision where the variant adjusts them) goes into its
``report.json`` as ``laser``.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from scangeo.adjustment.results import VariantResult, add_notes
from scangeo.adjustment.variants import Variant, find_variant
from scangeo.io.project import Project
from scangeo.lidar.adjust import calibration_of, find_patches, tie_patches
from scangeo.lidar.differences import Differences
from scangeo.lidar.evaluation import apply, evaluate
from scangeo.lidar.groups import laser_calibration_keys
from scangeo.lidar.joint import PATCHES_FILE, JointResult, adjust_joint, build_joint, image_side, laser_part
from scangeo.lidar.options import LaserOptions
from scangeo.lidar.patches import TiePatch
from scangeo.lidar.search import StripFound
from scangeo.progress import ProgressCallback, no_progress, scaled
from scangeo.strategy.crossvalidation import HELD_OUT


def joins_a_laser(project: Project) -> bool:
    """Whether the project's variants are adjusted jointly: laser strips and image strips on one platform.

    Parameters
    ----------
    project : Project
        Any project.

    Returns
    -------
    bool
        True when it has both laser strips and image strips.
    """
    return bool(project.laser_strips) and bool(project.image_strips)


def _num(x) -> float | None:
    return None if x is None or not math.isfinite(float(x)) else float(x)


def _rms(d: np.ndarray) -> float | None:
    return float(np.sqrt(np.mean(d ** 2))) if d.size else None


def per_strip(before: Differences, after: Differences, unit: float = 1.0) -> dict[str, dict]:
    """Per laser strip the flat cells it shares with any other strip: their count and the rms of the
    strip differences there before and after (metres; ``before`` and ``after`` row by row the same cells
    and pairs, as :func:`scangeo.lidar.differences.common_rows` gives them)."""
    out: dict[str, dict] = {}
    strips = sorted({str(s) for s in np.concatenate([before.a, before.b])}) if before.dz.size else []
    for sid in strips:
        sel = ((before.a.astype(str) == sid) | (before.b.astype(str) == sid)) & before.flat
        b, a = _rms(before.dz[sel]), _rms(after.dz[sel])
        out[sid] = {"flat_cells": int(sel.sum()), "before_m": None if b is None else b * unit,
                    "after_m": None if a is None else a * unit}
    return out


def _mounting(joint: JointResult) -> dict:
    """The laser's mounting and scanner calibration (degrees and metres), each with its 1-sigma a posteriori
    where the variant adjusts it (none: held at project.toml's values)."""
    laser = joint.block.laser
    params, stats = joint.adjustment.parameters, joint.adjustment.statistics
    cal = calibration_of(params.values(), laser.sensor)
    bore, lever, offset, index = laser_calibration_keys(laser.sensor)
    out: dict = {"boresight_deg": [float(np.degrees(v)) for v in cal.boresight],
                 "lever_arm_m": [float(v) for v in cal.lever_arm], "range_offset_m": float(cal.range_offset),
                 "scan_index_deg": float(np.degrees(cal.scan_index))}
    for key, name, scale in ((bore, "boresight_sigma_deg", math.degrees(1.0)), (lever, "lever_arm_sigma_m", 1.0),
                             (offset, "range_offset_sigma_m", 1.0), (index, "scan_index_sigma_deg", math.degrees(1.0))):
        if key in params and params[key].free.any():
            sigmas = [_num(v * scale) for v in stats.sigmas(key)]
            out[name] = sigmas if len(sigmas) > 1 else sigmas[0]
    return out


def laser_summary(joint: JointResult) -> dict:
    """The laser side of a joint adjustment, as ``report.json``'s ``laser`` (metres and degrees).

    Parameters
    ----------
    joint : JointResult
        A variant adjusted with :func:`scangeo.lidar.joint.run_joint`.

    Returns
    -------
    dict
        ``sensor`` (its id), ``mounting`` (:func:`_mounting`), ``patches`` (tie, control, check counts),
        the evaluation's figures before and after (``strip_differences_flat_rms_m``,
        ``strip_differences_rms_m``, ``check_patches_rms_m``, per check patch and strip pair) and ``strips``
        (per laser strip its flat cells and their rms before and after, :func:`per_strip`).
    """
    laser, ev = joint.block.laser, joint.laser
    kinds = list(laser.kinds)
    figures = ev.summary()
    return {"sensor": laser.sensor, "mounting": _mounting(joint),
            "patches": {k: kinds.count(k) for k in ("tie", "control", "height", "check")},
            **{k: figures[k] for k in ("strip_differences_flat_rms_m", "strip_differences_rms_m",
                                       "check_patches_rms_m", "check_patches", "pairs_after")},
            "strips": per_strip(ev.before, ev.after, ev.unit)}


@dataclass
class JointRunner:
    """Adjusts one variant of a platform with a laser jointly; called as
    :func:`~scangeo.adjustment.results.run_variant` is (:data:`scangeo.strategy.crossvalidation.VariantRunner`).

    Parameters
    ----------
    found : dict of str to StripFound
        The laser strips' patches (the ``patches`` stage's, or :func:`scangeo.lidar.adjust.find_patches` on
        :func:`scangeo.lidar.joint.laser_part`).
    exclude : frozenset of (str, str)
        ``(laser strip, patch)`` observations left out.
    options : LaserOptions, optional
        The patch settings (default: the project's ``[adjustment]``).
    """

    found: dict[str, StripFound]
    exclude: frozenset[tuple[str, str]] = frozenset()
    options: LaserOptions | None = None
    #: the tie patches of ``found`` (found at the first call: the same for every variant)
    ties: list[TiePatch] | None = None
    #: per variant name its laser side (:func:`laser_summary`; none for the cross-validation's folds)
    laser: dict[str, dict] = field(default_factory=dict)

    def __call__(self, project_root, variant: str | Variant, variants_file=None,
                 callback: ProgressCallback = no_progress) -> VariantResult:
        """The variant adjusted jointly: its image side with ``sections["laser"]`` (:func:`laser_summary`; not
        for a cross-validation's fold, named ``NAME-cv``: the laser strips are not corrected for it).

        Raises
        ------
        LidarError
            A variant with a model across flight lines (BE, ME).
        """
        t0 = time.perf_counter()
        project = Project.from_user_input(project_root)
        v = variant if isinstance(variant, Variant) else find_variant(project.root, variant, variants_file)
        if self.options is None:
            self.options = LaserOptions.from_table(project.adjustment, str(project.file))
        if v.strategy not in ("BE", "ME") and self.ties is None:  # the same tie patches for every variant
            self.ties = tie_patches(laser_part(project), self.options, self.found)
        block = build_joint(project, v, self.options, found=self.found, callback=scaled(callback, 0.0, 0.4),
                            ties=self.ties, exclude=self.exclude)
        adjustment = adjust_joint(block, scaled(callback, 0.4, 0.7))
        result = image_side(block, adjustment)
        if not v.name.endswith(HELD_OUT):  # a cross-validation fold: its held-out image points are all it gives
            after = apply(block.laser, adjustment.parameters.values(), None, scaled(callback, 0.7, 1.0))
            joint = JointResult(block, adjustment, result, evaluate(block.laser, adjustment, after))
            result.sections["laser"] = self.laser[v.name] = laser_summary(joint)
        result.seconds = time.perf_counter() - t0
        add_notes(result)
        return result


#: The variants a platform's laser adds to the diagnosis's (``scangeo run`` appends them to the variants.toml
#: it writes): the laser's patches observe the GPS/IMU along each whole flight line, to the centimetre in
#: height, and a drift inside a flight line that the images' diagnosis does not single out (no problem strip)
#: still misfits them under a constant per flight line (SE), pulling the shared corrections off.
LINE_VARIANTS = """
[variants.P1_LINES]
strategy = "P"
description = "position polynomial of degree 1 on every flight line (the laser's patches observe it); DTM heights"
position_degree = 1
dtm_heights = true
dtm_height_points = ["*"]

[variants.P2_LINES]
strategy = "P"
description = "position polynomial of degree 2 on every flight line (the laser's patches observe it); DTM heights"
position_degree = 2
dtm_heights = true
dtm_height_points = ["*"]
"""


def joint_runner(project: Project, callback: ProgressCallback = no_progress) -> JointRunner:
    """A :class:`JointRunner` on the laser strips' patches searched now (with the control and check patches
    of ``patches.csv``): for a comparison outside ``scangeo run``, which searches them once in its
    ``patches`` stage.

    Parameters
    ----------
    project : Project
        A platform with line scanners and a laser (:func:`joins_a_laser`).
    callback : callable
        Progress of the search.

    Returns
    -------
    JointRunner
        Ready to hand to :func:`scangeo.strategy.comparison.compare_project`.
    """
    options = LaserOptions.from_table(project.adjustment, str(project.file))
    patches = project.root / PATCHES_FILE
    found = find_patches(laser_part(project), options, patches if patches.exists() else None, callback)
    return JointRunner(found, options=options)


__all__ = ["LINE_VARIANTS", "JointRunner", "joins_a_laser", "joint_runner", "laser_summary", "per_strip"]
