"""Set up the adjustment of a project for one variant: unknowns, GPS/IMU models, observation groups;
and adjust it (:func:`adjust_variant`: build, then :func:`adjust_block` with the variant's settings).

Unknowns: ``Knots(flight_line)`` (the orientation spline of the navigation reference point over a
flight line, fitted to its GPS/IMU as start values; fixed in DG), ``Correction(model)`` per GPS/IMU
model (models belong to flight lines), ``Ground(point)`` for every control, height, planimetric and
tie point measured in the images, and per sensor the calibration blocks (fixed unless the variant
calibrates them). Observations: GPS/IMU of every flight line at its knot epochs, image measurements
(not of check points) of every strip through its flight line's spline and its sensor's mounting,
control coordinates, DTM heights at tie points, and the priors on relative mountings.

A one-sensor project whose strips each have their own trajectory is one sensor (id ``""``) with one
flight line per strip: its unknowns and observations are exactly those of a strip-by-strip block.
"""
from __future__ import annotations

import logging
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.stats

from scangeo.adjustment.calibration import block_calibration, describe_change
from scangeo.adjustment.gpsimu import GpsImuSamples
from scangeo.adjustment.ground import DtmHeights, GroundControl
from scangeo.adjustment.image import ImageObservations
from scangeo.adjustment.keys import (
    AcrossOffset,
    AcrossScale,
    AlongOffset,
    Boresight,
    Ground,
    Knots,
    LeverArm,
    ScanIndex,
    ScanScale,
    TimeOffset,
)
from scangeo.adjustment.mounting import RelativeMountingPrior
from scangeo.adjustment.priors import (
    ANGLE_REGULARISATION_RAD,
    LEVER_ARM_REGULARISATION_M,
    SCALE_REGULARISATION,
    TIME_OFFSET_REGULARISATION_S,
    add_calibration,
    correction_sigmas,
    snooping_options,
)
from scangeo.adjustment.variants import (
    IMAGE_CALIBRATION,
    PUSHBROOM_CALIBRATION,
    WHISKBROOM_CALIBRATION,
    StripModels,
    Variant,
)
from scangeo.errors import AdjustmentError
from scangeo.filecache import FileCache
from scangeo.io.point_checks import check_points
from scangeo.io.points import GroundPoints, ImagePoints
from scangeo.io.project import Project
from scangeo.lsq.engine import Adjustment, adjust
from scangeo.lsq.keys import Key
from scangeo.lsq.observations import ObservationGroup
from scangeo.lsq.parameters import Parameters
from scangeo.lsq.solver import SolverOptions
from scangeo.orientation.models import GpsImuModel, ModelSet, group_model, strip_models
from scangeo.progress import ProgressCallback, no_progress
from scangeo.sensors.models import Pushbroom, Whiskbroom
from scangeo.sensors.strip import StripGeometry
from scangeo.trajectory.spline import COMPONENTS, OrientationSpline
from scangeo.trajectory.stream import ProjectTrajectory

log = logging.getLogger(__name__)

#: Roles whose points are unknowns with observed coordinates: (x, y, z) observed.
CONTROL_COMPONENTS = {"control": (True, True, True), "planimetric": (True, True, False), "height": (False, False, True)}


@dataclass
class FlightLineData:
    """One flight line: its GPS/IMU in P, start spline, GPS/IMU epochs and values, and its image strips."""

    id: str
    trajectory: ProjectTrajectory
    spline: OrientationSpline
    epochs: np.ndarray
    gpsimu: np.ndarray
    strips: tuple[str, ...] = ()


@dataclass
class StripData:
    """One image strip: its flight line (whose spline it follows), its sensor, and its
    direct-georeferencing geometry."""

    id: str
    line: FlightLineData
    geometry: StripGeometry
    sensor: str = ""

    @property
    def flight_line(self) -> str:
        """The id of the strip's flight line."""
        return self.line.id

    @property
    def trajectory(self) -> ProjectTrajectory:
        """The flight line's GPS/IMU in P."""
        return self.line.trajectory

    @property
    def spline(self) -> OrientationSpline:
        """The flight line's start spline."""
        return self.line.spline

    @property
    def epochs(self) -> np.ndarray:
        """The flight line's GPS/IMU epochs (s)."""
        return self.line.epochs

    @property
    def gpsimu(self) -> np.ndarray:
        """The flight line's GPS/IMU at its epochs (m, rad; project frame)."""
        return self.line.gpsimu


@dataclass
class Block:
    """The adjustment problem of one variant."""

    project: Project
    variant: Variant
    strips: dict[str, StripData]
    models: ModelSet
    parameters: Parameters
    groups: list[ObservationGroup]
    points: ImagePoints
    ground: GroundPoints
    roles: dict[str, str]
    notes: list[str] = field(default_factory=list)
    #: the flight lines of the image strips, by id
    flight_lines: dict[str, FlightLineData] = field(default_factory=dict)
    #: the t-tests of ``test_calibration`` (:func:`test_calibration`): unknown, component, t, critical,
    #: value, sigma, start, kept (SI units)
    calibration_tests: list[dict] = field(default_factory=list)
    #: the calibration unknowns' values before the adjustment (project.toml's), by key
    calibration_start: dict[Key, np.ndarray] = field(default_factory=dict)

    def role(self, point: str) -> str:
        return self.roles.get(point, "tie")


def gpsimu_epochs(spline: OrientationSpline, t_first: float, t_last: float) -> np.ndarray:
    """Epochs at which the GPS/IMU observes the spline: the knot epochs inside the data, the data's
    end, and the midpoints of the first and last segments. A cubic B-spline with K coefficients has
    K - 2 knot epochs; the two midpoints are its end conditions, so GPS/IMU alone determine it."""
    knots = spline.t0 + np.arange(spline.n_coef - 2) * spline.spacing
    knots = knots[(knots >= t_first) & (knots <= t_last)]
    ends = [t_last, spline.t0 + 0.5 * spline.spacing, spline.t_end - 0.5 * spline.spacing]
    out = np.unique(np.concatenate([knots, np.clip(ends, t_first, t_last)]))
    return out


#: the flight lines' trajectories read and fitted, while :func:`strips_read_once` is active; a block of 96
#: strips of 7,000 lines holds about 200 MB
_TRAJECTORIES: FileCache[tuple[ProjectTrajectory, OrientationSpline, np.ndarray, np.ndarray]] = FileCache(
    "flight line trajectories", 512)
_ACTIVE = 0


@contextmanager
def strips_read_once() -> Iterator[None]:
    """Within it, :func:`flight_line_data` reads, checks and fits each flight line's trajectory once (while
    the project file, the DTM (the map frame may come from it), the trajectory and the line times are
    unchanged: :mod:`scangeo.filecache`): for the many adjustments of one diagnosis or comparison, which
    otherwise read every trajectory again for each. Each :class:`FlightLineData` still gets its own
    copies. The trajectories are kept until the outermost ``with`` ends (about 2 MB a flight line of
    7,000 lines, 512 at most)."""
    global _ACTIVE
    _ACTIVE += 1
    try:
        yield
    finally:
        _ACTIVE -= 1
        if _ACTIVE == 0:
            _TRAJECTORIES.clear()


def _read_flight_line(project: Project, flight_line: str
                      ) -> tuple[ProjectTrajectory, OrientationSpline, np.ndarray, np.ndarray]:
    """A flight line's trajectory in the project frame, its orientation spline, GPS/IMU epochs and values."""
    traj = project.flight_line_stream(flight_line).to_project(project.map_frame.frame)
    spline = OrientationSpline.from_trajectory(traj, project.knot_spacing)
    epochs = gpsimu_epochs(spline, traj.time[0], traj.time[-1])
    values = np.column_stack([np.interp(epochs, traj.time, traj.p_P[:, k]) for k in range(3)]
                             + [np.interp(epochs, traj.time, traj.angles_P[:, k]) for k in range(3)])
    return traj, spline, epochs, values


def flight_line_data(project: Project, flight_line: str, strips: tuple[str, ...] = ()) -> FlightLineData:
    """A flight line's GPS/IMU and start spline (read once within :func:`strips_read_once`); ``strips``:
    its image strips in the block."""
    if not _ACTIVE:
        return FlightLineData(flight_line, *_read_flight_line(project, flight_line), strips)
    line = project.flight_lines[flight_line]
    files = [project.root / "project.toml", project.dtm_path, line.trajectory,
             *(project.strip(sid).line_times for sid in line.strips)]
    traj, spline, epochs, values = _TRAJECTORIES.get((str(project.root), flight_line), files,
                                                     lambda: _read_flight_line(project, flight_line))
    traj = replace(traj, time=traj.time.copy(), p_P=traj.p_P.copy(), angles_P=traj.angles_P.copy())
    return FlightLineData(flight_line, traj, spline.with_coef(spline.coef.copy()), epochs.copy(), values.copy(),
                          strips)


def block_strips(project: Project) -> tuple[dict[str, FlightLineData], dict[str, StripData]]:
    """The flight lines of the project's image strips and the strips on them (in the file's order)."""
    images = project.image_strips
    lines: dict[str, FlightLineData] = {}
    for s in images:
        if s.flight_line not in lines:
            on = tuple(x.id for x in images if x.flight_line == s.flight_line)
            lines[s.flight_line] = flight_line_data(project, s.flight_line, on)
    strips = {s.id: StripData(s.id, lines[s.flight_line],
                              project.geometry(s.id, spline=lines[s.flight_line].spline), s.sensor)
              for s in images}
    return lines, strips


def strip_data(project: Project, strip_id: str) -> StripData:
    """One image strip with its flight line (:func:`flight_line_data`)."""
    s = project.strip(strip_id)
    line = flight_line_data(project, s.flight_line, (strip_id,))
    return StripData(strip_id, line, project.geometry(strip_id, spline=line.spline), s.sensor)


def _line_overrides(project: Project, variant: Variant, flight_line: str) -> tuple[StripModels, list[float]]:
    """A variant's per-strip overrides of a flight line's models: the entry naming the flight line, or one of
    its strips (``breaks_lines`` are that strip's lines), merged; and the breaks as times (s)."""
    names = (flight_line, *(sid for sid in project.flight_lines[flight_line].strips if sid != flight_line))
    found = [m for m in variant.strips if m.strip in names]
    cfg = found[0] if found else StripModels(flight_line)
    for other in found[1:]:
        for key in ("position_degree", "attitude_degree", "rotation"):
            a, b = getattr(cfg, key), getattr(other, key)
            if a is not None and b is not None and a != b:
                raise AdjustmentError(f"variant {variant.name}: strips {cfg.strip} and {other.strip} of flight line "
                                      f"{flight_line} give different {key} ({a}, {b}); the models belong to the "
                                      "flight line")
    breaks: list[float] = []
    for m in found:
        breaks += list(m.breaks_times)
        if m.breaks_lines:
            strip = m.strip if m.strip != flight_line or flight_line in {s.id for s in project.strips} else None
            if strip is None:
                raise AdjustmentError(f"variant {variant.name}: breaks_lines of flight line {flight_line}: give "
                                      "breaks_times, or the lines of one of its strips (id = the strip's)")
            breaks += list(project.timing(strip).time_of_line(np.array(m.breaks_lines, float)))
    def first(key: str):
        return next((getattr(m, key) for m in found if getattr(m, key) is not None), None)

    merged = StripModels(flight_line, position_degree=first("position_degree"),
                         attitude_degree=first("attitude_degree"), rotation=first("rotation"))
    return merged, sorted(breaks)


def build_models(project: Project, variant: Variant, lines: dict[str, FlightLineData]) -> ModelSet:
    """The GPS/IMU models of a variant (none for DG): for the block (BE), per mission (ME), or per flight
    line, split at its breaks (SE, P, S). Every model serves flight lines (its windows are theirs)."""
    if variant.strategy == "DG":
        return ModelSet([])
    if variant.strategy in ("BE", "ME"):
        groups: dict[str, list[str]] = {}
        for fid, line in lines.items():
            missions = sorted({project.strip(sid).mission for sid in line.strips})
            if len(missions) > 1:
                raise AdjustmentError(f"flight line {fid}: its strips belong to missions {', '.join(missions)}; "
                                      "a flight line is flown in one mission")
            groups.setdefault("block" if variant.strategy == "BE" else f"mission {missions[0]}", []).append(fid)
        out = []
        for name, fids in groups.items():
            t0 = min(lines[f].epochs[0] for f in fids)
            t1 = max(lines[f].epochs[-1] for f in fids)
            centre = np.mean(np.vstack([lines[f].gpsimu[:, :3] for f in fids]), axis=0)
            out.append(group_model(name, fids, t0, t1, variant.position_degree, variant.attitude_degree,
                                   variant.rotation, centre))
        return ModelSet(out)
    models = []
    for fid, line in lines.items():
        cfg, breaks = _line_overrides(project, variant, fid)
        pdeg = variant.position_degree if cfg.position_degree is None else cfg.position_degree
        adeg = variant.attitude_degree if cfg.attitude_degree is None else cfg.attitude_degree
        rot = variant.rotation if cfg.rotation is None else cfg.rotation
        edges = [float(line.epochs[0])] + breaks + [float(line.epochs[-1])]
        spans = list(zip(edges, edges[1:]))
        centres = ([line.gpsimu[(line.epochs >= lo) & (line.epochs <= hi), :3].mean(axis=0) for lo, hi in spans]
                   if all(hi > lo for lo, hi in spans) else None)  # else strip_models names the bad break
        models += strip_models(fid, edges, pdeg, adeg, rot, centres, where=f"variant {variant.name}, ")
    return ModelSet(models)


def _correction_block(params: Parameters, m: GpsImuModel, v: Variant) -> None:
    names = m.names()
    prior, regularisation = correction_sigmas(m, v)
    params.add(m.key, np.zeros(len(names)), True, prior_sigma=prior, prior_values=np.zeros(len(names)),
               regularisation_sigma=regularisation, names=names, conditions=m.conditions)


@dataclass
class _Setup:
    """What the steps of :func:`build_block` share: the inputs, the strips and models, each
    point's role, the points that enter the adjustment (and their rows of points.csv by strip), and
    the notes for the user."""

    project: Project
    variant: Variant
    points: ImagePoints
    ground: GroundPoints
    lines: dict[str, FlightLineData]
    strips: dict[str, StripData]
    models: ModelSet
    roles: dict[str, str] = field(default_factory=dict)
    used: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    rows: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def given(self) -> dict[str, int]:
        """Row of each point of ground.csv."""
        return {str(p): i for i, p in enumerate(self.ground.point)}

    def measured_in(self, sid: str) -> np.ndarray:
        """Rows of points.csv of strip ``sid`` whose points enter the adjustment (ascending)."""
        return self.rows.get(sid, np.empty(0, dtype=np.intp))


def build_block(project: Project, variant: Variant, points: ImagePoints, ground: GroundPoints) -> Block:
    """The parameters and observation groups of ``variant`` on ``project``.

    The steps: every flight line's GPS/IMU and start spline and the image strips on it
    (:func:`block_strips`), the GPS/IMU models (:func:`build_models`), the unknowns of the orientation
    and of every sensor's calibration, each point's role and which points enter, their start
    coordinates, and the observation groups.
    """
    check_points(project, points, ground)  # strips, inside the images, tie points in 2+ strips, near the DTM
    lines, strips = block_strips(project)
    setup = _Setup(project, variant, points, ground, lines, strips, build_models(project, variant, lines))
    params = Parameters()
    _orientation_unknowns(setup, params)
    _calibration_unknowns(setup, params)
    _choose_points(setup)
    _require_points(setup)
    _ground_unknowns(setup, params)
    groups = _observation_groups(setup)
    for note in setup.notes:
        log.warning("%s", note)
    start = {key: params[key].values.copy() for key, *_ in block_calibration(project) if key in params}
    return Block(project, variant, strips, setup.models, params, groups, points, ground, setup.roles, setup.notes,
                 calibration_start=start, flight_lines=lines)


def _orientation_unknowns(setup: _Setup, params: Parameters) -> None:
    """Knots of every flight line's spline (fixed in DG) and the coefficients of every GPS/IMU model."""
    v = setup.variant
    for fid, line in setup.lines.items():
        params.add(Knots(fid), line.spline.coef.ravel(), v.strategy != "DG",
                   regularisation_sigma=np.tile([1.0, 1.0, 1.0, 0.01, 0.01, 0.01], line.spline.n_coef),
                   names=[f"{c}[{k}]" for k in range(line.spline.n_coef) for c in COMPONENTS])
    for m in setup.models:
        _correction_block(params, m, v)


def _calibration_unknowns(setup: _Setup, params: Parameters) -> None:
    """Per sensor: boresight, lever arm, time offset, a whiskbroom's scan index and scale, a pushbroom's
    across-track offset and scale and along-track offset: free where the variant calibrates them. The
    pushbroom's three carry priors (``value = the sensor's`` with the variant's ``*_sigma``), always: an
    across-track offset is nearly a boresight roll and an along-track offset nearly a boresight pitch (and
    a time offset), so without them calibrating both would leave the normal equations (nearly) singular.
    A sensor-specific name of ``calibrate`` (a whiskbroom's, a pushbroom's) frees it on the sensors of
    that kind, and must fit one of them."""
    project, v = setup.project, setup.variant
    sensors = project.line_scanners
    cal = set(v.calibrate)
    for names, kind, cls in ((WHISKBROOM_CALIBRATION, "whiskbroom (scan mirror)", Whiskbroom),
                             (PUSHBROOM_CALIBRATION, "pushbroom (detector line)", Pushbroom)):
        wrong = sorted(cal & set(names))
        if wrong and not any(isinstance(sc.model, cls) for sc in sensors.values()):
            kinds = " and ".join(sorted({sc.kind for sc in sensors.values()}))
            raise AdjustmentError(f"variant {v.name}: calibrate {', '.join(wrong)} is a {kind} parameter, but the "
                                  f"project's sensor is a {kinds}")
    laser_only = sorted(cal - set(IMAGE_CALIBRATION))
    if laser_only:
        kinds = " and ".join(sorted({sc.kind for sc in sensors.values()}))
        raise AdjustmentError(f"variant {v.name}: calibrate {', '.join(laser_only)} is a laser scanner's parameter, "
                              f"but the project's sensor is a {kinds}")
    for sid, sc in sensors.items():
        mount, sensor = sc.mounting, sc.model
        scan = sensor if isinstance(sensor, Whiskbroom) else None
        push = sensor if isinstance(sensor, Pushbroom) else None
        mine = cal - set(PUSHBROOM_CALIBRATION if scan else WHISKBROOM_CALIBRATION)
        for key, name, sigma in ((AcrossOffset(sid), "across_offset", np.radians(v.across_offset_sigma_deg)),
                                 (AcrossScale(sid), "across_scale", v.across_scale_sigma),
                                 (AlongOffset(sid), "along_offset", np.radians(v.along_offset_sigma_deg))):
            value = float(getattr(push, name)) if push else 0.0
            params.add(key, [value], name in mine, prior_sigma=[sigma], prior_values=[value],
                       regularisation_sigma=sigma, names=[name])
        add_calibration(params, [
            ("boresight", Boresight(sid), mount.boresight, ("roll", "pitch", "heading"), ANGLE_REGULARISATION_RAD),
            ("lever_arm", LeverArm(sid), mount.lever_arm_B, ("x", "y", "z"), LEVER_ARM_REGULARISATION_M),
            ("time_offset", TimeOffset(sid), [mount.time_offset], ("dt",), TIME_OFFSET_REGULARISATION_S),
            ("index_error", ScanIndex(sid), [scan.index_error if scan else 0.0], ("index",),
             ANGLE_REGULARISATION_RAD),
            ("scale_error", ScanScale(sid), [scan.scale_error if scan else 0.0], ("scale",), SCALE_REGULARISATION),
        ], mine)


def _require_points(setup: _Setup) -> None:
    """A variant that estimates anything beyond GPS/IMU as measured needs image measurements of ground
    points: calibration unknowns or corrected GPS/IMU models with no control or tie point have nothing
    to be determined by (the priors alone would return them unchanged, and no residual would say so)."""
    v = setup.variant
    if setup.used or (not v.calibrate and v.strategy == "DG"):
        return
    what = f"calibrates {', '.join(v.calibrate)}" if v.calibrate else f"corrects GPS/IMU ({v.strategy})"
    raise AdjustmentError(
        f"variant {v.name} {what}, but no control or tie point enters the adjustment (ground.csv has "
        f"{int(np.isin(setup.ground.role, list(CONTROL_COMPONENTS)).sum())} control points, points.csv "
        f"{len(setup.points)} measurements): add control points, or use direct georeferencing (DG)")


def _choose_points(setup: _Setup) -> None:
    """Each point's role (the variant's over ground.csv's; measured only: tie) and the points that
    enter the adjustment (not check or ignored; tie points seen in two strips or more)."""
    v, points, ground = setup.variant, setup.points, setup.ground
    setup.roles = v.roles_of(zip(map(str, ground.point), map(str, ground.role)))
    measured_only = [p for p in dict.fromkeys(map(str, points.point)) if p not in setup.roles]
    setup.roles.update(v.roles_of((p, "tie") for p in measured_only))
    meas_strips: dict[str, set] = {}
    for p, sid in zip(map(str, points.point), map(str, points.strip)):
        meas_strips.setdefault(p, set()).add(sid)
    given = setup.given
    for p, ss in meas_strips.items():
        role = setup.roles[p]
        if role in ("check", "ignore"):
            continue
        if role == "tie" and len(ss) < 2:
            setup.notes.append(f"tie point {p} is measured in strip {next(iter(ss))} only: left out")
            continue
        if role in CONTROL_COMPONENTS and p not in given:
            raise AdjustmentError(f"point {p} has role {role} but no coordinates in ground.csv")
        setup.used.append(p)
    # the rows of every strip in one pass over points.csv (a pass per strip is quadratic in strips)
    rows = np.flatnonzero(np.isin(points.point.astype(str), setup.used))
    strips = points.strip.astype(str)[rows]
    order = np.argsort(strips, kind="stable")  # rows stay ascending within a strip
    ids, starts = np.unique(strips[order], return_index=True)
    setup.rows = dict(zip(map(str, ids), np.split(rows[order], starts[1:])))


def _ground_unknowns(setup: _Setup, params: Parameters) -> None:
    """Coordinates of every point in the adjustment; start values: control from ground.csv, the
    others the mean of their rays of the direct georeferencing onto the DTM."""
    project, points, given = setup.project, setup.points, setup.given
    start: dict[str, list] = {p: [] for p in setup.used}
    for sid, s in setup.strips.items():
        sel = setup.measured_in(sid)
        if sel.size:
            xyz, _ = s.geometry.image_to_ground(points.line[sel], points.pixel[sel], project.dtm)
            for k, p in enumerate(points.point[sel]):
                if np.isfinite(xyz[k]).all():
                    start[str(p)].append(xyz[k])
    for p in setup.used:
        if setup.roles[p] == "control":
            x, y, z = setup.ground.xyz[given[p]]
            p0 = project.map_frame.map_to_project(np.array([x]), np.array([y]), np.array([z]))[0]
        elif start[p]:
            p0 = np.mean(start[p], axis=0)
        else:
            raise AdjustmentError(f"point {p}: no measurement of it hits the DTM with the GPS/IMU orientation")
        params.add(Ground(p), p0, True, regularisation_sigma=10.0, names=["x", "y", "z"])


def _observation_groups(setup: _Setup) -> list[ObservationGroup]:
    """Per flight line its GPS/IMU (not in DG); per strip its image measurements; the control coordinates;
    DTM heights at the tie points the variant asks for; the priors on relative mountings."""
    project, v, points, ground, roles = setup.project, setup.variant, setup.points, setup.ground, setup.roles
    groups: list[ObservationGroup] = []
    sig_gps = np.concatenate([v.gps_sigma_m, np.radians(v.imu_sigma_deg)])
    for sid, s in setup.strips.items():  # a flight line's GPS/IMU before its first strip's measurements
        line = s.line
        if v.strategy != "DG" and sid == next(x for x in line.strips if x in setup.strips):
            groups.append(GpsImuSamples(line.id, line.spline, line.epochs, line.gpsimu, sig_gps, setup.models))
        sel = setup.measured_in(sid)
        if sel.size == 0:
            setup.notes.append(f"strip {sid} has no image measurement in the adjustment"
                               + (f": it takes its orientation from flight line {s.flight_line}"
                                  if len(s.line.strips) > 1 else ""))
            continue
        sigma = points.sigma_px[sel] if v.image_sigma_px is None else v.image_sigma_px
        scanner = project.scanner_of(sid)
        groups.append(ImageObservations(sid, scanner.model, s.spline, project.timing(sid),
                                        points.point[sel].astype(str), points.line[sel], points.pixel[sel], sigma,
                                        measured_time=scanner.measured_time, flight_line=s.flight_line,
                                        sensor_id=s.sensor))
        if not any(roles[str(p)] in CONTROL_COMPONENTS for p in points.point[sel]):
            setup.notes.append(f"strip {sid} has no control point: it is held only by tie points and its GPS/IMU"
                               + (f" (flight line {s.flight_line}, shared with "
                                  f"{', '.join(x for x in s.line.strips if x != sid)})"
                                  if len(s.line.strips) > 1 else ""))
    ctrl = [p for p in setup.used if roles[p] in CONTROL_COMPONENTS]
    if ctrl:
        given = setup.given
        idx = [given[p] for p in ctrl]
        sig = np.column_stack([ground.sigma_xy[idx], ground.sigma_xy[idx], ground.sigma_z[idx]])
        comp = np.array([CONTROL_COMPONENTS[roles[p]] for p in ctrl])
        groups.append(GroundControl(ctrl, ground.xyz[idx], sig, comp, project.map_frame))
    else:
        setup.notes.append("no control point in the adjustment: the block's datum comes from the GPS/IMU alone")
    dtm_pts = [p for p in setup.used if roles[p] == "tie" and v.dtm_height_at(p)]
    if dtm_pts:
        groups.append(DtmHeights(dtm_pts, project.dtm, project.dtm_sigma))
    sensors = project.line_scanners
    for rel in project.relative_mountings:
        if rel.sensor in sensors and rel.reference in sensors:
            groups.append(RelativeMountingPrior(rel))
    return groups


def adjust_block(block: Block, snooping: bool | None = None, start: Mapping[Key, np.ndarray] | None = None,
                 callback: ProgressCallback = no_progress, max_rejections: int | None = None) -> Adjustment:
    """Adjust a built block with its variant's solver settings and data snooping.

    Parameters
    ----------
    snooping : None: as the variant says (``snooping``, ``critical_value``, ``rejections_per_round``,
        ``independent_rejections``, ``snooping_method``); False: no data snooping (probes, planning); True:
        on, with the variant's settings.
    start : start values of unknowns by key (e.g. the previous probe's solution); keys the block lacks,
        or whose size differs, are left at the block's start values.
    callback : progress of the adjustment.
    max_rejections : data snooping stops after this many units (None: the engine's default).
    """
    v = block.variant
    for key, values in (start or {}).items():
        if key in block.parameters and block.parameters[key].values.size == np.size(values):
            block.parameters[key].values[:] = values
    options = snooping_options(v, snooping)
    if max_rejections is not None:
        options = replace(options, max_rejections=max_rejections)
    return adjust(block.parameters, block.groups, SolverOptions(max_iterations=v.max_iterations, backend=v.backend),
                  options, callback, point_key=Ground)


def adjust_variant(project: Project, variant: Variant, points: ImagePoints, ground: GroundPoints,
                   snooping: bool | None = None, start: Mapping[Key, np.ndarray] | None = None,
                   callback: ProgressCallback = no_progress) -> tuple[Block, Adjustment]:
    """Build the block of ``variant`` (:func:`build_block`) and adjust it (:func:`adjust_block`); then
    test the calibration unknowns the variant names in ``test_calibration`` (:func:`test_calibration`)."""
    block = build_block(project, variant, points, ground)
    if variant.test_calibration:
        return block, test_calibration(block, lambda: adjust_block(block, snooping, start, callback))
    return block, adjust_block(block, snooping, start, callback)


def test_calibration(block: Block, adjust_it: Callable[[], Adjustment]) -> Adjustment:
    """Keep only the calibration the observations determine (Gruen's test of additional parameters).

    Every free component of the variant's ``test_calibration`` unknowns gets a two-sided t-test of its
    change from the start value, ``t = |x - x_0| / sigma_x`` against Student's t at
    ``calibration_alpha`` with the adjustment's redundancy. The least significant component below the
    critical value is fixed at its start value and the block adjusted again (``adjust_it``), until every
    tested component is significant. A component that only its prior holds (a pushbroom's across-track
    offset beside the boresight roll) has a small t and goes. Each decision is a note of the block
    and an entry of ``block.calibration_tests``; the check points take no part.
    """
    v, params = block.variant, block.parameters
    keys = block_calibration(block.project)
    names = {key: f"{sid} {name}" if sid else name for key, name, _, sid in keys if name in v.test_calibration}
    units = {key: unit for key, _, unit, _ in keys}
    start = {key: block.calibration_start[key] for key in names if key in block.calibration_start}
    tests = block.calibration_tests
    adjustment = adjust_it()
    while True:
        stats = adjustment.statistics
        crit = float(scipy.stats.t.ppf(1 - v.calibration_alpha / 2, max(stats.redundancy, 1)))
        candidates = []
        for key in start:
            block_now = adjustment.solution.parameters[key]
            sig = stats.sigmas(key)
            for j in np.flatnonzero(block_now.free):
                t_j = abs(block_now.values[j] - start[key][j]) / sig[j] if sig[j] > 0 else float("inf")
                candidates.append((float(t_j), key, int(j), float(block_now.values[j]), float(sig[j])))
        if not candidates:
            return adjustment
        t, key, i, value, sigma = min(candidates, key=lambda c: c[0])
        component = params[key].names[i]
        entry = {"unknown": names[key], "component": component, "t": t, "critical": crit, "value": value,
                 "sigma": sigma, "start": float(start[key][i]), "unit": units[key]}
        if t >= crit:
            for t_k, key_k, i_k, value_k, sigma_k in candidates:
                tests.append({"unknown": names[key_k], "component": params[key_k].names[i_k], "t": t_k,
                              "critical": crit, "value": value_k, "sigma": sigma_k,
                              "start": float(start[key_k][i_k]), "unit": units[key_k], "kept": True})
            return adjustment
        tests.append({**entry, "kept": False})
        change = describe_change(names[key], component, units[key], value - start[key][i], sigma)
        block.notes.append(f"calibration test: {change} (t = {t:.2f} < {crit:.2f}, alpha {v.calibration_alpha:g}): "
                           "not determined by the observations, fixed at its start value")
        params[key].free[i] = False
        params[key].values[i] = start[key][i]
        adjustment = adjust_it()
