"""The conventions of a drone line's ``.lcf`` and ``.times``, found from the data and recorded with their figures.

Each function takes what it needs from the read files, decides one thing, records it in the
:class:`~scangeo.importers.record.ImportRecord` (figures of the choice and of its alternatives), and
returns what :func:`scangeo.importers.lcf.import_lcf` applies:

* :func:`time_base` -- the ``.lcf``'s system time as GPS seconds of the week, and the ``.times`` on
  it (the specification: the first line, the first ``.times`` entry and the first record meet);
* :func:`attitude_checks` -- the heading against the course over ground, the roll against the
  lateral acceleration (a right-wing-up roll turns into scangeo's right-wing-down one);
* :func:`altitude_datum` -- whether the altitude is above the ellipsoid (the specification) or above
  the geoid, from the height above the ground each reading gives and the pixels' shape on it;
* :func:`knot_spacing` -- the spline's knot spacing that follows the attitude to a tenth of a pixel.
"""
from __future__ import annotations

import datetime
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.interpolate import make_lsq_spline

from scangeo.errors import ArgumentError, ImportFileError
from scangeo.importers.lcf_files import LineTimes, NavigationLog
from scangeo.importers.record import ImportRecord, rounded
from scangeo.trajectory.checks import GAP_FACTOR, MIN_GAP_S, TIME_RESOLUTION_S

GPS_EPOCH = datetime.datetime(1980, 1, 6)
UNIX_EPOCH = datetime.datetime(1970, 1, 1)
WEEK_S = 604800.0
#: system times above this are seconds since an epoch (1983 on the GPS epoch), below it of a week or a day
EPOCH_TIMES_S = 1e8
EARTH_RADIUS_M = 6371000.0


@dataclass(frozen=True)
class Timing:
    """The navigation times and the line times on the project's time base (s), and the lines kept."""

    nav_time: np.ndarray
    line_time: np.ndarray
    lines: int
    line_rate_hz: float


def time_base(nav: NavigationLog, times: LineTimes, cube_lines: int, frame_rate_hz: float | None,
              record: ImportRecord) -> Timing:
    """The two time bases met as the specification says, and the lines the navigation covers."""
    t0 = float(nav.time[0])
    if t0 > EPOCH_TIMES_S:
        week = math.floor(t0 / WEEK_S)
        nav_time = nav.time - week * WEEK_S
        as_gps, as_unix = GPS_EPOCH + datetime.timedelta(seconds=t0), UNIX_EPOCH + datetime.timedelta(seconds=t0)
        record.decide("time_base", f"GPS seconds of week {week}",
                      f"the .lcf's system time {t0:.3f} s counts from the GPS epoch (1980-01-06): "
                      f"{as_gps:%Y-%m-%d %H:%M:%S} GPS; read from the Unix epoch it would be {as_unix:%Y-%m-%d}; "
                      "the project's times are GPS seconds of the week (as an SBET's)",
                      {"lcf_first_time_s": t0, "gps_week": week, "gps_date": f"{as_gps:%Y-%m-%dT%H:%M:%S}",
                       "unix_date": f"{as_unix:%Y-%m-%dT%H:%M:%S}", **nav.extra})
    else:
        nav_time = nav.time.copy()
        record.decide("time_base", "the .lcf's system time as it stands",
                      f"the .lcf's first time {t0:.3f} s is below {EPOCH_TIMES_S:g} s: seconds of a week or a day, "
                      "taken as they are", {"lcf_first_time_s": t0, **nav.extra})
    if len(times) != cube_lines:
        raise ImportFileError(f"{times.path}: {len(times)} line times, but the cube has {cube_lines} lines "
                              "(one time per image line)")
    offset = float(nav_time[0] - times.time[0])
    line_time = times.time + offset
    step = np.diff(times.time)
    median = float(np.median(step)) if len(step) else math.nan
    rate = 1.0 / median
    nav_step = float(np.median(np.diff(nav_time)))
    covered = line_time <= nav_time[-1] + TIME_RESOLUTION_S
    lines = int(np.argmin(covered)) if not covered.all() else len(line_time)
    if lines < 2:
        raise ImportFileError(f"{nav.path}: the navigation ends {nav_time[-1] - line_time[0]:.3f} s after the first "
                              "image line: it covers fewer than 2 lines")
    dropped = int(np.sum(step > 1.5 * median))
    record.decide("time_alignment", "the first image line at the first .lcf record (lcf_spec)",
                  "the specification: the first image line, the first .times entry and the first .lcf record are "
                  "recorded at the same moment; the line times are the .times less its first, plus the .lcf's first",
                  {"offset_s": offset, "lcf_span_s": rounded(nav_time[-1] - nav_time[0], 6),
                   "times_span_s": rounded(times.time[-1] - times.time[0], 6),
                   "line_interval_s": {"median": rounded(median, 7), "min": rounded(step.min(), 7),
                                       "max": rounded(step.max(), 7)},
                   "dropped_frames": dropped, "navigation_interval_s": rounded(nav_step, 7),
                   "lines_kept": lines, "lines_in_cube": cube_lines})
    if lines < cube_lines:
        after = float(line_time[lines] - nav_time[-1])
        record.note(f"lines {lines}-{cube_lines - 1} of the cube were taken after the last navigation record "
                    f"({after * 1000:.1f} ms and more): left out (lines = {lines})")
    if dropped:
        record.note(f"{dropped} line intervals of the .times are longer than 1.5 x the median {median * 1000:.3f} ms "
                    "(dropped frames): the line times carry them")
    if frame_rate_hz is not None and abs(frame_rate_hz - rate) > 0.01 * rate:
        record.warn(f"the cube's header says framerate = {frame_rate_hz:g} Hz, the .times {rate:.3f} Hz "
                    f"({median * 1000:.3f} ms a line): the line times are used")
    _check_gaps(nav, nav_time, line_time[:lines])
    return Timing(nav_time, line_time, lines, rate)


def _check_gaps(nav: NavigationLog, nav_time: np.ndarray, line_time: np.ndarray) -> None:
    step = np.diff(nav_time)
    limit = max(MIN_GAP_S, GAP_FACTOR * float(np.median(step)))
    gaps = np.flatnonzero((step > limit) & (nav_time[1:] > line_time[0]) & (nav_time[:-1] < line_time[-1]))
    if gaps.size:
        i = int(gaps[0])
        aside = f"; {len(nav.set_aside)} records flagged 0 (do not use) were set aside" if nav.set_aside else ""
        raise ImportFileError(f"{nav.path} line {nav.file_line[i + 1]}: a gap of {step[i]:.3f} s in the navigation "
                              f"after time {nav.time[i]:.3f} (records every {np.median(step):.4f} s; at most "
                              f"{limit:g} s over the image lines){aside}")


def local_track(nav: NavigationLog) -> tuple[np.ndarray, np.ndarray]:
    """East and north (m) of the records on a sphere tangent at the first: for speeds and courses."""
    lat0 = math.radians(float(nav.lat[0]))
    east = np.radians(nav.lon - nav.lon[0]) * EARTH_RADIUS_M * math.cos(lat0)
    north = np.radians(nav.lat - nav.lat[0]) * EARTH_RADIUS_M
    return east, north


def _derivatives(t: np.ndarray, v: np.ndarray, window_s: float) -> tuple[np.ndarray, np.ndarray]:
    """First and second derivatives of v(t) by local quadratic fits over ``window_s``."""
    from scipy.signal import savgol_filter

    dt = float(np.median(np.diff(t)))
    w = max(5, int(round(window_s / dt)) | 1)
    if w >= len(t):
        w = len(t) - 1 if len(t) % 2 == 0 else len(t)
    if w < 5:
        return np.gradient(v, t), np.gradient(np.gradient(v, t), t)
    return savgol_filter(v, w, 2, deriv=1, delta=dt), savgol_filter(v, w, 2, deriv=2, delta=dt)


def attitude_checks(nav: NavigationLog, nav_time: np.ndarray, record: ImportRecord) -> float:
    """Record the heading and roll conventions with the figures that test them; returns the median
    ground speed (m/s)."""
    east, north = local_track(nav)
    ve, ae = _derivatives(nav_time, east, 1.0)
    vn, an = _derivatives(nav_time, north, 1.0)
    speed = np.hypot(ve, vn)
    moving = speed > 0.5
    course = np.arctan2(ve, vn)

    def off(a):
        d = np.degrees(np.angle(np.exp(1j * (a - course[moving]))))
        return {"median_deg": rounded(np.median(d), 2), "rms_deg": rounded(np.sqrt(np.mean(d ** 2)), 2)}

    if moving.sum() >= 10:
        spec, other = off(nav.heading[moving]), off(np.pi / 2 - nav.heading[moving])
        record.decide("heading", "heading clockwise from north (lcf_spec), as scangeo's",
                      "the course over ground from the positions against the heading, read as the specification "
                      "says and as a mathematical angle from east", {"heading_minus_course": spec},
                      {"counter-clockwise from east": {"heading_minus_course": other}})
        if abs(spec["median_deg"]) > 45 and abs(other["median_deg"]) < abs(spec["median_deg"]):
            record.warn(f"{nav.path}: the heading is {spec['median_deg']:.0f} deg off the course over ground "
                        f"(read from east, counter-clockwise: {other['median_deg']:.0f} deg)")
    else:
        record.decide("heading", "heading clockwise from north (lcf_spec), as scangeo's",
                      "the line hardly moves: the heading cannot be compared with a course", {})
    # a right-wing-down roll (scangeo's, the specification's negated) accelerates to the right
    right = ae * np.cos(nav.heading) - an * np.sin(nav.heading)
    roll = -nav.roll
    corr = float(np.corrcoef(roll[moving], right[moving])[0, 1]) if moving.sum() >= 10 and np.std(roll) > 0 \
        and np.std(right[moving]) > 0 else math.nan
    g = 9.80665
    record.decide("roll", "scangeo roll = -lcf roll (lcf_spec: positive right wing up; scangeo: right wing down)",
                  "a right-wing-down roll turns and accelerates the platform to the right: the correlation of "
                  "scangeo's roll with the lateral acceleration tells the sign where the platform banks "
                  "(|r| >= 0.5); a camera on a stabilising gimbal does not bank, and the sign is then the "
                  "specification's, unchecked",
                  {"correlation_with_lateral_acceleration": rounded(corr, 3),
                   "roll_deg": {"mean": rounded(np.degrees(roll.mean()), 3), "std": rounded(np.degrees(roll.std()), 3)},
                   "lateral_acceleration_rms_m_s2": rounded(np.sqrt(np.mean(right ** 2)), 4),
                   "bank_of_that_acceleration_deg": rounded(np.degrees(np.arctan(np.sqrt(np.mean(right ** 2)) / g)),
                                                            3)})
    if math.isfinite(corr) and corr < -0.5:
        record.warn(f"{nav.path}: the roll, read as right wing up, turns against the lateral acceleration "
                    f"(r = {corr:.2f}): its sign may be the other one")
    return float(np.median(speed[moving])) if moving.any() else 0.0


def altitude_datum(altitude: str, nav: NavigationLog, geoid_n: float | None, ground_h: float | None,
                   along_gsd_m: float, ifov_rad: float, record: ImportRecord) -> tuple[str, float]:
    """Which datum the altitude is on; returns ``(datum, N)``: the trajectory's ellipsoidal height is the
    altitude (``"ellipsoidal"``) or the altitude + N (``"orthometric"``); N is 0 when not known.

    The readings are weighed by the height above the ground each gives and the pixels' shape there:
    the across-track sample (height x the centre pixels' angle) against the along-track one (ground
    speed / line rate). Drone pushbroom lines are flown for square pixels (their makers' planning
    rule), and a reading that puts the camera at a fraction of the height that gives them is not the
    file's.
    """
    if altitude not in ("auto", "ellipsoidal", "orthometric"):
        raise ArgumentError(f"altitude {altitude!r}: expected auto, ellipsoidal or orthometric")
    alt = float(np.median(nav.altitude))
    square = along_gsd_m / ifov_rad if ifov_rad > 0 else math.nan

    def reading(n: float) -> dict[str, Any]:
        out: dict[str, Any] = {"altitude_m": rounded(alt, 3)}
        if ground_h is not None:
            agl = alt - n - ground_h
            out.update(height_above_ground_m=rounded(agl, 3), across_gsd_m=rounded(agl * ifov_rad, 4),
                       along_gsd_m=rounded(along_gsd_m, 4),
                       across_over_along=rounded(agl * ifov_rad / along_gsd_m, 3) if along_gsd_m > 0 else None)
        return out

    figures = {"square_pixel_height_m": rounded(square, 2), "geoid_undulation_m": geoid_n,
               "ground_height_m": ground_h}
    readings = {"orthometric": reading(0.0)}
    if geoid_n is not None:
        readings["ellipsoidal"] = reading(geoid_n)
    if altitude != "auto":
        if altitude == "ellipsoidal" and geoid_n is None:
            raise ArgumentError("altitude ellipsoidal: the DTM's orthometric heights meet ellipsoidal altitudes only "
                                "through the geoid undulation: give the geoid (a number of metres or a raster)")
        record.decide("altitude", f"above the {'ellipsoid' if altitude == 'ellipsoidal' else 'geoid'} (given)",
                      "as given", figures, readings)
        return altitude, geoid_n or 0.0
    if geoid_n is None:
        record.decide("altitude", "as it stands, with N = 0 for the trajectory and the DTM",
                      "no geoid undulation given: the readings above the ellipsoid and above the geoid cannot be "
                      "told apart; with N = 0 the trajectory and the DTM share the altitude's datum, right when the "
                      "DTM's heights are on it (over the sea: when the altitude is above the geoid)", figures, readings)
        record.warn("no geoid given: the altitude is taken as it stands (N = 0); give the geoid undulation to tell "
                    "whether it is above the ellipsoid or the geoid")
        return "orthometric", 0.0
    if ground_h is None:
        record.decide("altitude", "above the ellipsoid (lcf_spec)",
                      "no DTM or GCP heights: the readings cannot be weighed; the specification's is taken",
                      figures, readings)
        return "ellipsoidal", geoid_n
    score = {k: abs(math.log(v["across_over_along"])) if v.get("across_over_along") and v["across_over_along"] > 0
             else math.inf for k, v in readings.items()}
    chosen = min(score, key=lambda k: score[k])
    other = "orthometric" if chosen == "ellipsoidal" else "ellipsoidal"
    r, o = readings[chosen], readings[other]
    record.decide("altitude", f"above the {'ellipsoid' if chosen == 'ellipsoidal' else 'geoid'}",
                  f"read above the {'ellipsoid' if chosen == 'ellipsoidal' else 'geoid'} the camera flies "
                  f"{r['height_above_ground_m']:.1f} m above the ground, its pixels {r['across_over_along']:.2f} times "
                  f"as wide as long; the other reading gives {o['height_above_ground_m']:.1f} m and "
                  f"{o['across_over_along'] if o['across_over_along'] is not None else math.nan:.2f} "
                  f"(square pixels need {square:.1f} m)", figures, readings)
    if score[chosen] > math.log(2.0):
        record.warn(f"the altitude read above the {'ellipsoid' if chosen == 'ellipsoidal' else 'geoid'} gives pixels "
                    f"{r['across_over_along']:.2f} times as wide as long; check the altitude, the DTM and the "
                    "camera's field of view")
    return chosen, geoid_n


def knot_spacing(nav_time: np.ndarray, roll: np.ndarray, pitch: np.ndarray, heading: np.ndarray, ifov_rad: float,
                 record: ImportRecord, given: float | None = None, tolerance_px: float = 0.1) -> float:
    """The largest knot spacing whose cubic spline follows each attitude angle to ``tolerance_px`` rms."""
    step = float(np.median(np.diff(nav_time)))
    candidates = [c for c in (0.2, 0.1, 0.05, 0.02, 0.01) if c > 1.5 * step] + [step]
    figures: dict[str, float | None] = {}
    chosen: float | None = None
    for c in candidates:
        if c == step:  # a knot per record: the spline interpolates the records
            figures[f"{c:g}"] = 0.0
            chosen = chosen or c
            continue
        rms = max(_spline_rms(nav_time, np.unwrap(a) if name == "heading" else a, c)
                  for name, a in (("roll", roll), ("pitch", pitch), ("heading", heading)))
        figures[f"{c:g}"] = rounded(rms / ifov_rad, 4) if ifov_rad > 0 else None
        if chosen is None and ifov_rad > 0 and rms / ifov_rad <= tolerance_px:
            chosen = c
    if chosen is None:
        chosen = step
    if given is not None:
        record.decide("knot_spacing", f"{given:g} s (given)", "as given", {"attitude_rms_px_by_spacing_s": figures})
        return given
    record.decide("knot_spacing", f"{chosen:g} s",
                  f"the largest spacing whose spline follows roll, pitch and heading to {tolerance_px:g} px rms "
                  "(the worst of the three, in centre pixels)", {"attitude_rms_px_by_spacing_s": figures})
    return chosen


def _spline_rms(t: np.ndarray, v: np.ndarray, spacing: float) -> float:
    n = int(math.floor((t[-1] - t[0]) / spacing))
    if n < 1:
        return 0.0
    inner = t[0] + spacing * np.arange(1, n)
    inner = inner[inner < t[-1] - 1e-9]
    knots = np.concatenate([[t[0]] * 4, inner, [t[-1]] * 4])
    try:
        fit = make_lsq_spline(t, v, knots, k=3)
    except (ValueError, np.linalg.LinAlgError):  # Schoenberg-Whitney fails where records are sparse
        return math.inf
    return float(np.sqrt(np.mean((fit(t) - v) ** 2)))


__all__ = ["Timing", "altitude_datum", "attitude_checks", "knot_spacing", "local_track", "time_base"]
