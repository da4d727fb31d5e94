"""Summaries of the files of a project (``scangeo info``): what a file is and what it holds.

``summarise(path)`` detects the kind of a file by its extension and content and returns a plain,
JSON-serialisable dict with ``kind`` one of ``trajectory``, ``dtm``, ``image``, ``points``,
``ground`` or ``project``; ``summary_text`` renders it for people. Angles are in degrees and
ranges are ``{"min": .., "max": ..}`` (this is an edge of the library).
"""
from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any

import numpy as np

from scangeo.errors import InputFileError, ScangeoError
from scangeo.frames import geodetic_to_ecef
from scangeo.io.points import GroundPoints, ImagePoints
from scangeo.io.project import LaserSensor, Project, RelativeMounting, SensorConfig, StripConfig
from scangeo.sensors.models import Whiskbroom
from scangeo.textfile import read_text
from scangeo.trajectory.checks import strip_times_of, uncovered_lines
from scangeo.trajectory.readers import read_sbet, read_trajectory_csv

KINDS = ("trajectory", "dtm", "image", "points", "ground", "project")
SBET_SUFFIXES = (".out", ".sbet")
TEXT_SUFFIXES = (".csv", ".txt", ".tsv")
SBET_RECORD_BYTES = 17 * 8


def _range(values, digits: int) -> dict[str, float]:
    values = np.asarray(values, dtype=float)
    return {"min": round(float(np.min(values)), digits), "max": round(float(np.max(values)), digits)}


# ------------------------------------------------------------------------------------ detection
def detect_kind(path: Path) -> str:
    """The kind of a file or folder (one of ``KINDS``), from its extension and content."""
    if not path.exists():
        raise InputFileError(f"{path}: no such file or folder")
    if path.is_dir():
        if (path / "project.toml").exists():
            return "project"
        raise InputFileError(f"{path}: a folder without project.toml (expected a project folder)")
    suffix = path.suffix.lower()
    if suffix == ".toml":
        return "project"
    if suffix in SBET_SUFFIXES:
        return "trajectory"
    if suffix in TEXT_SUFFIXES:
        return _text_kind(path)
    raster = _raster_kind(path)
    if raster is not None:
        return raster
    if not _is_binary(path):
        return _text_kind(path)
    if path.stat().st_size and path.stat().st_size % SBET_RECORD_BYTES == 0:
        return "trajectory"
    raise InputFileError(
        f"{path}: cannot tell what this is (expected a project folder or project.toml, a trajectory "
        "CSV or SBET, a raster GDAL can read, points.csv or ground.csv)"
    )


def _is_binary(path: Path) -> bool:
    """True for a file with NUL bytes in its first 8 KiB (text never has them; an SBET does)."""
    with open(path, "rb") as f:
        return b"\0" in f.read(8192)


def _text_kind(path: Path) -> str:
    text = read_text(path, "a CSV with a header line; an Applanix SBET needs the extension .out or .sbet")
    header = text.split("\n", 1)[0]
    names = {c.strip().strip("\"'").strip().lower() for c in header.replace("\t", ",").replace(" ", ",").split(",")}
    if "point" in names:
        return "ground" if {"x", "y", "z"} <= names else "points"
    return "trajectory"


def _raster_kind(path: Path) -> str | None:
    """``dtm`` (one band, georeferenced, not bytes), ``image``, or None when GDAL cannot read it."""
    import rasterio

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)
            with rasterio.open(path) as src:
                georeferenced = src.crs is not None
                one_band = src.count == 1
                dtype = np.dtype(src.dtypes[0])
    except rasterio.errors.RasterioIOError:
        return None
    return "dtm" if one_band and georeferenced and dtype != np.uint8 else "image"


# ------------------------------------------------------------------------------------ summaries
def summarise(path, kind: str | None = None, crs: str | None = None) -> dict[str, Any]:
    """Summary of a trajectory, DTM, image, points file or project.

    Parameters
    ----------
    path : file or project folder.
    kind : one of ``KINDS`` to skip detection.
    crs : map CRS of a trajectory CSV with x, y, z columns.
    """
    path = Path(path)
    if not path.exists():
        raise InputFileError(f"{path}: no such file or folder")
    kind = kind or detect_kind(path)
    if kind not in KINDS:
        raise InputFileError(f"{path}: unknown kind {kind!r} (expected one of {', '.join(KINDS)})")
    if kind == "trajectory":
        return summarise_trajectory(path, crs=crs)
    if kind in ("dtm", "image"):
        return summarise_raster(path, as_dtm=kind == "dtm")
    if kind in ("points", "ground"):
        return summarise_points(path, kind)
    return summarise_project(path)


def summarise_trajectory(path: Path, crs: str | None = None) -> dict[str, Any]:
    """Records, rate, time span, extent (lat/lon degrees, ellipsoidal h) and attitude ranges."""
    sbet = path.suffix.lower() in SBET_SUFFIXES or _is_binary(path)
    s = read_sbet(path) if sbet else read_trajectory_csv(path, crs=crs)
    steps = np.diff(s.time)
    ecef = geodetic_to_ecef(s.lat, s.lon, s.h)
    legs = np.linalg.norm(np.diff(ecef, axis=0), axis=1)
    heading = np.degrees(s.heading)
    heading = heading - 360.0 * np.floor(heading[0] / 360.0)  # unwrapped, starting in [0, 360)
    return {
        "kind": "trajectory",
        "path": str(path),
        "format": "sbet" if sbet else "csv",
        "records": len(s),
        "rate_hz": round(s.rate_hz, 6),
        "time_s": {"start": round(float(s.time[0]), 6), "end": round(float(s.time[-1]), 6),
                   "duration": round(float(s.time[-1] - s.time[0]), 6)},
        "largest_gap_s": round(float(steps.max()), 6),
        "lat_deg": _range(np.degrees(s.lat), 9),
        "lon_deg": _range(np.degrees(s.lon), 9),
        "h_m": _range(s.h, 3),
        "roll_deg": _range(np.degrees(s.roll), 4),
        "pitch_deg": _range(np.degrees(s.pitch), 4),
        "heading_deg": _range(heading, 4),
        "length_m": round(float(legs.sum()), 3),
        "speed_mps": round(float(np.median(legs / steps)), 3),
    }


def _crs_fields(crs) -> dict[str, Any]:
    if crs is None:
        return {"crs": None}
    import pyproj

    c = pyproj.CRS.from_user_input(crs.to_wkt())
    return {"crs": c.name, "epsg": c.to_epsg()}


def summarise_raster(path: Path, as_dtm: bool) -> dict[str, Any]:
    """A DTM (size, CRS, resolution, height range, nodata fraction) or an image (lines x pixels x
    bands, data type)."""
    import rasterio

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)
            with rasterio.open(path) as src:
                out: dict[str, Any] = {"kind": "dtm" if as_dtm else "image", "path": str(path), "driver": src.driver}
                if as_dtm:
                    values = src.read(1, masked=True).astype(np.float64).filled(np.nan)
                    finite = values[np.isfinite(values)]
                    out.update({
                        "width": src.width, "height": src.height, **_crs_fields(src.crs),
                        "resolution": [float(src.res[0]), float(src.res[1])],
                        "bounds": [float(v) for v in src.bounds],
                        "dtype": src.dtypes[0], "nodata": src.nodata,
                        "height_m": ({**_range(finite, 3), "mean": round(float(finite.mean()), 3)}
                                     if finite.size else None),
                        "nodata_fraction": round(1.0 - finite.size / values.size, 6),
                    })
                else:
                    out.update(
                        {
                            "lines": src.height,
                            "pixels": src.width,
                            "bands": src.count,
                            "dtype": src.dtypes[0],
                            "band_names": [d or "" for d in src.descriptions] if any(src.descriptions) else [],
                            "nodata": src.nodata,
                            **_crs_fields(src.crs),
                        }
                    )
                return out
    except rasterio.errors.RasterioIOError as exc:
        raise InputFileError(f"{path}: cannot read the raster ({exc})") from exc


def summarise_points(path: Path, kind: str) -> dict[str, Any]:
    """Counts of image measurements per strip (points.csv) or of ground points per role (ground.csv)."""
    if kind == "points":
        pts = ImagePoints.read(path)
        strips, counts = np.unique(pts.strip.astype(str), return_counts=True)
        return {
            "kind": "points",
            "path": str(path),
            "measurements": len(pts),
            "points": len(set(pts.point)),
            "per_strip": dict(zip(strips.tolist(), counts.tolist())),
        }
    g = GroundPoints.read(path)
    roles, counts = np.unique(g.role.astype(str), return_counts=True)
    return {
        "kind": "ground",
        "path": str(path),
        "points": len(g),
        "per_role": dict(zip(roles.tolist(), counts.tolist())),
    }


def _scanner_summary(sensor: SensorConfig) -> dict[str, Any]:
    model = sensor.model
    return {
        "kind": sensor.kind,
        "pixels": model.pixels,
        "line_rate_hz": sensor.line_rate,
        **(
            {"fov_deg": round(float(np.degrees(model.fov)), 6), "per_pixel_timing": model.per_pixel_timing}
            if isinstance(model, Whiskbroom)
            else {}
        ),
        "lever_arm_m": [float(v) for v in sensor.mounting.lever_arm_B],
        "boresight_deg": [round(float(v), 9) for v in np.degrees(sensor.mounting.boresight)],
        "bands": list(sensor.bands),
    }


def _laser_sensor_summary(laser: LaserSensor) -> dict[str, Any]:
    return {"kind": "laser", "boresight_deg": list(laser.boresight_deg), "lever_arm_m": list(laser.lever_arm_m),
            "range_sigma_m": laser.range_sigma_m, **laser.info}


def summarise_project(path: Path) -> dict[str, Any]:
    """CRS, sensor, DTM, strips (lines, line and trajectory time spans), point counts; of a platform also
    its sensors, relative mountings and flight lines (which strips share each).

    A strip whose files cannot be read is reported with an ``error`` rather than stopping the summary.
    """
    project = Project.load(path)
    if project.is_laser and not project.is_platform:
        return _laser_project_summary(project)
    out: dict[str, Any] = {
        "kind": "platform project" if project.is_platform else "project",
        "path": str(project.root),
        "crs": project.crs,
        "geoid": str(project.geoid.path) if project.geoid.path else f"constant {project.geoid.constant:g} m",
        "origin": list(project.origin) if project.origin else None,
        "knot_spacing_s": project.knot_spacing,
    }
    if project.is_platform:
        out["sensors"] = [{"id": sid, **(_laser_sensor_summary(sc) if isinstance(sc, LaserSensor)
                                         else _scanner_summary(sc))} for sid, sc in project.sensors.items()]
        if project.relative_mountings:
            out["relative_mountings"] = [_relative_summary(r) for r in project.relative_mountings]
        out["flight_lines"] = [
            {"id": f.id, "trajectory": str(f.trajectory) if f.has_trajectory else None, "strips": list(f.strips),
             "sensors": list(dict.fromkeys(project.strip(sid).sensor for sid in f.strips))}
            for f in project.flight_lines.values()]
    else:
        out["sensor"] = _scanner_summary(project.sensor)
    try:
        out["dtm"] = summarise_raster(project.dtm_path, as_dtm=True)
    except ScangeoError as exc:
        out["dtm"] = {"path": str(project.dtm_file), "error": str(exc)}
    out["strips"] = [_strip_summary(project, s.id) if s in project.image_strips else _laser_strip_summary(project, s)
                     for s in project.strips]
    for name, kind in (("points.csv", "points"), ("ground.csv", "ground")):
        file = project.root / name
        if file.exists():
            try:
                out[kind] = summarise_points(file, kind)
            except ScangeoError as exc:
                out[kind] = {"path": str(file), "error": str(exc)}
    return out


def _las_summary(path: Path) -> dict[str, Any]:
    """A LAS/LAZ file's header: returns, point format, x, y, z extent."""
    import laspy  # start-up cost: laspy loads when a laser project's files are read

    try:
        with laspy.open(str(path)) as f:
            h = f.header
            return {"path": str(path), "returns": int(h.point_count), "point_format": int(h.point_format.id),
                    "x": [float(h.mins[0]), float(h.maxs[0])], "y": [float(h.mins[1]), float(h.maxs[1])],
                    "z": [float(h.mins[2]), float(h.maxs[2])]}
    except (OSError, ValueError, laspy.errors.LaspyException) as exc:
        return {"path": str(path), "error": f"cannot read the LAS header ({exc})"}


def _laser_strip_summary(project: Project, s: StripConfig) -> dict[str, Any]:
    entry: dict[str, Any] = {"id": s.id}
    if project.is_platform:
        entry.update(sensor=s.sensor, flight_line=s.flight_line)
    entry.update(mission=s.mission, files=[_las_summary(f) for f in s.las])
    if s.point_source_id is not None:
        entry["point_source_id"] = s.point_source_id
    if s.has_trajectory:
        try:
            entry["trajectory"] = summarise_trajectory(s.trajectory, project.trajectory_crs or project.crs)
        except ScangeoError as exc:
            entry["trajectory"] = {"path": str(s.trajectory), "error": str(exc)}
    errors = [f["error"] for f in entry["files"] if "error" in f]
    if errors:
        entry["error"] = errors[0]
    return entry


def _relative_summary(r: RelativeMounting) -> dict[str, Any]:
    out: dict[str, Any] = {"sensor": r.sensor, "reference": r.reference}
    if r.boresight is not None and r.boresight_sigma is not None:
        out["boresight_deg"] = [round(float(v), 9) for v in np.degrees(r.boresight)]
        out["boresight_sigma_deg"] = [round(float(v), 9) for v in np.degrees(r.boresight_sigma)]
    if r.lever_arm is not None and r.lever_arm_sigma is not None:
        out["lever_arm_m"] = [float(v) for v in r.lever_arm]
        out["lever_arm_sigma_m"] = [float(v) for v in r.lever_arm_sigma]
    return out


def _laser_project_summary(project: Project) -> dict[str, Any]:
    """A laser project: CRS, the scanner, per strip its LAS/LAZ files' headers, mission and trajectory."""
    return {"kind": "laser project", "path": str(project.root), "crs": project.crs,
            "origin": list(project.origin) if project.origin else None,
            "sensor": _laser_sensor_summary(project.laser),
            "strips": [_laser_strip_summary(project, s) for s in project.strips]}


def _strip_summary(project, strip_id: str) -> dict[str, Any]:
    cfg = project.strip(strip_id)
    out: dict[str, Any] = {"id": strip_id}
    if project.is_platform:
        out.update(sensor=cfg.sensor, flight_line=cfg.flight_line)
    out.update(image=str(cfg.image) if cfg.image else None, trajectory=str(cfg.trajectory))
    try:
        n = project.n_lines(strip_id)
        timing = project.timing(strip_id)
        first, last = (float(v) for v in timing.time_of_line(np.array([0.0, n - 1.0])))
        out.update({"lines": n, "line_time_s": {"start": round(first, 6), "end": round(last, 6)}})
        stream = project.stream(strip_id, check=False)  # coverage is reported below, not raised
        out.update(
            {
                "trajectory_records": len(stream),
                "trajectory_time_s": {
                    "start": round(float(stream.time[0]), 6),
                    "end": round(float(stream.time[-1]), 6),
                },
                "covered": uncovered_lines(stream, strip_times_of(project, strip_id)).size == 0,
            }
        )
    except ScangeoError as exc:
        out["error"] = str(exc)
    return out


# ------------------------------------------------------------------------------------ text
def summary_text(summary: dict[str, Any]) -> str:
    """The summary as indented ``key: value`` lines."""
    lines = [f"{summary['kind']}: {summary['path']}"]
    _render(lines, {k: v for k, v in summary.items() if k not in ("kind", "path")}, "  ")
    return "\n".join(lines)


def _value(v: Any) -> str:
    if isinstance(v, dict) and set(v) >= {"min", "max"}:
        extra = "".join(f", {k} {_value(x)}" for k, x in v.items() if k not in ("min", "max"))
        return f"{_value(v['min'])} .. {_value(v['max'])}{extra}"
    if isinstance(v, dict) and set(v) >= {"start", "end"}:
        extra = "".join(f", {k} {_value(x)}" for k, x in v.items() if k not in ("start", "end"))
        return f"{_value(v['start'])} .. {_value(v['end'])}{extra}"
    if isinstance(v, float):
        return repr(v)
    if isinstance(v, list):
        return ", ".join(_value(x) for x in v) if v else "-"
    if v is None:
        return "-"
    return str(v)


def _render(lines: list[str], data: dict[str, Any], indent: str) -> None:
    width = max((len(k) for k in data), default=0)
    for key, value in data.items():
        if isinstance(value, list) and value and all(isinstance(x, dict) for x in value):
            lines.append(f"{indent}{key}:")
            for item in value:
                head = next(iter(item))
                lines.append(f"{indent}  - {head} {_value(item[head])}")
                _render(lines, {k: v for k, v in item.items() if k != head}, indent + "    ")
        elif isinstance(value, dict) and not (set(value) >= {"min", "max"} or set(value) >= {"start", "end"}):
            lines.append(f"{indent}{key}:")
            _render(lines, value, indent + "  ")
        else:
            lines.append(f"{indent}{key:<{width}}  {_value(value)}")
