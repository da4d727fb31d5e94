"""Plausibility checks of a strip's GPS/IMU trajectory before anything is computed with it.

* **Coverage** (error): every image line's navigation times (line time + mounting time offset, +- the
  scan's per-pixel time offsets) must lie within the trajectory's first and last record, to the
  ``TIME_RESOLUTION_S`` that trajectory and project files give times to.
* **Gaps** (error): no interval between records longer than ``max(MIN_GAP_S, GAP_FACTOR x median
  interval)`` over the strip's lines (a gap outside them, in a turn, does no harm).
* **Attitudes** (warning): the heading is compared with the course over ground from the positions
  wherever the aircraft moves faster than ``MIN_SPEED``; a median difference above ``MAX_CRAB_DEG``
  is reported, with radians-read-as-degrees named as the cause when the values taken as radians
  agree with the course. Roll and pitch beyond ``MAX_ROLL_DEG`` / ``MAX_PITCH_DEG`` are reported too.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from scangeo.errors import TrajectoryError
from scangeo.frames import WGS84_A, WGS84_E2
from scangeo.trajectory.stream import GpsImuStream

log = logging.getLogger(__name__)

MIN_GAP_S = 1.0
GAP_FACTOR = 20.0
MIN_SPEED = 15.0  # m/s: slower samples (taxiing, hovering) are not compared with the course
MAX_CRAB_DEG = 30.0
MAX_ROLL_DEG = 60.0
MAX_PITCH_DEG = 30.0
#: Times in trajectory CSVs and project.toml are written to the microsecond: a line that ends within it
#: of the last record is covered (one navigation record per line, as imported lines have, ends exactly
#: at the last line).
TIME_RESOLUTION_S = 1e-6

_warned: set[str] = set()


@dataclass(frozen=True)
class StripTimes:
    """What a strip needs of its trajectory: navigation times of its lines.

    ``line_times`` (n,) s are the sensor times of lines 0..n-1; the navigation times of line l span
    ``line_times[l] + offset - half_scan .. line_times[l] + offset + half_scan``.
    """

    strip_id: str
    line_times: np.ndarray
    offset: float = 0.0
    half_scan: float = 0.0


def _ranges(lines: np.ndarray) -> str:
    """``3-7, 12`` of sorted line numbers."""
    parts = []
    start = prev = int(lines[0])
    for line in (int(v) for v in lines[1:]):
        if line != prev + 1:
            parts.append(f"{start}-{prev}" if prev > start else f"{start}")
            start = line
        prev = line
    parts.append(f"{start}-{prev}" if prev > start else f"{start}")
    return ", ".join(parts)


def uncovered_lines(stream: GpsImuStream, strip: StripTimes) -> np.ndarray:
    """The lines of the strip whose navigation times the trajectory does not cover (to TIME_RESOLUTION_S)."""
    first = strip.line_times + strip.offset - strip.half_scan
    last = strip.line_times + strip.offset + strip.half_scan
    t0, t1 = float(stream.time[0]), float(stream.time[-1])
    return np.flatnonzero((first < t0 - TIME_RESOLUTION_S) | (last > t1 + TIME_RESOLUTION_S))


def check_coverage(stream: GpsImuStream, strip: StripTimes) -> None:
    """Raise TrajectoryError naming the lines of the strip the trajectory does not cover."""
    out = uncovered_lines(stream, strip)
    if out.size:
        first = strip.line_times + strip.offset - strip.half_scan
        last = strip.line_times + strip.offset + strip.half_scan
        t0, t1 = float(stream.time[0]), float(stream.time[-1])
        raise TrajectoryError(
            f"trajectory {stream.source} does not cover lines {_ranges(out)} of strip {strip.strip_id} "
            f"(it runs from {t0:.3f} to {t1:.3f} s; the strip's lines need {first[0]:.3f} to {last[-1]:.3f} s)"
        )


def check_gaps(stream: GpsImuStream, strip: StripTimes) -> None:
    """Raise TrajectoryError at the first gap between records that falls over the strip's lines."""
    time = np.asarray(stream.time)
    steps = np.diff(time)
    limit = max(MIN_GAP_S, GAP_FACTOR * float(np.median(steps)))
    lo = strip.line_times[0] + strip.offset - strip.half_scan
    hi = strip.line_times[-1] + strip.offset + strip.half_scan
    gaps = np.flatnonzero((steps > limit) & (time[1:] > lo) & (time[:-1] < hi))
    if gaps.size:
        i = int(gaps[0])
        nav = strip.line_times + strip.offset
        inside = np.flatnonzero((nav + strip.half_scan > time[i]) & (nav - strip.half_scan < time[i + 1]))
        lines = f"; lines {_ranges(inside)} of strip {strip.strip_id} fall into it" if inside.size else ""
        raise TrajectoryError(
            f"trajectory {stream.source}: gap of {steps[i]:.1f} s at time {time[i]:.3f} "
            f"(records {i + 1} and {i + 2}; the median interval is {np.median(steps):.3g} s){lines}"
        )


def attitude_findings(stream: GpsImuStream) -> list[str]:
    """Implausible attitudes of a trajectory, as messages naming its file (empty when plausible)."""
    found = []
    lat, lon, time = np.asarray(stream.lat), np.asarray(stream.lon), np.asarray(stream.time)
    s2 = np.sin(lat) ** 2
    r_n = WGS84_A / np.sqrt(1.0 - WGS84_E2 * s2)
    r_m = r_n * (1.0 - WGS84_E2) / (1.0 - WGS84_E2 * s2)
    north = np.diff(lat) * 0.5 * (r_m[1:] + r_m[:-1])
    east = np.diff(lon) * 0.5 * (r_n[1:] * np.cos(lat[1:]) + r_n[:-1] * np.cos(lat[:-1]))
    dt = np.diff(time)
    moving = np.hypot(north, east) / dt > MIN_SPEED
    if moving.sum() >= 10:
        course = np.arctan2(east, north)[moving]
        heading = 0.5 * (stream.heading[1:] + stream.heading[:-1])[moving]

        def median_difference(h):
            return float(np.degrees(np.median(np.abs(np.angle(np.exp(1j * (h - course)))))))

        as_read = median_difference(heading)
        if as_read > MAX_CRAB_DEG:
            as_radians = median_difference(np.degrees(heading))  # file values were radians, read as degrees
            if as_radians <= MAX_CRAB_DEG:
                cause = (f"the attitudes look like radians (taken as radians the heading agrees to "
                         f"{as_radians:.1f} deg): roll, pitch, heading must be in degrees")
            else:
                cause = "is it a true heading in degrees (not grid north, not the wander angle, clockwise from north)?"
            found.append(f"trajectory {stream.source}: the heading differs from the course over ground by "
                         f"{as_read:.1f} deg (median over {int(moving.sum())} records); {cause}")
    for name, limit in (("roll", MAX_ROLL_DEG), ("pitch", MAX_PITCH_DEG)):
        values = np.degrees(np.abs(np.asarray(getattr(stream, name))))
        k = int(np.argmax(values))
        if values[k] > limit:
            found.append(f"trajectory {stream.source} record {k + 1}: {name} of {values[k]:.1f} deg is beyond "
                         f"a plausible {limit:.0f} deg for a survey flight (degrees expected; wrong column?)")
    return found


def check_strip_trajectory(stream: GpsImuStream, strip: StripTimes) -> None:
    """Coverage and gaps (errors), then attitudes (a logged warning, once per message and process)."""
    check_coverage(stream, strip)
    check_gaps(stream, strip)
    for message in attitude_findings(stream):
        if message not in _warned:
            _warned.add(message)
            log.warning("%s", message)


def strip_times_of(project, strip_id: str) -> StripTimes:
    """The navigation times a project's strip needs (its line timing, mounting offset, scan time)."""
    n = project.n_lines(strip_id)
    sensor = project.scanner_of(strip_id)
    model = sensor.model
    half_scan = float(np.abs(model.time_offset(np.array([0.0, model.pixels - 1.0]))).max())
    return StripTimes(str(strip_id), project.timing(strip_id).as_table(n), sensor.mounting.time_offset, half_scan)
