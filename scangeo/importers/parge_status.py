"""PARGE status files (``.gcs``): what a PARGE project holds, read and checked.

A PARGE status file is an IDL SAVE file (read with :func:`scipy.io.readsav`) of structures and
arrays. The parts scangeo reads (names as PARGE 3.4 writes them):

``image``
    ``N_P``, ``N_L``, ``N_C`` (pixels, lines, bands), ``SCANFREQ`` (PARGE's line rate, Hz),
    ``STARTTIME`` (hours of the day), ``DESCR``-like header text in ``result.DESCR`` (a HySpex
    header carries ``Frameperiod = N`` in microseconds).
``rollarr``, ``pitcharr``, ``headarr`` (``yawarr``)
    one attitude record per image line, radians, in PARGE's conventions (see
    :mod:`scangeo.importers.parge`).
``gpsarr``, ``navarr``
    per line: longitude, latitude (deg), altitude (m); and map easting, northing (m), height (m).
``sensarr``
    per pixel: index, across-track look angle (rad), along-track look angle (rad), and a fourth
    column.
``gcparr``
    per ground control point: pixel, line, easting, northing, height, used flag (1 used, 0 not).
    A row of six zeros is PARGE's empty list, not a GCP: such rows are dropped (``placeholder_gcps``
    counts them).
``aux[k].OFFSET``
    PARGE's offsets of the navigation channels: 0 roll, 1 pitch, 2 yaw, 3 heading (rad),
    4 easting, 5 northing, 6 height (m).
``pr.HSRY``
    the processing history, newest first; ``GC_CROSSBORE`` lines carry boresight results and
    ``M_OFFSET_EVENT`` lines the offsets a user added (degrees).

Everything is checked here: a file that is not an IDL SAVE file, is truncated, is an IDL SAVE file
but not a PARGE status, lacks an array, or has arrays of inconsistent lengths, raises
:class:`~scangeo.errors.ParGeFileError` naming the file and what was expected.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.io import readsav

from scangeo.errors import MissingFileError, ParGeFileError

#: aux entries that hold the navigation channels' offsets (index in ``aux``)
AUX_CHANNELS = {"roll": 0, "pitch": 1, "yaw": 2, "heading": 3, "easting": 4, "northing": 5, "height": 6}

_STRUCTURES = ("image", "sensor", "aux", "pr")
_ARRAYS = ("rollarr", "pitcharr", "headarr", "gpsarr", "navarr", "sensarr")
_HISTORY_OFFSET = re.compile(r"M_OFFSET_EVENT:\s*Offsetted\s+(\w+)\s+Parameter\s+by\s+([-+0-9.eE]+)\s*deg")
_HISTORY_CROSSBORE = re.compile(r"GC_CROSSBORE:\s*Resulting boresights \(rph\) \[deg\]:\s*"
                                r"([-+0-9.eE]+),\s*([-+0-9.eE]+),\s*([-+0-9.eE]+)")
_FRAME_PERIOD = re.compile(r"Frameperiod\s*=\s*([0-9.]+)")


@dataclass(frozen=True)
class OffsetEvent:
    """One change of PARGE's attitude offsets recorded in the history.

    ``kind`` is ``crossbore`` (a boresight result, all three angles) or ``offset`` (one angle a user
    offset). ``degrees`` holds the change of (roll, pitch, heading) in degrees, as PARGE prints it.
    """

    time: str
    kind: str
    degrees: tuple[float, float, float]
    text: str


@dataclass(frozen=True)
class GroundControl:
    """PARGE's ground control points: image pixel and line, map E, N, Z, PARGE's used flag, and each
    one's row in ``gcparr`` (0-based; placeholder rows of zeros are not among them)."""

    pixel: np.ndarray
    line: np.ndarray
    xyz: np.ndarray
    used: np.ndarray
    row: np.ndarray

    def __len__(self) -> int:
        return len(self.pixel)


@dataclass(frozen=True)
class ParGeStatus:
    """The contents of a PARGE status file that a scangeo project needs (module docstring).

    Angles are radians, heights metres, as stored; conventions are applied by
    :func:`scangeo.importers.parge.import_parge`, not here.
    """

    path: Path
    image_name: str
    camera: str
    pixels: int
    lines: int
    bands: int
    scan_frequency_hz: float
    frame_period_us: float | None
    start_hours: float
    roll: np.ndarray
    pitch: np.ndarray
    heading: np.ndarray
    lon: np.ndarray
    lat: np.ndarray
    altitude: np.ndarray
    easting: np.ndarray
    northing: np.ndarray
    height: np.ndarray
    look_across: np.ndarray
    look_along: np.ndarray
    gcps: GroundControl
    offsets: dict[str, float]
    sensor_boresight: tuple[float, float, float]
    crs_wkt: str
    dem_name: str
    history: tuple[str, ...] = ()
    events: tuple[OffsetEvent, ...] = field(default=())
    sensor_file: str = ""
    sensor_description: str = ""
    date: str = ""
    placeholder_gcps: int = 0

    @classmethod
    def read(cls, path) -> ParGeStatus:
        """Read and check a PARGE status file; errors name the file and what is wrong."""
        path = Path(path)
        data = _read_save(path)
        missing = [s for s in _STRUCTURES if s not in data]
        if len(missing) == len(_STRUCTURES):
            raise ParGeFileError(f"{path}: an IDL SAVE file, but not a PARGE status (none of the structures "
                                 f"{', '.join(_STRUCTURES)}; found {', '.join(sorted(data)) or 'nothing'})")
        if missing:
            raise ParGeFileError(f"{path}: not a complete PARGE status: missing the structure "
                                 f"{', '.join(missing)}")
        absent = [a for a in _ARRAYS if a not in data]
        if absent:
            raise ParGeFileError(f"{path}: missing the array{'s' if len(absent) > 1 else ''} {', '.join(absent)} "
                                 "(a PARGE status of a line with navigation has rollarr, pitcharr, headarr, "
                                 "gpsarr, navarr and sensarr)")
        image, sensor, pr = data["image"][0], data["sensor"][0], data["pr"][0]
        pixels, lines = _int(image, "N_P", path), _int(image, "N_L", path)
        bands = _int(image, "N_C", path)
        columns = {"rollarr": 1, "pitcharr": 1, "headarr": 1, "gpsarr": 3, "navarr": 3}
        arrays = {}
        for name, ncol in columns.items():
            arrays[name] = _array(data, name, (lines, ncol), path, f"one record per image line ({lines} lines)")
        sens = _array(data, "sensarr", (pixels, None), path, f"one row per pixel ({pixels} pixels)")
        if sens.shape[1] < 3:
            raise ParGeFileError(f"{path}: sensarr has {sens.shape[1]} columns, expected at least 3 "
                                 "(pixel, across-track angle, along-track angle)")
        if not np.array_equal(sens[:, 0], np.arange(pixels)):
            raise ParGeFileError(f"{path}: sensarr's first column is not the pixel index 0..{pixels - 1}")
        gcps, placeholders = _ground_control(data, pixels, lines, path)
        history = tuple(_text(h) for h in np.atleast_1d(pr["HSRY"]) if _text(h).strip())
        result = data.get("result")
        descr = _text(result[0]["DESCR"]) if result is not None and "DESCR" in result.dtype.names else ""
        period = _FRAME_PERIOD.search(descr)
        crs_wkt = _crs_wkt(data, path)
        dem = data.get("dem")
        return cls(
            path=path,
            image_name=_text(image["NAME"]),
            camera=_camera(descr, _text(image["NAME"])),
            pixels=pixels, lines=lines, bands=bands,
            scan_frequency_hz=float(image["SCANFREQ"]),
            frame_period_us=float(period.group(1)) if period else None,
            start_hours=float(image["STARTTIME"]),
            roll=arrays["rollarr"][:, 0], pitch=arrays["pitcharr"][:, 0], heading=arrays["headarr"][:, 0],
            lon=arrays["gpsarr"][:, 0], lat=arrays["gpsarr"][:, 1], altitude=arrays["gpsarr"][:, 2],
            easting=arrays["navarr"][:, 0], northing=arrays["navarr"][:, 1], height=arrays["navarr"][:, 2],
            look_across=sens[:, 1].copy(), look_along=sens[:, 2].copy(),
            gcps=gcps,
            offsets=_offsets(data["aux"], path),
            sensor_boresight=tuple(float(v) for v in np.asarray(sensor["BORESIGHT"], float)[:3]),  # type: ignore[arg-type]
            crs_wkt=crs_wkt,
            dem_name=_text(dem[0]["NAME"]) if dem is not None else "",
            history=history,
            events=tuple(parse_events(history)),
            sensor_file=_text(sensor["FILE"]) if "FILE" in sensor.dtype.names else "",
            sensor_description=_text(sensor["DESCR"]) if "DESCR" in sensor.dtype.names else "",
            date=_text(image["DATE"]) if "DATE" in image.dtype.names else "",
            placeholder_gcps=placeholders,
        )

    @property
    def line_rate_hz(self) -> float:
        """The line rate: the camera's frame period where the header gives one, else PARGE's SCANFREQ."""
        return 1e6 / self.frame_period_us if self.frame_period_us else self.scan_frequency_hz

    @property
    def start_seconds(self) -> float:
        """Time of line 0 in seconds of the day (PARGE's STARTTIME is in hours)."""
        return self.start_hours * 3600.0


def parse_events(history) -> list[OffsetEvent]:
    """The offset changes of a PARGE history (newest first), oldest first.

    ``GC_CROSSBORE`` lines give a boresight result (roll, pitch, heading in degrees); ``M_OFFSET_EVENT``
    lines one angle a user offset (``Offsetted Roll Parameter by 0.013deg``)."""
    events = []
    for line in history:
        stamp = line.split()[0] if line.split() else ""
        m = _HISTORY_CROSSBORE.search(line)
        if m:
            events.append(OffsetEvent(stamp, "crossbore", tuple(float(v) for v in m.groups()), line.strip()))  # type: ignore[arg-type]
            continue
        m = _HISTORY_OFFSET.search(line)
        if m:
            axis = {"roll": 0, "pitch": 1, "heading": 2, "yaw": 2}.get(m.group(1).lower())
            if axis is None:
                continue
            change = [0.0, 0.0, 0.0]
            change[axis] = float(m.group(2))
            events.append(OffsetEvent(stamp, "offset", tuple(change), line.strip()))  # type: ignore[arg-type]
    return events[::-1]


def _read_save(path: Path) -> dict:
    if not path.exists():
        raise MissingFileError(f"{path}: no such PARGE status file")
    head = path.read_bytes()[:2]
    if head != b"SR":
        raise ParGeFileError(f"{path}: not an IDL SAVE file (a PARGE status .gcs starts with 'SR', "
                             f"found {head!r})")
    try:
        return readsav(str(path), python_dict=True, verbose=False)
    except Exception as exc:  # scipy raises struct.error, ValueError, EOFError, zlib.error ... on a bad file
        raise ParGeFileError(f"{path}: cannot read the IDL SAVE file: truncated or damaged "
                             f"({type(exc).__name__}: {exc})") from None


def _text(value) -> str:
    return value.decode("utf-8", errors="replace") if isinstance(value, bytes) else str(value)


def _int(record, key: str, path: Path) -> int:
    if key not in record.dtype.names:
        raise ParGeFileError(f"{path}: image.{key} is missing")
    value = int(record[key])
    if value < 1:
        raise ParGeFileError(f"{path}: image.{key} is {value}, expected a positive count")
    return value


def _array(data: dict, name: str, shape: tuple[int, int | None], path: Path, expected: str) -> np.ndarray:
    a = np.asarray(data[name], dtype=float)
    if a.ndim == 1:
        a = a[:, None]
    if a.ndim != 2 or a.shape[0] != shape[0] or (shape[1] is not None and a.shape[1] != shape[1]):
        want = f"({shape[0]}, {shape[1]})" if shape[1] is not None else f"({shape[0]}, n)"
        raise ParGeFileError(f"{path}: {name} has shape {a.shape}, expected {want}: {expected}")
    bad = ~np.isfinite(a)
    if bad.any():
        row = int(np.argwhere(bad)[0][0])
        raise ParGeFileError(f"{path}: {name} row {row} is not finite")
    return a


def _ground_control(data: dict, pixels: int, lines: int, path: Path) -> tuple[GroundControl, int]:
    """The GCPs, and the number of all-zero rows (PARGE's empty list) dropped."""
    empty = GroundControl(np.zeros(0), np.zeros(0), np.zeros((0, 3)), np.zeros(0, bool), np.zeros(0, int))
    if "gcparr" not in data or data["gcparr"] is None or np.size(data["gcparr"]) == 0:
        return empty, 0
    g = np.atleast_2d(np.asarray(data["gcparr"], float))
    if g.shape[1] < 6:
        raise ParGeFileError(f"{path}: gcparr has {g.shape[1]} columns, expected 6 (pixel, line, E, N, Z, used)")
    placeholder = np.all(g[:, :6] == 0, axis=1)
    rows = np.flatnonzero(~placeholder)
    g = g[~placeholder]
    if not len(g):
        return empty, int(placeholder.sum())
    for i, row in zip(rows, g):
        if not np.isfinite(row[:6]).all():
            raise ParGeFileError(f"{path}: gcparr GCP {i + 1} has a value that is not finite")
        if not (-0.5 <= row[0] <= pixels - 0.5 and -0.5 <= row[1] <= lines - 0.5):
            raise ParGeFileError(f"{path}: gcparr GCP {i + 1} at pixel {row[0]:g}, line {row[1]:g} is outside the "
                                 f"line's image (pixels 0..{pixels - 1}, lines 0..{lines - 1})")
    return (GroundControl(g[:, 0].copy(), g[:, 1].copy(), g[:, 2:5].copy(), g[:, 5] > 0.5, rows),
            int(placeholder.sum()))


def _offsets(aux, path: Path) -> dict[str, float]:
    if len(aux) < 7 or "OFFSET" not in aux.dtype.names:
        raise ParGeFileError(f"{path}: aux has {len(aux)} entries, expected 7 navigation channels with OFFSET "
                             "(roll, pitch, yaw, heading, easting, northing, height)")
    return {name: float(aux[k]["OFFSET"]) for name, k in AUX_CHANNELS.items()}


def _crs_wkt(data: dict, path: Path) -> str:
    """The map CRS of navarr and the GCPs: the WKT PARGE keeps in pr.AUX2 (or result/dem.AUX2)."""
    for struct in ("pr", "result", "dem"):
        rec = data.get(struct)
        if rec is not None and "AUX2" in rec.dtype.names:
            text = _text(rec[0]["AUX2"]).strip()
            if text.startswith(("PROJCS", "GEOGCS", "PROJCRS")):
                return text
    raise ParGeFileError(f"{path}: no map CRS (expected a WKT in pr.AUX2, result.AUX2 or dem.AUX2)")


def _camera(descr: str, image_name: str) -> str:
    m = re.search(r"ID\s*=\s*(\S+)", descr)
    if m:
        return m.group(1)
    return Path(image_name.replace("\\", "/")).stem


__all__ = ["AUX_CHANNELS", "GroundControl", "OffsetEvent", "ParGeStatus", "parse_events"]
