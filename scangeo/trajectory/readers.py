"""Trajectory files: CSV (geodetic or map coordinates) and Applanix SBET binary; a CSV writer.

CSV (docs/formats.md): a header line naming the columns, then one record per line, comma- or
whitespace-separated. Columns (case-insensitive, quotes ignored, aliases in brackets):
``time`` [gpstime, gps_time, t], then either ``lat, lon, h`` [latitude, longitude, height, alt]
in degrees and ellipsoidal metres, or ``x, y, z`` [easting, northing; a height column serves as z]
in a map CRS with ellipsoidal ``z``; and ``roll, pitch, heading`` [azimuth, yaw] in degrees. Other
columns are ignored; a UTF-8 byte-order mark is allowed.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pyproj

from scangeo.atomic import atomic_path
from scangeo.errors import TrajectoryError
from scangeo.frames import parse_crs
from scangeo.textfile import read_text
from scangeo.trajectory.stream import GpsImuStream, check_times

ALIASES = {
    "time": ("time", "gpstime", "gps_time", "t"),
    "lat": ("lat", "latitude"),
    "lon": ("lon", "long", "longitude"),
    "h": ("h", "height", "alt", "altitude", "ellipsoidal_height"),
    "x": ("x", "easting"),
    "y": ("y", "northing"),
    "z": ("z",),
    "roll": ("roll",),
    "pitch": ("pitch",),
    "heading": ("heading", "azimuth", "yaw", "true_heading"),
}
GEODETIC = ("time", "lat", "lon", "h", "roll", "pitch", "heading")
MAPPED = ("time", "x", "y", "z", "roll", "pitch", "heading")

SBET_FIELDS = (
    "time", "lat", "lon", "alt", "vx", "vy", "vz", "roll", "pitch", "platform_heading", "wander",
    "ax", "ay", "az", "wx", "wy", "wz",
)
SBET_RECORD = np.dtype([(name, "<f8") for name in SBET_FIELDS])


def _columns(header: str, path) -> tuple[dict[str, int], str | None]:
    delimiter = "," if "," in header else None
    names = [c.strip().strip('"').strip("'").strip().lower() for c in header.split(delimiter)]
    found: dict[str, int] = {}
    for index, name in enumerate(names):
        for key, aliases in ALIASES.items():
            if name in aliases:
                if key in found:
                    raise TrajectoryError(f"{path} line 1: column {key!r} appears twice ({names})")
                found[key] = index
    if "x" in found and "y" in found and "z" not in found and "h" in found:
        found["z"] = found.pop("h")  # time,easting,northing,height,...: the height is z
    for wanted in (GEODETIC, MAPPED):
        if all(k in found for k in wanted):
            return {k: found[k] for k in wanted}, delimiter
    raise TrajectoryError(
        f"{path} line 1: expected the columns time,lat,lon,h,roll,pitch,heading or "
        f"time,x,y,z,roll,pitch,heading; found {','.join(names)}"
    )


def _parse_rows(path, lines: list[str], delimiter, columns: dict[str, int]) -> np.ndarray:
    """Parse data lines into a (n, 7) float array; errors name the file line."""
    width = max(columns.values()) + 1
    order = list(columns.values())
    try:  # fast path; the slow path below finds the offending line when this fails
        out = np.loadtxt(lines, delimiter=delimiter, usecols=order, ndmin=2, dtype=float, comments=None)
        if out.shape == (len(lines), len(order)):
            lines = []
    except ValueError:
        out = np.empty((len(lines), len(order)))
    for row, text in enumerate(lines):
        fields = text.split(delimiter)
        if len(fields) < width:
            raise TrajectoryError(
                f"{path} line {row + 2}: {len(fields)} fields, expected at least {width} (truncated record?)"
            )
        try:
            out[row] = [float(fields[i]) for i in order]
        except ValueError:
            name, bad = next((n, fields[i]) for n, i in columns.items() if not _is_float(fields[i]))
            raise TrajectoryError(f"{path} line {row + 2}: {name} {bad.strip()!r} is not a number") from None
    bad_rows = np.flatnonzero(~np.isfinite(out).all(axis=1))
    if bad_rows.size:
        r = bad_rows[0]
        name = list(columns)[int(np.flatnonzero(~np.isfinite(out[r]))[0])]
        raise TrajectoryError(
            f"{path} line {r + 2}: {name} is not a finite number ({out[r][list(columns).index(name)]})"
        )
    return out


def _is_float(text: str) -> bool:
    try:
        float(text)
        return True
    except ValueError:
        return False


def read_trajectory_csv(path, crs=None) -> GpsImuStream:
    """Read a trajectory CSV into a GPS/IMU stream.

    Parameters
    ----------
    path : the file.
    crs : the map CRS of x, y columns (z is ellipsoidal height); not needed for lat/lon/h.
    """
    path = Path(path)
    raw = read_text(path, "a trajectory CSV; an Applanix SBET needs the extension .out or .sbet",
                    TrajectoryError).splitlines()
    if not raw:
        raise TrajectoryError(f"{path}: the file is empty (expected a header line and records)")
    columns, delimiter = _columns(raw[0], path)
    lines = raw[1:]
    while lines and not lines[-1].strip():
        lines.pop()
    blank = [i for i, text in enumerate(lines) if not text.strip()]
    if blank:
        raise TrajectoryError(f"{path} line {blank[0] + 2}: empty line inside the records")
    if not lines:
        raise TrajectoryError(f"{path}: no records after the header line")
    data = _parse_rows(path, lines, delimiter, columns)
    check_times(data[:, 0], str(path), lambda i: f"line {i + 2}")
    if "lat" in columns:
        lat, lon, h = np.radians(data[:, 1]), np.radians(data[:, 2]), data[:, 3]
    else:
        if crs is None:
            raise TrajectoryError(
                f"{path}: x,y,z columns need the CRS of x and y (trajectory_crs or crs in project.toml, "
                "or the crs argument)"
            )
        to_geo = pyproj.Transformer.from_crs(parse_crs(crs, f"{path}: the CRS of x, y"), "EPSG:4326", always_xy=True)
        lon_deg, lat_deg = to_geo.transform(data[:, 1], data[:, 2])
        lat, lon, h = np.radians(lat_deg), np.radians(lon_deg), data[:, 3]
    roll, pitch, heading = (np.radians(data[:, k]) for k in (4, 5, 6))
    return GpsImuStream(data[:, 0], lat, lon, h, roll, pitch, np.unwrap(heading), source=str(path))


def read_sbet_records(path) -> np.ndarray:
    """The records of an Applanix SBET as they are: 17 little-endian float64 per record (fields
    :data:`SBET_FIELDS`; radians, metres, seconds). Errors name the file and the record: a
    truncated record, a value that is not finite, a time not after the previous one."""
    path = Path(path)
    try:
        size = path.stat().st_size
        raw = np.fromfile(path, dtype=SBET_RECORD, count=size // SBET_RECORD.itemsize)
    except OSError as exc:
        raise TrajectoryError(f"{path}: cannot read ({exc.strerror})") from exc
    rest = size % SBET_RECORD.itemsize
    if rest:
        raise TrajectoryError(
            f"{path} record {size // SBET_RECORD.itemsize + 1}: truncated ({rest} bytes of "
            f"{SBET_RECORD.itemsize}; an SBET record is 17 float64)"
        )
    if len(raw) == 0:
        raise TrajectoryError(f"{path}: no SBET records")
    for name in SBET_FIELDS:
        bad = np.flatnonzero(~np.isfinite(raw[name]))
        if bad.size:
            raise TrajectoryError(f"{path} record {bad[0] + 1}: {name} is not a finite number")
    check_times(raw["time"], str(path), lambda i: f"record {i + 1}")
    return raw


def read_sbet(path) -> GpsImuStream:
    """Read an Applanix SBET (:func:`read_sbet_records`) as a GPS/IMU stream.

    The true heading is the platform heading minus the wander angle.
    """
    raw = read_sbet_records(path)
    heading = np.unwrap(raw["platform_heading"] - raw["wander"])
    return GpsImuStream(
        raw["time"].copy(),
        raw["lat"].copy(),
        raw["lon"].copy(),
        raw["alt"].copy(),
        raw["roll"].copy(),
        raw["pitch"].copy(),
        heading,
        source=str(path),
    )


def read_trajectory(path, crs=None) -> GpsImuStream:
    """Read a trajectory file by its form: SBET binary (.out, .sbet) or CSV/text."""
    suffix = Path(path).suffix.lower()
    if suffix in (".out", ".sbet"):
        return read_sbet(path)
    return read_trajectory_csv(path, crs=crs)


def write_trajectory_csv(path, stream: GpsImuStream) -> None:
    """Write ``time,lat,lon,h,roll,pitch,heading`` (degrees, ellipsoidal m), atomically."""
    path = Path(path)
    data = np.column_stack(
        [
            stream.time,
            np.degrees(stream.lat),
            np.degrees(stream.lon),
            stream.h,
            np.degrees(stream.roll),
            np.degrees(stream.pitch),
            np.degrees(stream.heading),
        ]
    )
    with atomic_path(path) as tmp:
        np.savetxt(
            tmp,
            data,
            delimiter=",",
            header="time,lat,lon,h,roll,pitch,heading",
            comments="",
            fmt=["%.6f", "%.11f", "%.11f", "%.4f", "%.8f", "%.8f", "%.8f"],
        )
