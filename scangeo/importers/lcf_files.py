"""Resonon and Specim drone pushbrooms' navigation log (``.lcf``) and line times (``.times``), read and checked.

The specification (Resonon, inherited from Space Computer Corp.'s GeoReg; docs/formats.md):

``.lcf``
    space- or tab-separated text, one record per line, at least 10 columns:
    1 system time (s), 2 roll (rad, positive right wing up), 3 pitch (rad, positive nose up),
    4 heading (rad, zero at due north, pi/2 at due east), 5 longitude (deg, negative west),
    6 latitude (deg, negative south), 7 altitude (m; the specification says above the WGS-84
    ellipsoid), 8 and 9 zeros (placeholders), 10 a flag: 5 use the record, 0 do not use it.
    Columns after the 10th belong to the writer's GPS/IMU: with 11 columns an Athena's satellite
    count, with 18 a Piccolo's GPS year, month, day, hours, minutes, seconds and the acquisition
    computer's clock (s, us). Others are not read.
``.times``
    one time (s) per image line, of the camera computer's clock: another time base than the
    ``.lcf``'s. The first image line, the first ``.times`` entry and the first ``.lcf`` record are
    taken at the same moment (:mod:`scangeo.importers.lcf` applies it).

Conventions are applied by :func:`scangeo.importers.lcf.import_lcf`, not here. Every error names the
file and the line (1-based) and what was expected; a record flagged 0 ("do not use") is set aside,
and the reader says which.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from scangeo.errors import ImportFileError, MissingFileError
from scangeo.textfile import read_text

#: the ten columns of the specification
COLUMNS = ("time", "roll", "pitch", "heading", "longitude", "latitude", "altitude", "zero", "zero", "flag")
USE, DO_NOT_USE = 5, 0
#: the Piccolo GPS/IMU's columns 11-16 (its GPS date and time)
PICCOLO_DATE = ("year", "month", "day", "hours", "minutes", "seconds")


@dataclass(frozen=True)
class NavigationLog:
    """The records of an ``.lcf`` file that are to be used, as stored (radians, degrees, metres).

    ``file_line``: each kept record's line in the file (1-based); ``set_aside``: the lines of the
    records flagged 0 (do not use); ``columns``: fields per record; ``extra``: what the columns after
    the 10th said (their meaning is known only for 11 and 18 columns).
    """

    path: Path
    time: np.ndarray
    roll: np.ndarray
    pitch: np.ndarray
    heading: np.ndarray
    lon: np.ndarray
    lat: np.ndarray
    altitude: np.ndarray
    file_line: np.ndarray
    columns: int
    set_aside: tuple[int, ...] = ()
    extra: dict = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.time)

    @classmethod
    def read(cls, path) -> NavigationLog:
        path = Path(path)
        rows, numbers = _rows(path, "a navigation log (.lcf): 10 or more numbers a line, as lcf_spec says")
        width = len(rows[0])
        if width < len(COLUMNS):
            raise ImportFileError(f"{path} line {numbers[0]}: {width} fields, expected at least 10 (time, roll, "
                                  "pitch, heading, longitude, latitude, altitude, 0, 0, flag)")
        values = np.empty((len(rows), width))
        for i, (row, n) in enumerate(zip(rows, numbers)):
            if len(row) != width:
                raise ImportFileError(f"{path} line {n}: {len(row)} fields, expected {width} as on line {numbers[0]}"
                                      + (" (a truncated record?)" if len(row) < width else ""))
            values[i] = _floats(path, n, row, width)
        flag = values[:, 9]
        wrong = np.flatnonzero((flag != USE) & (flag != DO_NOT_USE))
        if wrong.size:
            i = int(wrong[0])
            raise ImportFileError(f"{path} line {numbers[i]}: column 10 is {flag[i]:g}, expected 5 (use) or 0 (do "
                                  "not use)")
        keep = flag == USE
        set_aside = tuple(int(numbers[i]) for i in np.flatnonzero(~keep))
        if not keep.any():
            raise ImportFileError(f"{path}: every record is flagged 0 (do not use)")
        v, lines = values[keep], np.asarray(numbers)[keep]
        _check_values(path, v, lines)
        return cls(path, v[:, 0].copy(), v[:, 1].copy(), v[:, 2].copy(), v[:, 3].copy(), v[:, 4].copy(),
                   v[:, 5].copy(), v[:, 6].copy(), lines, width, set_aside, _extra(v, width))


@dataclass(frozen=True)
class LineTimes:
    """The per-line times of a ``.times`` file (s, the camera computer's clock)."""

    path: Path
    time: np.ndarray

    def __len__(self) -> int:
        return len(self.time)

    @classmethod
    def read(cls, path) -> LineTimes:
        path = Path(path)
        rows, numbers = _rows(path, "line times (.times): one time a line")
        times = np.empty(len(rows))
        for i, (row, n) in enumerate(zip(rows, numbers)):
            if len(row) != 1:
                raise ImportFileError(f"{path} line {n}: {len(row)} fields, expected one time")
            times[i] = _floats(path, n, row, 1, names=("time",))[0]
        step = np.diff(times)
        bad = np.flatnonzero(step <= 0)
        if bad.size:
            i = int(bad[0]) + 1
            raise ImportFileError(f"{path} line {numbers[i]}: time {times[i]:.6f} is not after the previous "
                                  f"{times[i - 1]:.6f} (times must increase)")
        return cls(path, times)


def _rows(path: Path, expected: str) -> tuple[list[list[str]], list[int]]:
    if not path.is_file():
        raise MissingFileError(f"{path}: no such file ({expected})")
    text = read_text(path, expected, ImportFileError)
    rows, numbers = [], []
    for n, line in enumerate(text.splitlines(), start=1):
        fields = line.split()
        if fields:
            rows.append(fields)
            numbers.append(n)
    if not rows:
        raise ImportFileError(f"{path}: empty (expected {expected})")
    return rows, numbers


def _floats(path: Path, n: int, row: list[str], width: int, names=COLUMNS) -> list[float]:
    out = []
    for k, text in enumerate(row[:width]):
        name = names[k] if k < len(names) else f"column {k + 1}"
        try:
            value = float(text)
        except ValueError:
            raise ImportFileError(f"{path} line {n}: {name} {text!r} is not a number") from None
        if not math.isfinite(value):
            raise ImportFileError(f"{path} line {n}: {name} is not a finite number ({text})")
        out.append(value)
    return out


def _check_values(path: Path, v: np.ndarray, lines: np.ndarray) -> None:
    step = np.diff(v[:, 0])
    bad = np.flatnonzero(step <= 0)
    if bad.size:
        i = int(bad[0]) + 1
        raise ImportFileError(f"{path} line {lines[i]}: time {v[i, 0]:.6f} is not after the previous "
                              f"{v[i - 1, 0]:.6f} (times must increase)")
    limits = ((4, 180.0, "longitude", "degrees"), (5, 90.0, "latitude", "degrees"),
              (1, math.pi, "roll", "radians"), (2, math.pi / 2, "pitch", "radians"),
              (3, 2 * math.pi, "heading", "radians"))
    for col, limit, name, unit in limits:
        out = np.flatnonzero(np.abs(v[:, col]) > limit)
        if out.size:
            i = int(out[0])
            raise ImportFileError(f"{path} line {lines[i]}: {name} {v[i, col]:g} is outside +-{limit:g} "
                                  f"(expected {unit}, as lcf_spec says)")


def _extra(v: np.ndarray, width: int) -> dict:
    """What the columns after the 10th say, where their meaning is known."""
    if width == 11:
        sats = v[:, 10]
        return {"columns_after_10": "column 11: the satellite count (an Athena GPS/IMU)",
                "satellites": [int(sats.min()), int(sats.max())]}
    if width == 18:
        y, mo, d, h, mi, s = (v[0, 10 + k] for k in range(6))
        plausible = 1980 <= y <= 2200 and 1 <= mo <= 12 and 1 <= d <= 31 and 0 <= h < 24 and 0 <= mi < 60
        if plausible:
            return {"columns_after_10": "columns 11-18: a Piccolo's GPS date and time and the computer's clock",
                    "gps_date_time_first": f"{int(y):04d}-{int(mo):02d}-{int(d):02d}T{int(h):02d}:{int(mi):02d}:"
                                           f"{s:06.3f}"}
    return {"columns_after_10": f"{width - 10} columns after the 10th, not read (their meaning is not known for "
                                f"{width} columns)" if width > 10 else "none"}


__all__ = ["COLUMNS", "LineTimes", "NavigationLog"]
