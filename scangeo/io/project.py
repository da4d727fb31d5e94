"""The project folder: ``project.toml`` (docs/formats.md) and access to its DTM, strips and points.

One schema for both kinds of sensor: a line scanner (whiskbroom, pushbroom) whose strips are images
with their line times, or a laser scanner (``kind = "laser"``) whose strips are LAS/LAZ files of
returns (``las``), with an optional trajectory each and no DTM needed.

The platform: a project has one navigation system and one or more sensors (``[sensor]``, or
``[[sensors]]`` with ids). A **flight line** is a stretch of the platform's trajectory
(``[[flight_lines]]``); a **strip** is what one sensor recorded on one flight line, and strips of
different sensors on one flight line share its trajectory. A one-sensor project of one ``[sensor]``
whose strips each give their own ``trajectory`` is the special case of one sensor (id ``""``) and one
flight line per strip (the flight line's id is the strip's). :meth:`Project.sensor_of` is the sensor of
a strip and :meth:`Project.flight_line_of` its flight line; :attr:`Project.sensor` (the line scanner)
and :attr:`Project.laser` (the laser scanner) are the one sensor of a one-sensor project.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np

from scangeo.dtm import DTM
from scangeo.errors import InputFileError, MissingFileError, ProjectFileError
from scangeo.frames import Geoid, MapFrame, ProjectFrame, parse_crs
from scangeo.io.project_schema import (
    RelativeMountingKeys,
    SensorKeys,
    StripKeys,
    read_project_file,
    sensor_tables,
)
from scangeo.io.toml_config import load_toml
from scangeo.sensors.models import Pushbroom, Whiskbroom
from scangeo.sensors.strip import Mounting, StripGeometry
from scangeo.textfile import read_text
from scangeo.timing import LineTiming
from scangeo.trajectory.checks import check_strip_trajectory, strip_times_of
from scangeo.trajectory.readers import read_trajectory
from scangeo.trajectory.spline import OrientationSpline

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class SensorConfig:
    """A line scanner: the [sensor] table, or one [[sensors]] entry (``id``; ``""`` for the one sensor of a
    one-sensor project)."""

    kind: str
    model: Whiskbroom | Pushbroom
    mounting: Mounting
    line_rate: float
    bands: tuple[str, ...] = ()
    wavelengths_nm: tuple[float, ...] = ()
    measurement_time: str = "scan_plane"
    id: str = ""

    @property
    def measured_time(self) -> bool:
        """True when the measured line fixes the time of an image measurement (``measurement_time = "line"``)."""
        return self.measurement_time == "line"

    @classmethod
    def from_keys(cls, t: SensorKeys, root: Path) -> SensorConfig:
        """The sensor model and mounting of a checked [sensor] table."""
        model: Whiskbroom | Pushbroom
        assert t.pixels is not None and t.line_rate_hz is not None  # SensorKeys.check
        if t.kind == "whiskbroom":
            assert t.fov_deg is not None  # SensorKeys.check
            model = Whiskbroom(
                pixels=t.pixels, fov=np.radians(t.fov_deg), line_rate=t.line_rate_hz,
                scan_direction=t.scan_direction, per_pixel_timing=t.per_pixel_timing,
                index_error=np.radians(t.index_error_deg), scale_error=t.scale_error,
            )
        elif t.look_angles is not None:
            along, across = read_look_angles(root / t.look_angles, t.pixels)
            model = Pushbroom(pixels=t.pixels, along=along, across=across).with_calibration(**_pushbroom_calibration(t))
        else:
            assert t.focal_length_mm is not None and t.pixel_pitch_um is not None  # SensorKeys.check
            model = Pushbroom(
                pixels=t.pixels, focal_length=t.focal_length_mm / 1000.0, pitch=t.pixel_pitch_um / 1e6,
                principal_point=t.principal_point_px, k1=t.k1, k2=t.k2, line_offset=t.line_offset_mm / 1000.0,
            ).with_calibration(**_pushbroom_calibration(t))
        mounting = Mounting(lever_arm_B=np.array(t.lever_arm_m), boresight=np.radians(t.boresight_deg),
                            time_offset=t.time_offset_s)
        return cls(t.kind, model, mounting, t.line_rate_hz, t.bands, t.wavelengths_nm, t.measurement_time, t.id or "")


def _pushbroom_calibration(t: SensorKeys) -> dict[str, float]:
    """A pushbroom's calibration values of [sensor] in the model's units (rad, relative)."""
    return {"across_offset": float(np.radians(t.across_offset_deg)), "across_scale": t.across_scale,
            "along_offset": float(np.radians(t.along_offset_deg))}


@dataclass(frozen=True)
class LaserSensor:
    """The [sensor] table of a laser scanner: nominal calibration (degrees and metres as in the file)
    and precision; ``info`` the informative scan-pattern keys that were given."""

    boresight_deg: tuple[float, float, float]
    lever_arm_m: tuple[float, float, float]
    range_sigma_m: float = 0.02
    angle_sigma_deg: float = 0.005
    range_offset_m: float = 0.0
    index_error_deg: float = 0.0
    info: dict = field(default_factory=dict)
    id: str = ""
    kind: str = "laser"

    @classmethod
    def from_keys(cls, t: SensorKeys) -> LaserSensor:
        info = {k: getattr(t, k) for k in ("fov_deg", "pulse_rate_hz", "scan_rate_hz", "scan_pattern")}
        return cls(t.boresight_deg, t.lever_arm_m, t.range_sigma_m, t.angle_sigma_deg, t.range_offset_m,
                   t.index_error_deg, {k: v for k, v in info.items() if v is not None}, t.id or "")


Sensor = SensorConfig | LaserSensor


@dataclass(frozen=True)
class RelativeMounting:
    """A prior on the mounting of ``sensor`` relative to ``reference`` (``[[relative_mountings]]``):
    ``R_BS(sensor) = R_BS(reference) R_rel``, with ``R_rel`` from ``boresight`` (roll, pitch, heading,
    radians) within ``boresight_sigma``, and the lever arm difference ``lever_arm`` (sensor minus
    reference, body frame, metres) within ``lever_arm_sigma``; None: not given."""

    sensor: str
    reference: str
    boresight: np.ndarray | None = None
    boresight_sigma: np.ndarray | None = None
    lever_arm: np.ndarray | None = None
    lever_arm_sigma: np.ndarray | None = None

    @classmethod
    def from_keys(cls, t: RelativeMountingKeys) -> RelativeMounting:
        def rad(v):
            return None if v is None else np.radians(np.array(v, float))

        def arr(v):
            return None if v is None else np.array(v, float)

        return cls(t.sensor, t.reference, rad(t.boresight_deg), rad(t.boresight_sigma_deg), arr(t.lever_arm_m),
                   arr(t.lever_arm_sigma_m))


@dataclass(frozen=True)
class FlightLine:
    """A stretch of the platform's trajectory: ``id``, the trajectory file (the project folder when a laser
    strip has none: ``has_trajectory`` False) and the strips recorded on it. ``own``: the flight line of a
    strip that gives its own ``trajectory`` (its id is the strip's)."""

    id: str
    trajectory: Path
    strips: tuple[str, ...]
    own: bool = False
    has_trajectory: bool = True


def las_extent(path: Path) -> tuple[float, float, float, float]:
    """x min, y min, x max, y max of a LAS/LAZ file's returns, from its header."""
    import laspy  # start-up cost: laspy loads when a laser project's files are read

    try:
        with laspy.open(str(path)) as f:
            h = f.header
            return float(h.mins[0]), float(h.mins[1]), float(h.maxs[0]), float(h.maxs[1])
    except FileNotFoundError as exc:
        raise MissingFileError(f"{path}: no such LAS/LAZ file") from exc
    except (OSError, ValueError, laspy.errors.LaspyException) as exc:
        raise InputFileError(f"{path}: cannot read the LAS header ({exc})") from exc


def read_look_angles(path: Path, pixels: int) -> tuple[np.ndarray, np.ndarray]:
    """``pixel,along_deg,across_deg`` CSV -> (along, across) radians."""
    lines = read_text(path, "a look-angle table (CSV)", ProjectFileError).splitlines()
    try:
        data = np.loadtxt(lines, delimiter=",", skiprows=1, ndmin=2)
    except (OSError, ValueError) as exc:
        raise ProjectFileError(f"{path}: cannot read the look-angle table ({exc})") from exc
    if data.shape != (pixels, 3) or not np.array_equal(data[:, 0], np.arange(pixels)):
        raise ProjectFileError(f"{path}: expected rows pixel,along_deg,across_deg for pixels 0..{pixels - 1}")
    return np.radians(data[:, 1]), np.radians(data[:, 2])


@dataclass(frozen=True)
class StripConfig:
    """One [[strips]] entry: an image strip (image, line times) or a laser strip (LAS/LAZ files), recorded by
    ``sensor`` on ``flight_line`` (whose trajectory is ``trajectory``)."""

    id: str
    image: Path | None
    trajectory: Path
    first_line_time: float | None
    line_times: Path | None
    lines: int | None
    las: tuple[Path, ...] = ()
    point_source_id: int | None = None
    mission: str = "1"
    has_trajectory: bool = True
    sensor: str = ""
    flight_line: str = ""

    @classmethod
    def from_keys(cls, t: StripKeys, root: Path, sensor: str, trajectories: dict[str, str]) -> StripConfig:
        """A strip of a checked [[strips]] entry (paths relative to the project folder; ``trajectories``: the
        [[flight_lines]]' files by id); a laser strip without a trajectory has ``has_trajectory`` False (its
        ``trajectory`` is then the folder)."""
        line = t.flight_line if t.flight_line is not None else t.id
        trajectory = trajectories[t.flight_line] if t.flight_line is not None else t.trajectory
        return cls(t.id, root / t.image if t.image else None, root / (trajectory or ""), t.first_line_time,
                   root / t.line_times if t.line_times else None, t.lines,
                   tuple(root / n for n in (t.las or ())), t.point_source_id, t.mission, trajectory is not None,
                   sensor, line)


@dataclass(frozen=True)
class Project:
    """A project folder read from ``project.toml`` (module docstring; docs/formats.md): its frames, DTM,
    sensor and strips, for images and laser strips alike.

    Made by :meth:`load` (or :meth:`from_user_input`); every key of project.toml is checked there.

    Parameters
    ----------
    root : Path
        The project folder.
    crs : str
        The map CRS of the DTM, the control points and the outputs (any pyproj CRS string).
    dtm_file : Path or None
        The DTM raster (None: a laser project without one).
    geoid : Geoid
        The geoid undulation: a constant or a raster, metres.
    origin : tuple of 3 float or None
        Origin of the project frame: latitude, longitude (degrees), ellipsoidal height (metres);
        None: the DTM's centre (or the strips' returns').
    sensors : dict of str to SensorConfig or LaserSensor
        The platform's sensors by id, in the file's order: line scanners (sensor model, mounting, line
        rate) and laser scanners; a one-sensor project's ``[sensor]`` has the id ``""``.
    strips : tuple of StripConfig
        The strips: id, sensor, flight line, image or LAS files, trajectory, line times.
    flight_lines : dict of str to FlightLine
        The flight lines by id: their trajectory and strips (a strip with its own trajectory is one).
    relative_mountings : tuple of RelativeMounting
        Priors on the mounting of one sensor relative to another.
    knot_spacing : float
        Spacing of the orientation spline's knots, seconds.
    dtm_sigma : float
        Accuracy of the DTM's heights, metres.
    trajectory_crs : str or None
        CRS of trajectory CSVs with x, y columns (None: ``crs``).
    extra : dict
        Anything a caller attaches (not read from the file).
    adjustment : dict
        A laser project's ``[adjustment]`` table.
    """

    root: Path
    crs: str
    dtm_file: Path | None
    geoid: Geoid
    origin: tuple[float, float, float] | None
    sensors: dict[str, Sensor]
    strips: tuple[StripConfig, ...]
    flight_lines: dict[str, FlightLine] = field(default_factory=dict)
    relative_mountings: tuple[RelativeMounting, ...] = ()
    knot_spacing: float = 0.2
    dtm_sigma: float = 1.5
    trajectory_crs: str | None = None
    extra: dict = field(default_factory=dict)
    adjustment: dict = field(default_factory=dict)  # a laser project's [adjustment] table (unchecked here)

    @property
    def kind(self) -> str:
        """The kind of scanner of a one-sensor project.

        Returns
        -------
        str
            ``whiskbroom``, ``pushbroom`` or ``laser``; ``platform`` for several sensors.
        """
        kinds = {sensor.kind for sensor in self.sensors.values()}
        return kinds.pop() if len(self.sensors) == 1 else "platform"

    @property
    def is_laser(self) -> bool:
        """Whether every sensor is a laser scanner (a laser project).

        Returns
        -------
        bool
            True for ``kind = "laser"`` sensors only.
        """
        return all(isinstance(sensor, LaserSensor) for sensor in self.sensors.values())

    @property
    def is_platform(self) -> bool:
        """Whether the project has several sensors or flight lines shared by several strips.

        Returns
        -------
        bool
            False for a project of one ``[sensor]`` whose strips each have their own trajectory.
        """
        return len(self.sensors) > 1 or any(len(f.strips) > 1 for f in self.flight_lines.values())

    def sensor_of(self, strip_id: str) -> Sensor:
        """The sensor that recorded a strip.

        Parameters
        ----------
        strip_id : str
            The strip's id.

        Returns
        -------
        SensorConfig or LaserSensor
            Its line scanner (model, mounting, line rate) or laser scanner.
        """
        return self.sensors[self.strip(strip_id).sensor]

    def scanner_of(self, strip_id: str) -> SensorConfig:
        """The line scanner that recorded an image strip.

        Parameters
        ----------
        strip_id : str
            The strip's id.

        Returns
        -------
        SensorConfig
            The whiskbroom or pushbroom model, its mounting and line rate.

        Raises
        ------
        ProjectFileError
            A strip of a laser scanner.
        """
        sensor = self.sensor_of(strip_id)
        if isinstance(sensor, LaserSensor):
            raise ProjectFileError(f"{self.file} strip {strip_id}: recorded by the laser scanner "
                                   f"{sensor.id or '[sensor]'}; this needs a line scanner's image")
        return sensor

    def flight_line_of(self, strip_id: str) -> FlightLine:
        """The flight line a strip was recorded on.

        Parameters
        ----------
        strip_id : str
            The strip's id.

        Returns
        -------
        FlightLine
            Its id, trajectory file and strips (a strip with its own trajectory: a flight line of its own,
            of the strip's id).
        """
        return self.flight_lines[self.strip(strip_id).flight_line]

    @property
    def image_strips(self) -> tuple[StripConfig, ...]:
        """The strips of line scanners (images).

        Returns
        -------
        tuple of StripConfig
            In the file's order.
        """
        return tuple(s for s in self.strips if not isinstance(self.sensors[s.sensor], LaserSensor))

    @property
    def line_scanners(self) -> dict[str, SensorConfig]:
        """The line scanners that recorded the image strips, by id, in the file's order.

        Returns
        -------
        dict of str to SensorConfig
            Whiskbrooms and pushbrooms with at least one strip.
        """
        used = {s.sensor for s in self.image_strips}
        return {sid: sc for sid, sc in self.sensors.items() if sid in used and isinstance(sc, SensorConfig)}

    @property
    def laser_strips(self) -> tuple[StripConfig, ...]:
        """The strips of laser scanners (returns).

        Returns
        -------
        tuple of StripConfig
            In the file's order.
        """
        return tuple(s for s in self.strips if isinstance(self.sensors[s.sensor], LaserSensor))

    def _one_sensor(self, what: str) -> Sensor:
        if len(self.sensors) != 1:
            raise ProjectFileError(f"{self.file} [sensors]: a platform of {len(self.sensors)} sensors "
                                   f"({', '.join(self.sensors)}); {what} of a strip is Project.sensor_of(strip)")
        return next(iter(self.sensors.values()))

    @property
    def file(self) -> Path:
        """The project file.

        Returns
        -------
        Path
            ``PROJECT/project.toml``.
        """
        return self.root / "project.toml"

    @property
    def sensor(self) -> SensorConfig:
        """The line scanner of an image project.

        Returns
        -------
        SensorConfig
            The whiskbroom or pushbroom model, its mounting and line rate.

        Raises
        ------
        ProjectFileError
            A laser project.
        """
        sensor = self._one_sensor("the line scanner")
        if isinstance(sensor, LaserSensor):
            raise ProjectFileError(f"{self.file} [sensor.kind]: a laser project; this needs a line scanner's images "
                                   "(whiskbroom or pushbroom); a laser project runs through scangeo run (docs/run.md)")
        return sensor

    @property
    def laser(self) -> LaserSensor:
        """The laser scanner of a laser project.

        Returns
        -------
        LaserSensor
            Its mounting and scan geometry.

        Raises
        ------
        ProjectFileError
            An image project.
        """
        sensor = self._one_sensor("the laser scanner")
        if not isinstance(sensor, LaserSensor):
            raise ProjectFileError(f"{self.file} [sensor.kind]: a {sensor.kind} project; this needs a laser "
                                   "project (kind = \"laser\", strips with las)")
        return sensor

    @property
    def dtm_path(self) -> Path:
        """The DTM raster.

        Returns
        -------
        Path
            The file of ``[project] dtm``.

        Raises
        ------
        ProjectFileError
            The project has none (a laser project may not), naming the key.
        """
        if self.dtm_file is None:
            raise ProjectFileError(f"{self.file} [project.dtm]: missing (this step needs a DTM)")
        return self.dtm_file

    @property
    def has_trajectories(self) -> bool:
        """Whether every strip has a trajectory.

        Returns
        -------
        bool
            False for a laser project without them (adjusted trajectory-free).
        """
        return all(s.has_trajectory for s in self.strips)

    @classmethod
    def load(cls, path: str | Path) -> Project:
        """Read ``PATH/project.toml`` (or the file itself).

        Parameters
        ----------
        path : str or Path
            The project folder, or its project.toml.

        Returns
        -------
        Project
            The project, every key of project.toml checked.

        Raises
        ------
        MissingFileError
            There is no project.toml.
        ProjectFileError
            project.toml is not valid TOML, or a key is unknown, missing or out of range (the message
            names the file and the key).
        """
        path = Path(path)
        file = path / "project.toml" if path.is_dir() else path
        if not file.exists():
            raise MissingFileError(f"{file}: no such project file")
        root = file.parent
        keys = read_project_file(load_toml(file), file)  # every key checked (scangeo.io.schema)
        p = keys.project
        parse_crs(p.crs, f"{file} [project.crs]")
        if p.trajectory_crs is not None:
            parse_crs(p.trajectory_crs, f"{file} [project.trajectory_crs]")
        geoid = Geoid.from_raster(root / p.geoid) if p.geoid else Geoid(p.geoid_undulation_m or 0.0)
        sensors: dict[str, Sensor] = {
            sid: LaserSensor.from_keys(t) if t.kind == "laser" else SensorConfig.from_keys(t, root)
            for sid, (t, _) in sensor_tables(keys, file).items()}
        first = next(iter(sensors))
        trajectories = {f.id: f.trajectory for f in keys.flight_lines}
        strips = tuple(StripConfig.from_keys(s, root, s.sensor if s.sensor is not None else first, trajectories)
                       for s in keys.strips)
        lines: dict[str, FlightLine] = {}
        for f in keys.flight_lines:
            lines[f.id] = FlightLine(f.id, root / f.trajectory, tuple(s.id for s in strips if s.flight_line == f.id))
        for s in strips:  # a strip with a trajectory of its own is a flight line of its own
            if s.flight_line not in lines:
                lines[s.flight_line] = FlightLine(s.id, s.trajectory, (s.id,), True, s.has_trajectory)
        relative = tuple(RelativeMounting.from_keys(r) for r in keys.relative_mountings)
        return cls(root, p.crs, root / p.dtm if p.dtm else None, geoid, p.origin, sensors, strips, lines, relative,
                   p.knot_spacing_s, p.dtm_sigma_m, p.trajectory_crs, adjustment=dict(keys.adjustment or {}))

    @classmethod
    def from_user_input(cls, project: str | Path | Project) -> Project:
        """A project given as a loaded :class:`Project` (returned as it is) or as a path (:meth:`load`).

        Parameters
        ----------
        project : str, Path or Project
            The project folder, its project.toml, or a project already loaded.

        Returns
        -------
        Project
            ``project`` itself when it is one, else the project read from the path.
        """
        return project if isinstance(project, Project) else cls.load(project)

    # --- frames and DTM -------------------------------------------------------------------------
    @cached_property
    def map_frame(self) -> MapFrame:
        """The map CRS and the project frame (a local ENU frame), and the conversions between them.

        Returns
        -------
        MapFrame
            Map CRS <-> project frame; the frame's origin is ``[project] origin``, the DTM's centre or,
            in a laser project without a DTM, the centre of the strips' returns (their LAS headers).
        """
        if self.origin is not None:
            lat, lon, h = self.origin
            return MapFrame(self.crs, ProjectFrame.from_origin(lat, lon, h), self.geoid)
        if self.dtm_file is None:
            b = np.array([las_extent(f) for s in self.strips for f in s.las])
            cx, cy = 0.5 * (b[:, 0].min() + b[:, 2].max()), 0.5 * (b[:, 1].min() + b[:, 3].max())
            return MapFrame.centred_on(self.crs, float(cx), float(cy), 0.0, self.geoid)
        import rasterio

        try:
            with rasterio.open(self.dtm_path) as src:
                b = src.bounds
                cx, cy = 0.5 * (b.left + b.right), 0.5 * (b.bottom + b.top)
                src_crs = src.crs.to_wkt() if src.crs else None
        except rasterio.errors.RasterioIOError as exc:
            raise ProjectFileError(f"{self.dtm_path}: cannot read the DTM ({exc})") from exc
        if src_crs is not None:
            import pyproj

            tr = pyproj.Transformer.from_crs(src_crs, self.crs, always_xy=True)
            cx, cy = tr.transform(cx, cy)
        return MapFrame.centred_on(self.crs, float(cx), float(cy), 0.0, self.geoid)

    @cached_property
    def dtm(self) -> DTM:
        """The project's DTM, opened once.

        Returns
        -------
        DTM
            Heights (orthometric, metres) at map or project-frame positions.
        """
        return DTM.open(self.dtm_path, self.map_frame)

    # --- strips ---------------------------------------------------------------------------------
    def strip(self, strip_id: str) -> StripConfig:
        """One strip's entry of project.toml.

        Parameters
        ----------
        strip_id : str
            The strip's id.

        Returns
        -------
        StripConfig
            Its id, image or LAS files, trajectory and line times (paths within the project folder).

        Raises
        ------
        ProjectFileError
            No such strip (the message lists the strips).
        """
        for s in self.strips:
            if s.id == str(strip_id):
                return s
        raise ProjectFileError(
            f"{self.root / 'project.toml'}: no strip {strip_id!r} (strips: {', '.join(s.id for s in self.strips)})"
        )

    def stream(self, strip_id: str, check: bool = True):
        """The GPS/IMU stream as measured of a strip's flight line.

        Parameters
        ----------
        strip_id : str
            The strip's id.
        check : bool
            Check that the trajectory covers an image strip's lines without gaps
            (scangeo.trajectory.checks).

        Returns
        -------
        Trajectory
            Times (seconds), positions and attitudes as the trajectory file gives them.

        Raises
        ------
        TrajectoryError
            A malformed trajectory, or (with ``check``) one that does not cover the strip.
        """
        strip = self.strip(strip_id)
        if not strip.has_trajectory:
            raise ProjectFileError(f"{self.file}: strip {strip_id} has no trajectory")
        stream = read_trajectory(strip.trajectory, crs=self.trajectory_crs or self.crs)
        if check and not isinstance(self.sensors[strip.sensor], LaserSensor):
            check_strip_trajectory(stream, strip_times_of(self, strip_id))  # coverage, gaps: errors naming lines
        return stream

    def flight_line_stream(self, flight_line: str, check: bool = True):
        """A flight line's GPS/IMU stream as measured.

        Parameters
        ----------
        flight_line : str
            The flight line's id.
        check : bool
            Check that it covers the lines of every image strip recorded on it.

        Returns
        -------
        Trajectory
            Times (seconds), positions and attitudes as the trajectory file gives them.
        """
        line = self.flight_lines[flight_line]
        if not line.has_trajectory:
            raise ProjectFileError(f"{self.file}: flight line {flight_line} has no trajectory")
        stream = read_trajectory(line.trajectory, crs=self.trajectory_crs or self.crs)
        if check:
            self.check_flight_line(flight_line)
            for sid in line.strips:
                if not isinstance(self.sensor_of(sid), LaserSensor):
                    check_strip_trajectory(stream, strip_times_of(self, sid))
        return stream

    def check_flight_line(self, flight_line: str) -> None:
        """Check that the image strips of different sensors recorded on one flight line overlap in time.

        Parameters
        ----------
        flight_line : str
            The flight line's id.

        Returns
        -------
        None
            It raises where the strips do not overlap.

        Raises
        ------
        ProjectFileError
            Two strips of different sensors on the flight line whose line times do not overlap (a strip
            put on the wrong flight line), naming both strips and their times.
        """
        spans = []
        for sid in self.flight_lines[flight_line].strips:
            if isinstance(self.sensor_of(sid), LaserSensor):
                continue
            times = self.timing(sid).as_table(self.n_lines(sid))
            spans.append((sid, self.strip(sid).sensor, float(times[0]), float(times[-1])))
        for i, (a, sa, a0, a1) in enumerate(spans):
            for b, sb, b0, b1 in spans[i + 1:]:
                if sa != sb and (a1 < b0 or b1 < a0):
                    raise ProjectFileError(
                        f"{self.file} [strips] (flight line {flight_line}): strip {a} ({sa}, {a0:.3f}..{a1:.3f} s) "
                        f"and strip {b} ({sb}, {b0:.3f}..{b1:.3f} s) do not overlap in time; strips of one flight "
                        "line are recorded at the same time by the platform's sensors (another flight_line?)")

    def timing(self, strip_id: str) -> LineTiming:
        """When the strip's lines were taken.

        Parameters
        ----------
        strip_id : str
            The strip's id.

        Returns
        -------
        LineTiming
            Line -> time (seconds of the project's time base): the line time table, or the first line's
            time and the line rate.
        """
        s = self.strip(strip_id)
        if s.line_times is not None:
            return LineTiming.from_table_file(s.line_times)
        assert s.first_line_time is not None  # project_schema: exactly one of the two
        return LineTiming(s.first_line_time, self.scanner_of(strip_id).line_rate)

    def n_lines(self, strip_id: str) -> int:
        """The number of image lines of a strip.

        Parameters
        ----------
        strip_id : str
            The strip's id.

        Returns
        -------
        int
            ``lines`` of project.toml, else the line time table's length, else the image's height.
        """
        s = self.strip(strip_id)
        if s.lines is not None:
            return s.lines
        if s.line_times is not None:
            table = self.timing(strip_id).table
            assert table is not None  # a timing read from a line time table has one
            return len(table)
        if s.image is None:
            raise ProjectFileError(f"strip {strip_id}: give lines = N or an image to count them")
        import warnings

        import rasterio

        try:
            with warnings.catch_warnings():  # a raw scanner image has no georeferencing
                warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)
                with rasterio.open(s.image) as src:
                    return int(src.height)
        except rasterio.errors.RasterioIOError as exc:
            raise ProjectFileError(f"{s.image}: cannot read the image ({exc})") from exc

    def geometry(self, strip_id: str, spline=None, mounting: Mounting | None = None, sensor=None,
                 check: bool = True) -> StripGeometry:
        """A strip's geometry: sensor, orientation spline, line timing, mounting (ground <-> image).

        Parameters
        ----------
        strip_id : str
            The strip's id.
        spline : OrientationSpline, optional
            The orientation (project frame); default direct georeferencing: the spline fitted to the
            GPS/IMU as measured.
        mounting : Mounting, optional
            Lever arm and boresight (default the strip's sensor's, as project.toml gives it).
        sensor : Whiskbroom or Pushbroom, optional
            The sensor model (default the strip's sensor's).
        check : bool
            Check the trajectory's coverage and gaps (False: locate answers point by point "outside the
            trajectory" instead; rectify, adjust and the reports keep the check).

        Returns
        -------
        StripGeometry
            The strip's geometry in the project frame.
        """
        if spline is None:
            traj = self.stream(strip_id, check=check).to_project(self.map_frame.frame)
            spline = OrientationSpline.from_trajectory(traj, self.knot_spacing)
        scanner = self.scanner_of(strip_id)
        return StripGeometry(
            sensor or scanner.model,
            spline,
            self.timing(strip_id),
            self.n_lines(strip_id),
            mounting or scanner.mounting,
            strip_id,
        )
