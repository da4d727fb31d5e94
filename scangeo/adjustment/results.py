"""Run one variant on a project and describe the result: check points, rms per strip, coefficients.

``run_variant`` sets up the block (``scangeo.adjustment.block``), adjusts it with data snooping,
projects the check points into the images with the adjusted orientation (they never enter the
adjustment) and gathers everything ``report.json`` and ``residuals.csv`` hold.
"""
from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field

import numpy as np

from scangeo.adjustment.block import Block, adjust_variant
from scangeo.adjustment.image import ImageObservations
from scangeo.adjustment.keys import (
    AcrossOffset,
    AcrossScale,
    AlongOffset,
    Boresight,
    Knots,
    LeverArm,
    ScanIndex,
    ScanScale,
    TimeOffset,
    calibration_keys,
)
from scangeo.adjustment.mounting import RelativeMountingEstimate, relative_mounting
from scangeo.adjustment.variants import Variant, find_variant
from scangeo.io import rejected
from scangeo.io.points import GroundPoints, ImagePoints
from scangeo.io.project import Project, SensorConfig
from scangeo.lsq.engine import Adjustment
from scangeo.orientation.file import DIRECT, Orientation, SensorSetup, StripOrientation, map_reference
from scangeo.progress import ProgressCallback, no_progress
from scangeo.sensors.models import Pushbroom, Whiskbroom
from scangeo.sensors.strip import MULTIPLE, Mounting, StripGeometry
from scangeo.trajectory.spline import OrientationSpline

log = logging.getLogger(__name__)


@dataclass
class CheckResiduals:
    """Residuals (model - measured) of check-point measurements: lines along track, pixels across."""

    point: np.ndarray
    strip: np.ndarray
    line: np.ndarray
    pixel: np.ndarray
    status: np.ndarray
    sigma_px: np.ndarray | None = None
    #: the measured image line of every row (its place along the strip)
    at_line: np.ndarray | None = None


@dataclass
class VariantResult:
    """Everything about one adjusted variant (:func:`run_variant`).

    Parameters
    ----------
    block : Block
        The block adjusted: the project, the variant, the strips, the observation groups.
    adjustment : Adjustment
        The least-squares adjustment (:class:`scangeo.lsq.engine.Adjustment`): unknowns, statistics
        (sigma0, redundancy, accounting), solution, data snooping's rejections.
    checks : CheckResiduals
        The check points' residuals: point, strip, along track (lines), across track (pixels), status.
    seconds : float
        Wall-clock time.
    notes : list of str
        Remarks (did not converge, check points outside their strips, ...).
    sections : dict
        Further keys of ``report.json`` from observations beyond the image block's (a platform's laser
        strips adjusted with it: ``laser``); JSON-able, metres and degrees.
    """

    block: Block
    adjustment: Adjustment
    checks: CheckResiduals
    seconds: float
    notes: list[str] = field(default_factory=list)
    sections: dict = field(default_factory=dict)
    _orientation: Orientation | None = field(default=None, repr=False)

    @property
    def variant(self) -> Variant:
        """The variant adjusted.

        Returns
        -------
        Variant
            Its strategy, degrees, breaks, roles, sigmas.
        """
        return self.block.variant

    def spline(self, strip: str) -> OrientationSpline:
        """A strip's adjusted orientation spline (its flight line's).

        Parameters
        ----------
        strip : str
            The strip's id.

        Returns
        -------
        OrientationSpline
            x, y, z (metres) and roll, pitch, heading (radians) of the navigation reference point in the
            project frame, in time.
        """
        s = self.block.strips[strip]
        return s.spline.with_coef(self.adjustment.parameters[Knots(s.flight_line)].values.reshape(-1, 6))

    def mounting(self, sensor: str = "") -> Mounting:
        """A sensor's adjusted mounting.

        Parameters
        ----------
        sensor : str
            The sensor's id (``""``: the one sensor of a one-sensor project).

        Returns
        -------
        Mounting
            Lever arm (metres, body frame), boresight (radians) and time offset (seconds).
        """
        p = self.adjustment.parameters
        return Mounting(p[LeverArm(sensor)].values.copy(), p[Boresight(sensor)].values.copy(),
                        float(p[TimeOffset(sensor)].values[0]))

    def sensor_setup(self, sensor: str = "") -> SensorSetup:
        """A sensor's adjusted model (with its calibration) and mounting.

        Parameters
        ----------
        sensor : str
            The sensor's id.

        Returns
        -------
        SensorSetup
            The model with the adjusted index and scale error (whiskbroom) or offsets and scale
            (pushbroom), the mounting, and the names of what the adjustment estimated.
        """
        p = self.adjustment.parameters
        scanner = self.block.project.sensors[sensor]
        assert isinstance(scanner, SensorConfig)  # the block's sensors are line scanners (line_scanners)
        model = scanner.model
        if isinstance(model, Whiskbroom):
            model = model.with_calibration(index_error=float(p[ScanIndex(sensor)].values[0]),
                                           scale_error=float(p[ScanScale(sensor)].values[0]))
        elif isinstance(model, Pushbroom):
            model = model.with_calibration(across_offset=float(p[AcrossOffset(sensor)].values[0]),
                                           across_scale=float(p[AcrossScale(sensor)].values[0]),
                                           along_offset=float(p[AlongOffset(sensor)].values[0]))
        calibrated = tuple(name for key, name, _ in calibration_keys(sensor) if p[key].free.any())
        return SensorSetup(model, self.mounting(sensor), calibrated)

    def orientation(self) -> Orientation:
        """The adjusted orientation (what ``orientation.json`` holds; built once).

        Returns
        -------
        Orientation
            Splines, GPS/IMU corrections, every sensor's mounting and calibration, sigma0.
        """
        if self._orientation is None:
            project, p = self.block.project, self.adjustment.parameters
            sensors = {sid: self.sensor_setup(sid) for sid in project.line_scanners}
            strips = {sid: StripOrientation(sid, s.geometry.n_lines, s.geometry.timing, self.spline(sid), s.sensor,
                                            "" if s.flight_line == sid else s.flight_line)
                      for sid, s in self.block.strips.items()}
            calibrated = tuple(dict.fromkeys(n for setup in sensors.values() for n in setup.calibrated))
            models = tuple(self.block.models)
            self._orientation = Orientation(
                self.variant.name, self.variant.strategy != DIRECT, sensors, strips, map_reference(project), models,
                {m.id: p[m.key].values.copy() for m in models}, calibrated, self.adjustment.statistics.sigma0)
        return self._orientation

    def relative_mountings(self, posterior: bool = True) -> list[RelativeMountingEstimate]:
        """The adjusted relative mountings of a platform's sensors, with their precision.

        Every pair given a prior in ``[[relative_mountings]]``, and every other sensor relative to the
        first sensor; nothing for a one-sensor project.

        Parameters
        ----------
        posterior : bool
            Precision scaled by sigma0 a posteriori (False: a priori).

        Returns
        -------
        list of RelativeMountingEstimate
            The relative rotation (roll, pitch, heading, radians) and lever-arm difference (metres),
            their standard deviations, and the prior where one was given.
        """
        sensors = list(self.block.project.line_scanners)
        if len(sensors) < 2:
            return []
        priors = {(r.sensor, r.reference): r for r in self.block.project.relative_mountings
                  if r.sensor in sensors and r.reference in sensors}
        pairs = list(priors) + [(s, sensors[0]) for s in sensors[1:]
                                if (s, sensors[0]) not in priors and (sensors[0], s) not in priors]
        stats, values = self.adjustment.statistics, self.adjustment.solution.parameters.values()
        out = []
        for sensor, reference in pairs:
            keys = [Boresight(sensor), Boresight(reference), LeverArm(sensor), LeverArm(reference)]
            cov = np.zeros((12, 12))
            free = np.concatenate([self.adjustment.parameters[k].free for k in keys])
            idx = np.flatnonzero(free)
            if idx.size:
                cov[np.ix_(idx, idx)] = stats.joint_covariance(keys, posterior)
            out.append(relative_mounting(values, cov, sensor, reference, priors.get((sensor, reference))))
        return out

    def geometry(self, strip: str) -> StripGeometry:
        """A strip's adjusted geometry (``Orientation.geometry`` of :meth:`orientation`).

        Parameters
        ----------
        strip : str
            The strip's id.

        Returns
        -------
        StripGeometry
            Ground <-> image of the strip with the adjusted orientation, project frame.
        """
        return self.orientation().geometry(strip)

    def image_residuals(self, roles=("control", "height", "planimetric", "tie")):
        """The residuals of the adjusted image measurements.

        Parameters
        ----------
        roles : tuple of str
            The roles of the points whose measurements are returned.

        Returns
        -------
        tuple of 5 ndarray
            point, strip, line residual (lines), pixel residual (pixels), active (False: rejected).
        """
        sol = self.adjustment.solution
        res = self.adjustment.statistics.residuals()
        out = []
        for g, r, act in zip(sol.groups, res, sol.active):
            if isinstance(g, ImageObservations):
                v = (r * g.sigma).reshape(-1, 2)
                keep = np.array([self.block.role(p) in roles for p in g.points])
                out.append((g.points[keep], np.full(keep.sum(), g.strip, dtype=object), v[keep, 0], v[keep, 1],
                            act.reshape(-1, 2)[keep, 0]))
        if not out:
            e = np.zeros(0)
            return e.astype(object), e.astype(object), e, e, e.astype(bool)
        return tuple(np.concatenate(c) for c in zip(*out))

    def rms_per_strip(self) -> dict:
        """The residuals at control and check points, per strip.

        Returns
        -------
        dict
            Strip id -> ``control`` and ``check`` -> ``n``, ``rms_along_lines``, ``rms_across_px``.
        """
        out = {}
        pts, strips, dl, dp, act = self.image_residuals(("control", "height", "planimetric"))
        for sid in self.block.strips:
            entry = {}
            sel = (strips == sid) & act
            entry["control"] = _rms(dl[sel], dp[sel])
            c = self.checks
            ok = (c.strip == sid) & (c.status == 0)
            entry["check"] = _rms(c.line[ok], c.pixel[ok])
            out[sid] = entry
        return out


def _rms(dl: np.ndarray, dp: np.ndarray) -> dict:
    n = int(dl.size)
    if n == 0:
        return {"n": 0, "rms_along_lines": None, "rms_across_px": None}
    return {"n": n, "rms_along_lines": float(np.sqrt(np.mean(dl**2))), "rms_across_px": float(np.sqrt(np.mean(dp**2)))}


def evaluate_checks(result_block: Block, geometry_of) -> CheckResiduals:
    """Project every check point into the strips that measured it; compare with the measurements (with
    ``measurement_time = "line"``: at the measured lines, as the adjustment does)."""
    b = result_block
    given = {str(p): i for i, p in enumerate(b.ground.point)}
    pts, strips, dl, dp, st, sig, at = [], [], [], [], [], [], []
    for sid in b.strips:
        sel = [i for i, (p, s) in enumerate(zip(b.points.point, b.points.strip))
               if str(s) == sid and b.role(str(p)) == "check" and str(p) in given]
        if not sel:
            continue
        rows = np.array(sel)
        xyz = b.ground.xyz[[given[str(p)] for p in b.points.point[rows]]]
        p_P = b.project.map_frame.map_to_project(xyz[:, 0], xyz[:, 1], xyz[:, 2])
        pts.append(b.points.point[rows].astype(str))
        strips.append(np.full(rows.size, sid, dtype=object))
        if b.project.scanner_of(sid).measured_time:  # as the adjustment's image observations: at the measured line
            d_line, d_pixel = geometry_of(sid).measured_line_residuals(p_P, b.points.line[rows], b.points.pixel[rows])
            dl.append(d_line)
            dp.append(d_pixel)
            st.append(np.where(np.isfinite(d_line) & np.isfinite(d_pixel), 0, 1))
        else:
            # of a point the over-scanning mirror sees more than once, the sighting nearest the measurement
            line, pixel, status = geometry_of(sid).nearest_sighting(p_P, b.points.line[rows], b.points.pixel[rows])
            dl.append(line - b.points.line[rows])
            dp.append(pixel - b.points.pixel[rows])
            st.append(status & ~MULTIPLE)  # seen more than once is no failure: the nearest sighting is the answer
        sig.append(b.points.sigma_px[rows])
        at.append(b.points.line[rows])
    if not pts:
        e = np.zeros(0)
        return CheckResiduals(e.astype(object), e.astype(object), e, e, e.astype(int), e, e)
    return CheckResiduals(*(np.concatenate(c) for c in (pts, strips, dl, dp, st, sig, at)))


def read_measurements(project: Project, set_aside: bool = True) -> tuple[ImagePoints, GroundPoints]:
    """The project's ``points.csv`` and ``ground.csv`` (no ground points when there is no ``ground.csv``),
    without the measurements the cleaning stage set aside (``PROJECT/results/cleaning/rejected.csv``,
    :mod:`scangeo.io.rejected`) unless ``set_aside`` is False."""
    points = ImagePoints.read(project.root / "points.csv")
    ground_file = project.root / "ground.csv"
    ground = GroundPoints.read(ground_file) if ground_file.exists() else GroundPoints(
        *(np.zeros(0, dtype=object),), np.zeros((0, 3)), np.zeros(0), np.zeros(0),
        np.zeros(0, dtype=object), np.zeros(0, int))
    if set_aside:
        points, ground, _ = rejected.set_aside(project.root, points, ground)
    return points, ground


def run_variant(project_root, variant: str | Variant, variants_file=None,
                callback: ProgressCallback = no_progress) -> VariantResult:
    """Adjust one variant of the project in ``project_root`` (a folder or a loaded :class:`Project`)."""
    t0 = time.perf_counter()
    project = Project.from_user_input(project_root)
    v = variant if isinstance(variant, Variant) else find_variant(project.root, variant, variants_file)
    points, ground = read_measurements(project)
    callback(0.0, 1.0, f"{v.name}: setting up")
    block, adj = adjust_variant(project, v, points, ground, callback=callback)
    result = VariantResult(block, adj, CheckResiduals(*(np.zeros(0),) * 5), 0.0, list(block.notes))
    result.checks = evaluate_checks(block, result.geometry)
    result.seconds = time.perf_counter() - t0
    add_notes(result)
    return result


def add_notes(result: VariantResult) -> None:
    """The remarks of an adjusted variant: not converged, check points that could not be projected."""
    if not result.adjustment.solution.converged:
        result.notes.append(f"the adjustment did not converge in {result.variant.max_iterations} iterations")
    bad = int((result.checks.status != 0).sum())
    if bad:
        result.notes.append(f"{bad} check-point measurements could not be projected into their strips")


__all__ = ["CheckResiduals", "VariantResult", "add_notes", "evaluate_checks", "read_measurements", "run_variant"]
