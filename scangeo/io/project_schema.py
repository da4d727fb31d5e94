"""The keys of project.toml as settings dataclasses (:mod:`scangeo.io.schema`).

:func:`read_project_file` checks the whole file, key by key (type, range, allowed values, kind-specific
sensor keys); :class:`scangeo.io.project.Project` builds the sensor model, frames and strips from the
result. docs/formats.md's key tables are generated from these classes.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from scangeo.errors import ProjectFileError
from scangeo.io.schema import read, setting

_WHISK = ("kind", "whiskbroom")
_PUSH = ("kind", "pushbroom")
_IMAGE = ("kind", ("whiskbroom", "pushbroom"))
_LASER = ("kind", "laser")
_ANGLES = ("kind", ("whiskbroom", "laser"))
#: The sensor kinds: line scanners that record images, and laser scanners that record returns.
IMAGE_KINDS = ("whiskbroom", "pushbroom")
KINDS = (*IMAGE_KINDS, "laser")


@dataclass(frozen=True)
class ProjectKeys:
    """The ``[project]`` table."""

    crs: str = setting(doc="map CRS of the DTM, ground points and outputs: anything pyproj accepts "
                           "(EPSG code, WKT, PROJ string); heights in it are orthometric")
    dtm: str | None = setting(None, default_doc="required for images",
                              doc="the DTM raster (orthometric heights, m), relative to the project folder; "
                                  "a DTM in another CRS is warped into `crs` (bilinear); a laser project needs none")
    geoid_undulation_m: float | None = setting(None, default_doc="0.0",
                                               doc="constant geoid undulation N: ellipsoidal h = H + N")
    geoid: str | None = setting(None, doc="a raster of N (m) sampled bilinearly (EGM2008 in EPSG:4326 works as "
                                          "it is); instead of `geoid_undulation_m`")
    origin: tuple[float, float, float] | None = setting(
        None, unit="deg, deg, m", default_doc="DTM centre (laser: centre of the strips)",
        doc="origin of the project frame: latitude, longitude (WGS84) and ellipsoidal height")
    knot_spacing_s: float = setting(0.2, gt=0, doc="knot spacing of the orientation spline")
    dtm_sigma_m: float = setting(1.5, gt=0, doc="standard deviation of the DTM heights (tie points with Z = DTM)")
    trajectory_crs: str | None = setting(None, default_doc="`crs`", doc="CRS of the x, y columns of trajectory CSVs")


@dataclass(frozen=True)
class SensorKeys:
    """The ``[sensor]`` table, or one ``[[sensors]]`` entry of a platform; whiskbroom, pushbroom and laser
    keys exist only for their kind."""

    kind: str = setting(choices=KINDS, doc="the scanner type: a line scanner recording images (whiskbroom, "
                                          "pushbroom) or a laser scanner recording returns (laser)")
    id: str | None = setting(None, file_type=str | int, parse=lambda v, where: str(v), default_doc="required in "
                             "[[sensors]]", doc="the sensor's name, unique in the project; the strips name it "
                                                "(`sensor`)")
    pixels: int | None = setting(None, ge=1, unit="px", when=_IMAGE, default_doc="required",
                                 doc="pixels per line (detector elements of a pushbroom)")
    line_rate_hz: float | None = setting(None, gt=0, when=_IMAGE, default_doc="required",
                                         doc="lines per second (of a whiskbroom also mirror revolutions per second)")
    boresight_deg: tuple[float, float, float] = setting(
        (0.0, 0.0, 0.0), doc="roll, pitch, heading of the sensor in the body frame: R = Rz(c) Ry(b) Rx(a)")
    lever_arm_m: tuple[float, float, float] = setting(
        (0.0, 0.0, 0.0), doc="navigation reference point -> projection centre, body frame (x forward, y right, z down)")
    time_offset_s: float = setting(0.0, when=_IMAGE, doc="navigation time of sensor time t is t + time_offset_s")
    bands: tuple[str, ...] = setting((), when=_IMAGE, doc="band names (written into outputs)")
    wavelengths_nm: tuple[float, ...] = setting((), gt=0, when=_IMAGE, doc="band centre wavelengths")
    measurement_time: str = setting(
        "scan_plane", choices=("scan_plane", "line"), when=_IMAGE,
        doc="the time of an image measurement: `scan_plane`, when the point lies in the scan plane "
            "(solved from the measured line); `line`, the measured line's own time (navigation with one "
            "record per line and attitude jitter between lines: docs/real-data.md)")
    # whiskbroom (and laser)
    fov_deg: float | None = setting(None, gt=0, lt=180, when=_ANGLES, default_doc="required for a whiskbroom",
                                    doc="whiskbroom: total scan angle; the angular step is fov / pixels; "
                                        "laser: the scan pattern's total angle (informative)")
    scan_direction: int = setting(1, choices=(1, -1), when=_WHISK, unit="1",
                                  doc="whiskbroom: +1 when pixel numbers grow to the right of the flight direction")
    per_pixel_timing: bool = setting(True, when=_WHISK,
                                     doc="whiskbroom: pixel j is recorded (j - (pixels-1)/2) step / (2 pi rate) "
                                         "after its line's time")
    index_error_deg: float = setting(0.0, when=_ANGLES, doc="whiskbroom, laser: scan-angle offset (index error)")
    scale_error: float = setting(0.0, when=_WHISK, unit="1", doc="whiskbroom: scan-angle scale error (0.001 = 0.1 %)")
    # pushbroom
    look_angles: str | None = setting(None, when=_PUSH,
                                      doc="pushbroom: the look-angle table (instead of the pinhole keys)")
    focal_length_mm: float | None = setting(None, gt=0, when=_PUSH, doc="pushbroom pinhole: focal length")
    pixel_pitch_um: float | None = setting(None, gt=0, when=_PUSH, doc="pushbroom pinhole: detector pitch")
    principal_point_px: float | None = setting(None, when=_PUSH, default_doc="(pixels - 1) / 2",
                                               doc="pushbroom pinhole: principal point")
    k1: float = setting(0.0, when=_PUSH, unit="1/m^2", doc="pushbroom pinhole: radial distortion x_u = x_d (1 + k1 r^2 "
                                                          "+ k2 r^4), r in metres on the focal plane")
    k2: float = setting(0.0, when=_PUSH, unit="1/m^4", doc="pushbroom pinhole: radial distortion (see k1)")
    line_offset_mm: float = setting(0.0, when=_PUSH, doc="pushbroom pinhole: along-track offset of the detector line")
    across_offset_deg: float = setting(0.0, when=_PUSH, doc="pushbroom calibration: offset of the across-track "
                                       "look angles' tangents (as an angle near the centre; docs/geometry.md)")
    across_scale: float = setting(0.0, gt=-0.5, lt=0.5, when=_PUSH, unit="1",
                                  doc="pushbroom calibration: scale of the across-track tangents about the centre "
                                      "pixel (0.001 = 0.1 %)")
    along_offset_deg: float = setting(0.0, when=_PUSH, doc="pushbroom calibration: offset of the along-track "
                                      "look angles' tangents")
    # laser
    range_sigma_m: float = setting(0.02, gt=0, when=_LASER, doc="laser: ranging precision (the plane fits' "
                                                               "a priori sigma)")
    angle_sigma_deg: float = setting(0.005, gt=0, when=_LASER, doc="laser: scan-angle precision (informative)")
    range_offset_m: float = setting(0.0, when=_LASER, doc="laser: nominal range offset")
    pulse_rate_hz: float | None = setting(None, gt=0, when=_LASER, doc="laser: pulse rate (informative)")
    scan_rate_hz: float | None = setting(None, gt=0, when=_LASER, doc="laser: scan rate (informative)")
    scan_pattern: str | None = setting(None, when=_LASER, doc="laser: scan pattern (informative)")

    def check(self, where: str) -> None:
        """Keys that depend on each other."""
        if self.kind in IMAGE_KINDS:
            for key in ("pixels", "line_rate_hz"):
                if getattr(self, key) is None:
                    raise ProjectFileError(f"{where}.{key}]: missing (required for a {self.kind})")
        if self.kind == "whiskbroom" and self.fov_deg is None:
            raise ProjectFileError(f"{where}.fov_deg]: missing (required for a whiskbroom)")
        if self.kind == "pushbroom" and self.look_angles is None:
            for key in ("focal_length_mm", "pixel_pitch_um"):
                if getattr(self, key) is None:
                    raise ProjectFileError(f"{where}.{key}]: missing (required for a pinhole pushbroom "
                                           "without look_angles)")
        if self.kind == "pushbroom" and self.look_angles is not None:
            given = [k for k in ("focal_length_mm", "pixel_pitch_um", "principal_point_px") if getattr(self, k)]
            if given:
                raise ProjectFileError(f"{where}.{given[0]}]: not a key with look_angles (a look-angle table "
                                       "replaces the pinhole camera)")


@dataclass(frozen=True)
class RelativeMountingKeys:
    """One ``[[relative_mountings]]`` entry: a prior on the mounting of one sensor relative to another's
    (from an earlier calibration), ``R_BS(sensor) = R_BS(reference) R_rel``."""

    sensor: str = setting(file_type=str | int, parse=lambda v, where: str(v), doc="the sensor whose mounting is "
                                                                                   "constrained")
    reference: str = setting(file_type=str | int, parse=lambda v, where: str(v),
                             doc="the sensor it is given relative to")
    boresight_deg: tuple[float, float, float] | None = setting(
        None, doc="roll, pitch, heading of R_rel = R_BS(reference)^T R_BS(sensor): Rz(c) Ry(b) Rx(a)")
    boresight_sigma_deg: tuple[float, float, float] | None = setting(
        None, gt=0, default_doc="required with boresight_deg", doc="standard deviations of the three angles")
    lever_arm_m: tuple[float, float, float] | None = setting(
        None, doc="lever arm of the sensor minus the reference's (body frame)")
    lever_arm_sigma_m: tuple[float, float, float] | None = setting(
        None, gt=0, default_doc="required with lever_arm_m", doc="standard deviations of its three components")

    def check(self, where: str, sensors: dict[str, str]) -> None:
        """Both sensors exist and differ, each value has its sigma, and something is given."""
        for key in ("sensor", "reference"):
            name = getattr(self, key)
            if name not in sensors:
                raise ProjectFileError(f"{where}.{key}]: unknown sensor {name!r} (sensors: {', '.join(sensors)})")
        if self.sensor == self.reference:
            raise ProjectFileError(f"{where}.reference]: the sensor itself ({self.sensor!r}); expected another sensor")
        for value, sigma in (("boresight_deg", "boresight_sigma_deg"), ("lever_arm_m", "lever_arm_sigma_m")):
            if (getattr(self, value) is None) != (getattr(self, sigma) is None):
                given, missing = (value, sigma) if getattr(self, sigma) is None else (sigma, value)
                raise ProjectFileError(f"{where}.{missing}]: missing (a prior needs both {value} and its "
                                       f"{sigma}; {given} is given)")
        if self.boresight_deg is None and self.lever_arm_m is None:
            raise ProjectFileError(f"{where}]: expected boresight_deg (with boresight_sigma_deg) or lever_arm_m "
                                   "(with lever_arm_sigma_m)")


@dataclass(frozen=True)
class FlightLineKeys:
    """One ``[[flight_lines]]`` entry: a stretch of the platform's trajectory, shared by the strips that
    the platform's sensors recorded on it."""

    id: str = setting(file_type=str | int, parse=lambda v, where: str(v),
                      doc="the flight line's name, unique among flight lines and strips with their own trajectory")
    trajectory: str = setting(doc="the platform's GPS/IMU over the flight line: CSV, or SBET when the name ends "
                                  "in .out or .sbet")


@dataclass(frozen=True)
class StripKeys:
    """One ``[[strips]]`` entry."""

    id: str = setting(file_type=str | int, parse=lambda v, where: str(v),
                      doc="the strip's name, unique in the project (12 and \"12\" are the same)")
    sensor: str | None = setting(None, file_type=str | int, parse=lambda v, where: str(v),
                                 default_doc="the only sensor", doc="the sensor that recorded it ([[sensors]] id); "
                                                                    "required with several sensors")
    flight_line: str | None = setting(None, file_type=str | int, parse=lambda v, where: str(v),
                                      default_doc="its own", doc="the flight line it was recorded on "
                                      "([[flight_lines]] id), whose trajectory it shares; instead of `trajectory`")
    trajectory: str | None = setting(None, default_doc="required for images without flight_line",
                                     doc="the strip's GPS/IMU trajectory (a flight line of its own): CSV, or SBET "
                                         "when the name ends in .out or .sbet; a laser strip without one is adjusted "
                                         "trajectory-free")
    first_line_time: float | None = setting(None, unit="s", default_doc="",
                                            doc="images: time of line 0; exactly one of this and `line_times`")
    line_times: str | None = setting(None, default_doc="", doc="images: a line time table (docs/formats.md)")
    image: str | None = setting(None, doc="images: the image, any raster GDAL reads, rows = lines, columns = pixels")
    lines: int | None = setting(None, ge=1, unit="line", default_doc="the table's rows, else the image's height",
                                doc="images: number of lines")
    las: tuple[str, ...] | None = setting(None, file_type=str | tuple[str, ...],
                                          parse=lambda v, where: _names(v, where), default_doc="required for laser",
                                          doc="laser: the strip's returns, a LAS/LAZ file or a list of them")
    point_source_id: int | None = setting(None, unit="1", doc="laser: only the returns of this flight line")
    mission: str = setting("1", file_type=str | int, parse=lambda v, where: str(v),
                           doc="the mission (flight) the strip belongs to: GPS/IMU models per mission (strategy ME)")


def _names(value: str | list[str], where: str) -> tuple[str, ...]:
    names = (value,) if isinstance(value, str) else tuple(value)
    if not names:
        raise ProjectFileError(f"{where}: expected a file name or a list of them, found []")
    return names


@dataclass(frozen=True)
class ProjectFile:
    """The whole project.toml: these tables and nothing else."""

    project: ProjectKeys = setting(doc="the project")
    sensor: SensorKeys | None = setting(None, default_doc="", doc="the scanner of a one-sensor project")
    sensors: tuple[SensorKeys, ...] = setting((), doc="the scanners of a platform (instead of [sensor])")
    relative_mountings: tuple[RelativeMountingKeys, ...] = setting(
        (), doc="priors on the mounting of one sensor relative to another")
    flight_lines: tuple[FlightLineKeys, ...] = setting((), doc="trajectories shared by the strips recorded on them")
    strips: tuple[StripKeys, ...] = setting((), doc="one per strip (at least one)")
    adjustment: dict[str, Any] | None = setting(None, default_doc="{}",
                                                doc="laser: the patch search's settings (docs/formats.md, "
                                                    "scangeo.lidar.options.LaserOptions)")


def sensor_tables(pf: ProjectFile, file: Path | str) -> dict[str, tuple[SensorKeys, str]]:
    """The sensors of a checked project file by id, with the dotted place of each table: ``[sensor]`` is
    the one sensor of a one-sensor project (id ``""`` unless it names one), ``[[sensors]]`` a platform's."""
    if pf.sensor is not None:
        return {pf.sensor.id or "": (pf.sensor, f"{file} [sensor")}
    return {str(t.id): (t, f"{file} [sensors[{i}]") for i, t in enumerate(pf.sensors)}


def _check_sensors(pf: ProjectFile, file: Path | str) -> dict[str, tuple[SensorKeys, str]]:
    if (pf.sensor is None) == (not pf.sensors):
        raise ProjectFileError(f"{file}: expected one [sensor] table or [[sensors]] entries"
                               + (", not both" if pf.sensor is not None else ""))
    for i, t in enumerate(pf.sensors):
        if t.id is None:
            raise ProjectFileError(f"{file} [sensors[{i}].id]: missing (required: the strips name their sensor)")
    ids = [str(t.id) for t in pf.sensors]
    dup = sorted({i for i in ids if ids.count(i) > 1})
    if dup:
        raise ProjectFileError(f"{file} [sensors]: sensor id {dup[0]!r} appears more than once")
    sensors = sensor_tables(pf, file)
    for t, where in sensors.values():
        t.check(where)
    kinds = {sid: t.kind for sid, (t, _) in sensors.items()}
    for i, r in enumerate(pf.relative_mountings):
        r.check(f"{file} [relative_mountings[{i}]", kinds)
    pairs = [frozenset((r.sensor, r.reference)) for r in pf.relative_mountings]
    twice = [pair for pair in pairs if pairs.count(pair) > 1]
    if twice:
        raise ProjectFileError(f"{file} [relative_mountings]: the sensors {' and '.join(sorted(twice[0]))} are given "
                               "a relative mounting more than once")
    return sensors


def _check_strip(s: StripKeys, where: str, kind: str, flight_lines: set[str]) -> None:
    """One strip's keys against its sensor's kind and the flight lines."""
    if s.flight_line is not None:
        if s.flight_line not in flight_lines:
            raise ProjectFileError(f"{where}: flight_line {s.flight_line!r} is not a [[flight_lines]] id"
                                   + (f" (flight lines: {', '.join(sorted(flight_lines))})" if flight_lines else
                                      " (the project has no [[flight_lines]])"))
        if s.trajectory is not None:
            raise ProjectFileError(f"{where}: give trajectory or flight_line, not both (a strip on a flight line "
                                   "shares its trajectory)")
    if kind == "laser":
        if s.las is None:
            raise ProjectFileError(f"{where}: missing las (the strip's LAS/LAZ files; required for a laser)")
        given = [k for k in ("image", "first_line_time", "line_times", "lines") if getattr(s, k) is not None]
        if given:
            raise ProjectFileError(f"{where}: {given[0]} is not a key of a laser strip (las, trajectory, "
                                   "flight_line, point_source_id, mission)")
        return
    given = [k for k in ("las", "point_source_id") if getattr(s, k) is not None]
    if given:
        raise ProjectFileError(f"{where}: {given[0]} is a key of laser strips only (a sensor of kind \"laser\")")
    if s.trajectory is None and s.flight_line is None:
        raise ProjectFileError(f"{where}: missing trajectory (required for a {kind}), or flight_line: a "
                               "[[flight_lines]] id")
    if (s.first_line_time is None) == (s.line_times is None):
        raise ProjectFileError(f"{where}: give exactly one of first_line_time and line_times")


def read_project_file(data: dict, file: Path | str) -> ProjectFile:
    """Check a parsed project.toml; errors name the file and the dotted key."""
    pf: ProjectFile = read(ProjectFile, data, str(file))
    p = pf.project
    if p.geoid is not None and p.geoid_undulation_m is not None:
        raise ProjectFileError(f"{file} [project]: give geoid or geoid_undulation_m, not both")
    sensors = _check_sensors(pf, file)
    if not pf.strips:
        raise ProjectFileError(f"{file}: expected at least one [[strips]] entry")
    kinds = {sid: t.kind for sid, (t, _) in sensors.items()}
    images = sorted({k for k in kinds.values() if k in IMAGE_KINDS})
    if images and p.dtm is None:
        raise ProjectFileError(f"{file} [project.dtm]: missing (required for a {images[0]}; only a laser "
                               "project needs no DTM)")
    if "laser" not in kinds.values() and pf.adjustment is not None:
        raise ProjectFileError(f"{file} [adjustment]: a table of laser projects only (the adjustment of images is "
                               "set in variants.toml)")
    lines = [f.id for f in pf.flight_lines]
    dup = sorted({i for i in lines if lines.count(i) > 1})
    if dup:
        raise ProjectFileError(f"{file} [flight_lines]: flight line id {dup[0]!r} appears more than once")
    for i, s in enumerate(pf.strips):
        where = f"{file} [strips[{i}]] (id {s.id})"
        if s.sensor is None and len(sensors) > 1:
            raise ProjectFileError(f"{where}: missing sensor (required with several sensors: "
                                   f"{', '.join(sensors)})")
        name = s.sensor if s.sensor is not None else next(iter(sensors))
        if name not in sensors:
            raise ProjectFileError(f"{where}: sensor {name!r} is not a sensor of the project (sensors: "
                                   f"{', '.join(repr(k) for k in sensors)})")
        _check_strip(s, where, kinds[name], set(lines))
    ids = [s.id for s in pf.strips]
    dup = sorted({i for i in ids if ids.count(i) > 1})
    if dup:
        raise ProjectFileError(f"{file}: strip id {dup[0]!r} appears more than once")
    own = {s.id for s in pf.strips if s.flight_line is None}
    clash = sorted(own & set(lines))
    if clash:
        raise ProjectFileError(f"{file} [flight_lines]: flight line id {clash[0]!r} is also the id of a strip with a "
                               "trajectory of its own (the strip's own flight line): rename one")
    used = {s.flight_line for s in pf.strips}
    unused = [f for f in lines if f not in used]
    if unused:
        raise ProjectFileError(f"{file} [flight_lines]: flight line {unused[0]!r} has no strip (a strip names it "
                               "with flight_line)")
    return pf


__all__ = ["IMAGE_KINDS", "KINDS", "FlightLineKeys", "ProjectFile", "ProjectKeys", "RelativeMountingKeys", "SensorKeys",
           "StripKeys", "read_project_file", "sensor_tables"]
