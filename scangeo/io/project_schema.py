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
    """The ``[sensor]`` table; whiskbroom, pushbroom and laser keys exist only for their kind."""

    kind: str = setting(choices=KINDS, doc="the scanner type: a line scanner recording images (whiskbroom, "
                                          "pushbroom) or a laser scanner recording returns (laser)")
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
class StripKeys:
    """One ``[[strips]]`` entry."""

    id: str = setting(file_type=str | int, parse=lambda v, where: str(v),
                      doc="the strip's name, unique in the project (12 and \"12\" are the same)")
    trajectory: str | None = setting(None, default_doc="required for images",
                                     doc="the strip's GPS/IMU trajectory: CSV, or SBET when the name ends in .out or "
                                         ".sbet; a laser strip without one is adjusted trajectory-free")
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
    sensor: SensorKeys = setting(doc="the scanner")
    strips: tuple[StripKeys, ...] = setting((), doc="one per strip (at least one)")
    adjustment: dict[str, Any] | None = setting(None, default_doc="{}",
                                                doc="laser: the patch search's settings (docs/formats.md, "
                                                    "scangeo.lidar.options.LaserOptions)")


def read_project_file(data: dict, file: Path | str) -> ProjectFile:
    """Check a parsed project.toml; errors name the file and the dotted key."""
    pf: ProjectFile = read(ProjectFile, data, str(file))
    p = pf.project
    if p.geoid is not None and p.geoid_undulation_m is not None:
        raise ProjectFileError(f"{file} [project]: give geoid or geoid_undulation_m, not both")
    pf.sensor.check(f"{file} [sensor")
    if not pf.strips:
        raise ProjectFileError(f"{file}: expected at least one [[strips]] entry")
    laser = pf.sensor.kind == "laser"
    if not laser and p.dtm is None:
        raise ProjectFileError(f"{file} [project.dtm]: missing (required for a {pf.sensor.kind}; only a laser "
                               "project needs no DTM)")
    if not laser and pf.adjustment is not None:
        raise ProjectFileError(f"{file} [adjustment]: a table of laser projects only (the adjustment of images is "
                               "set in variants.toml)")
    for i, s in enumerate(pf.strips):
        where = f"{file} [strips[{i}]] (id {s.id})"
        if laser:
            if s.las is None:
                raise ProjectFileError(f"{where}: missing las (the strip's LAS/LAZ files; required for a laser)")
            given = [k for k in ("image", "first_line_time", "line_times", "lines") if getattr(s, k) is not None]
            if given:
                raise ProjectFileError(f"{where}: {given[0]} is not a key of a laser strip (las, trajectory, "
                                       "point_source_id, mission)")
            continue
        given = [k for k in ("las", "point_source_id") if getattr(s, k) is not None]
        if given:
            raise ProjectFileError(f"{where}: {given[0]} is a key of laser strips only ([sensor] kind = \"laser\")")
        if s.trajectory is None:
            raise ProjectFileError(f"{where}: missing trajectory (required for a {pf.sensor.kind})")
        if (s.first_line_time is None) == (s.line_times is None):
            raise ProjectFileError(f"{where}: give exactly one of first_line_time and line_times")
    ids = [s.id for s in pf.strips]
    dup = sorted({i for i in ids if ids.count(i) > 1})
    if dup:
        raise ProjectFileError(f"{file}: strip id {dup[0]!r} appears more than once")
    return pf


__all__ = ["IMAGE_KINDS", "KINDS", "ProjectFile", "ProjectKeys", "SensorKeys", "StripKeys", "read_project_file"]
