"""What a variant did to the GPS/IMU over time, and the GPS/IMU itself, from the files of a project.

* :func:`correction_series`: the applied correction of a strip, adjusted orientation minus GPS/IMU
  as observed, at the adjustment's GPS/IMU epochs over the image: x, y, z (m, project frame) and
  roll, pitch, heading (rad). The adjustment observes the spline there as ``gpsimu(t) = s(t) -
  c(t)`` (as many epochs as spline coefficients), so this difference is the correction function.
* :func:`gpsimu_series`: the measured GPS/IMU of a strip over the image time span, in map
  coordinates and degrees, and its flight direction.
* :func:`problem_strips`: the strips a comparison corrects with more than a constant (a degree
  above 0 or a split) in some variant, from the variants' ``orientation.json``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from scangeo.adjustment.block import strip_data
from scangeo.io.project import Project
from scangeo.orientation.file import FILE_NAME, Orientation, read_orientation_file


@dataclass(frozen=True)
class Series:
    """Values over time: ``time`` (n,) s since the strip's first line, ``values`` (n, k)."""

    time: np.ndarray
    values: np.ndarray


def image_window(project: Project, strip_id: str) -> tuple[float, float]:
    """Times (s) of the strip's first and last image line."""
    t = project.timing(strip_id).time_of_line(np.array([0.0, project.n_lines(strip_id) - 1.0]))
    return float(t[0]), float(t[1])


def _measured(project: Project, strip_id: str):
    t0, t1 = image_window(project, strip_id)
    stream = project.stream(strip_id)
    return stream.select((stream.time >= t0) & (stream.time <= t1)), t0


def correction_series(project: Project, orientations: dict[str, Orientation], strip_id: str) -> dict[str, Series]:
    """The applied correction of a strip over its image in each variant (``orientations``: name ->
    the variant's :class:`Orientation`, read once for every strip), at the adjustment's GPS/IMU
    epochs: the adjusted spline minus the GPS/IMU observed there: x, y, z (m, P), roll, pitch,
    heading (rad)."""
    data = strip_data(project, strip_id)
    t0, t1 = image_window(project, strip_id)
    out = {}
    for name, orientation in orientations.items():
        adjusted = orientation.strip(strip_id).spline
        sel = (data.epochs >= t0) & (data.epochs <= t1) & adjusted.covers(data.epochs)
        d = adjusted.evaluate(data.epochs[sel]) - data.gpsimu[sel]
        d[:, 3:] = (d[:, 3:] + np.pi) % (2 * np.pi) - np.pi
        out[name] = Series(data.epochs[sel] - t0, d)
    return out


def gpsimu_series(project: Project, strip_id: str) -> tuple[Series, str]:
    """The measured GPS/IMU over the image: map x, y, ellipsoidal h (m), roll, pitch, heading (deg);
    and the flight direction as text (e.g. ``north (heading 2.1 deg)``)."""
    stream, t0 = _measured(project, strip_id)
    x, y = project.map_frame.geodetic_to_map_2d(stream.lat, stream.lon)
    values = np.column_stack([x, y, stream.h, np.degrees(stream.roll), np.degrees(stream.pitch),
                              np.degrees(stream.heading)])
    course = float(np.degrees(np.arctan2(x[-1] - x[0], y[-1] - y[0]))) % 360.0  # map grid azimuth
    names = ("north", "north-east", "east", "south-east", "south", "south-west", "west", "north-west")
    word = names[int(((course + 22.5) % 360) // 45)]
    return Series(stream.time - t0, values), f"{word} (grid course {course:.1f} deg)"


def written_orientations(project: Project, variants: list[str]) -> dict[str, Orientation]:
    """Each variant's written ``results/NAME/orientation.json`` (variants without one left out), read
    once: the figures of every strip use them (reading them per strip made the report quadratic in strips)."""
    out = {}
    for v in variants:
        path = project.root / "results" / v / FILE_NAME
        if path.exists():
            out[v] = read_orientation_file(path)
    return out


def problem_strips(project: Project, orientations: dict[str, Orientation]) -> list[str]:
    """Strips that some variant corrects with a polynomial (degree > 0) or a split model (of their flight
    line: every strip on it)."""
    found: set[str] = set()
    for doc in orientations.values():
        for m in doc.models:
            if (m.follows or max(m.position_degree, m.attitude_degree) > 0) and len(m.strips) == 1:
                found.add(m.strips[0])
    return [s.id for s in project.image_strips if s.flight_line in found]


def breaks_of(project: Project, orientations: dict[str, Orientation], strip_id: str) -> list[float]:
    """Break epochs (s since the strip's first line) of the variants' split models of a strip, sorted."""
    t0, _ = image_window(project, strip_id)
    return sorted({t - t0 for doc in orientations.values() for t in doc.breaks(strip_id)})


def true_gps_error(project: Project, strip_id: str) -> Series | None:
    """The injected GPS/IMU position error of a simulated strip's flight line (``truth/errors_<flight line
    id>.csv``: total x, y, z m)."""
    path = project.root / "truth" / f"errors_{project.strip(strip_id).flight_line}.csv"
    if not path.exists():
        return None
    with open(path) as f:
        header = f.readline().strip().split(",")
    cols = [header.index(c) for c in ("time", "total_x_m", "total_y_m", "total_z_m")]
    data = np.loadtxt(path, delimiter=",", skiprows=1, usecols=cols, ndmin=2)
    t0, t1 = image_window(project, strip_id)
    sel = (data[:, 0] >= t0) & (data[:, 0] <= t1)
    return Series(data[sel, 0] - t0, data[sel, 1:])


__all__ = ["Series", "breaks_of", "correction_series", "gpsimu_series", "image_window", "problem_strips",
           "true_gps_error", "written_orientations"]
