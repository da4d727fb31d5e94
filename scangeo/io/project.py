"""The project folder: ``project.toml`` (docs/formats.md) and access to its DTM, strips and points.

One schema for both kinds of sensor: a line scanner (whiskbroom, pushbroom) whose strips are images
with their line times, or a laser scanner (``[sensor] kind = "laser"``) whose strips are LAS/LAZ files
of returns (``las``), with an optional trajectory each and no DTM needed. :attr:`Project.sensor` is
the line scanner, :attr:`Project.laser` the laser scanner; asking a project for the other kind's is a
:class:`~scangeo.errors.ProjectFileError` naming the file.
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
from scangeo.io.project_schema import SensorKeys, StripKeys, read_project_file
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
    """The [sensor] table."""

    kind: str
    model: Whiskbroom | Pushbroom
    mounting: Mounting
    line_rate: float
    bands: tuple[str, ...] = ()
    wavelengths_nm: tuple[float, ...] = ()
    measurement_time: str = "scan_plane"

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
        return cls(t.kind, model, mounting, t.line_rate_hz, t.bands, t.wavelengths_nm, t.measurement_time)


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

    @classmethod
    def from_keys(cls, t: SensorKeys) -> LaserSensor:
        info = {k: getattr(t, k) for k in ("fov_deg", "pulse_rate_hz", "scan_rate_hz", "scan_pattern")}
        return cls(t.boresight_deg, t.lever_arm_m, t.range_sigma_m, t.angle_sigma_deg, t.range_offset_m,
                   t.index_error_deg, {k: v for k, v in info.items() if v is not None})


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
    """One [[strips]] entry: an image strip (image, line times) or a laser strip (LAS/LAZ files)."""

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

    @classmethod
    def from_keys(cls, t: StripKeys, root: Path) -> StripConfig:
        """A strip of a checked [[strips]] entry (paths relative to the project folder); a laser strip
        without a trajectory has ``has_trajectory`` False (its ``trajectory`` is then the folder)."""
        return cls(t.id, root / t.image if t.image else None, root / (t.trajectory or ""), t.first_line_time,
                   root / t.line_times if t.line_times else None, t.lines,
                   tuple(root / n for n in (t.las or ())), t.point_source_id, t.mission, t.trajectory is not None)


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
    scanner : SensorConfig or LaserSensor
        The line scanner (sensor model, mounting, line rate) or the laser scanner.
    strips : tuple of StripConfig
        The strips: id, image or LAS files, trajectory, line times.
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
    scanner: SensorConfig | LaserSensor
    strips: tuple[StripConfig, ...]
    knot_spacing: float = 0.2
    dtm_sigma: float = 1.5
    trajectory_crs: str | None = None
    extra: dict = field(default_factory=dict)
    adjustment: dict = field(default_factory=dict)  # a laser project's [adjustment] table (unchecked here)

    @property
    def kind(self) -> str:
        """The kind of scanner.

        Returns
        -------
        str
            ``whiskbroom``, ``pushbroom`` or ``laser``.
        """
        return "laser" if isinstance(self.scanner, LaserSensor) else self.scanner.kind

    @property
    def is_laser(self) -> bool:
        """Whether this is a laser project.

        Returns
        -------
        bool
            True for ``[sensor] kind = "laser"``.
        """
        return isinstance(self.scanner, LaserSensor)

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
        if isinstance(self.scanner, LaserSensor):
            raise ProjectFileError(f"{self.file} [sensor.kind]: a laser project; this needs a line scanner's images "
                                   "(whiskbroom or pushbroom); a laser project runs through scangeo run (docs/run.md)")
        return self.scanner

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
        if not isinstance(self.scanner, LaserSensor):
            raise ProjectFileError(f"{self.file} [sensor.kind]: a {self.scanner.kind} project; this needs a laser "
                                   "project (kind = \"laser\", strips with las)")
        return self.scanner

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
        scanner: SensorConfig | LaserSensor = (LaserSensor.from_keys(keys.sensor) if keys.sensor.kind == "laser"
                                               else SensorConfig.from_keys(keys.sensor, root))
        strips = tuple(StripConfig.from_keys(s, root) for s in keys.strips)
        return cls(root, p.crs, root / p.dtm if p.dtm else None, geoid, p.origin, scanner, strips, p.knot_spacing_s,
                   p.dtm_sigma_m, p.trajectory_crs, adjustment=dict(keys.adjustment or {}))

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
        """The strip's GPS/IMU stream as measured.

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
        if check and not self.is_laser:
            check_strip_trajectory(stream, strip_times_of(self, strip_id))  # coverage, gaps: errors naming lines
        return stream

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
        return LineTiming(s.first_line_time, self.sensor.line_rate)

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
            Lever arm and boresight (default the project's).
        sensor : Whiskbroom or Pushbroom, optional
            The sensor model (default the project's).
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
        return StripGeometry(
            sensor or self.sensor.model,
            spline,
            self.timing(strip_id),
            self.n_lines(strip_id),
            mounting or self.sensor.mounting,
            strip_id,
        )
