"""Locating points of one strip: image (line, pixel) -> map (x, y, z) on the DTM, and back.

The strip's geometry is direct georeferencing (the orientation spline fitted to the GPS/IMU as
measured, ``Project.geometry``) unless a ``StripGeometry`` is given. Map coordinates are in the
project's map CRS with orthometric heights. Every input point gets an answer or NaN with a reason:
the texts of ``scangeo.sensors.strip.STATUS`` plus ``OUTSIDE_IMAGE``, ``OUTSIDE_TRAJECTORY`` and
``NO_HEIGHT`` below. A reason may accompany an answer (over-scanning: the first sighting is kept).

Files (docs/formats.md): image points ``point,line,pixel`` (other columns ignored), ground points
``point,x,y[,z]`` (a ground.csv works as it is; a missing or empty z is taken from the DTM).
Outputs: ``point,line,pixel,x,y,z,reason`` and ``point,x,y,z,line,pixel,reason`` (z as used).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from scangeo.atomic import write_csv
from scangeo.errors import ProjectFileError
from scangeo.io.points import column_floats, read_rows
from scangeo.io.project import Project
from scangeo.orientation.file import FILE_NAME, load_adjusted_geometry, results_folder
from scangeo.sensors.strip import StripGeometry, status_text

OUTSIDE_IMAGE = "outside the image"
OUTSIDE_TRAJECTORY = "outside the trajectory's time span"
NO_HEIGHT = "no z given and no DTM height there"


def _join(*texts: str) -> str:
    return "; ".join(t for t in texts if t)


def _uncovered(geometry: StripGeometry, t_sensor: np.ndarray) -> np.ndarray:
    """True where sensor times fall outside the orientation spline (the trajectory's span)."""
    return ~geometry.spline.covers(np.asarray(t_sensor, float) + geometry.mounting.time_offset)


def image_to_map(project: Project, strip_id: str, line, pixel, geometry: StripGeometry | None = None):
    """Map coordinates of image points of a strip.

    Parameters
    ----------
    line, pixel : (n,) image coordinates (0-based, pixel centres at integers).
    geometry : the strip's geometry (default: direct georeferencing).

    Returns
    -------
    xyz : (n, 3) map x, y and orthometric z (m); NaN where there is no answer.
    reasons : n texts, empty where the answer is plain.
    """
    g = geometry or project.geometry(strip_id, check=False)
    line = np.atleast_1d(np.asarray(line, dtype=float))
    pixel = np.atleast_1d(np.asarray(pixel, dtype=float))
    outside = (line < -0.5) | (line > g.n_lines - 0.5) | (pixel < -0.5) | (pixel > g.sensor.pixels - 0.5)
    uncovered = _uncovered(g, g.time_of(line, pixel))
    p_P, status = g.image_to_ground(line, pixel, project.dtm)
    xyz = np.full((len(line), 3), np.nan)
    ok = np.isfinite(p_P).all(axis=1) & ~outside & ~uncovered
    if ok.any():
        xyz[ok] = np.column_stack(project.map_frame.project_to_map(p_P[ok]))
    texts = status_text(status)
    reasons = [OUTSIDE_IMAGE if o else OUTSIDE_TRAJECTORY if u else s
               for o, u, s in zip(outside, uncovered, texts)]
    return xyz, reasons


def map_to_image(project: Project, strip_id: str, xyz, geometry: StripGeometry | None = None):
    """Image coordinates of map points in a strip.

    Parameters
    ----------
    xyz : (n, 3) map x, y and orthometric z (m); a NaN z is taken from the DTM.
    geometry : the strip's geometry (default: direct georeferencing).

    Returns
    -------
    line, pixel : (n,) image coordinates; NaN where the strip did not see the point.
    reasons : n texts, empty where the answer is plain.
    """
    g = geometry or project.geometry(strip_id, check=False)
    xyz = fill_heights(project, xyz)
    no_height = np.isnan(xyz[:, 2])
    p_P = project.map_frame.map_to_project(xyz[:, 0], xyz[:, 1], xyz[:, 2])
    line, pixel, status = g.ground_to_image(p_P)
    uncovered = np.isfinite(line) & _uncovered(g, g.time_of(line, pixel))
    line = np.where(uncovered, np.nan, line)
    pixel = np.where(uncovered, np.nan, pixel)
    texts = status_text(status)
    reasons = [NO_HEIGHT if h else OUTSIDE_TRAJECTORY if u else s for h, u, s in zip(no_height, uncovered, texts)]
    return line, pixel, reasons


def fill_heights(project: Project, xyz) -> np.ndarray:
    """A copy of map points (n, 3) with each NaN z replaced by the DTM's height (NaN off the DTM)."""
    xyz = np.array(np.atleast_2d(xyz), dtype=float)
    no_z = np.isnan(xyz[:, 2])
    if no_z.any():
        xyz[no_z, 2] = project.dtm.height_at_map(xyz[no_z, 0], xyz[no_z, 1])
    return xyz


# ------------------------------------------------------------------------------------ files
@dataclass(frozen=True)
class LocatedPoints:
    """A table of located points: the header and one row of texts per input row."""

    header: list[str]
    rows: list[list[str]]

    def write(self, path) -> None:
        """Write as CSV (atomically: a temporary name, then renamed)."""
        write_csv(path, self.header, self.rows)

    @property
    def reasons(self) -> list[str]:
        return [r[-1] for r in self.rows]


def _text(value: float, digits: int) -> str:
    return f"{value:.{digits}f}" if np.isfinite(value) else "NaN"


def read_image_points(path) -> tuple[list[str], np.ndarray, np.ndarray]:
    """``point,line,pixel`` CSV -> point ids, lines, pixels."""
    path = Path(path)
    header, body, numbers = read_rows(path, ["point", "line", "pixel"], [])
    if not body:
        raise ProjectFileError(f"{path}: no points after the header")
    points = [r[header.index("point")] for r in body]
    lines = column_floats(path, header, body, numbers, "line")
    return points, lines, column_floats(path, header, body, numbers, "pixel")


def read_map_points(path) -> tuple[list[str], np.ndarray]:
    """``point,x,y[,z]`` CSV (map CRS, orthometric z) -> point ids, (n, 3) with NaN for missing z."""
    path = Path(path)
    header, body, numbers = read_rows(path, ["point", "x", "y"], ["z"])
    if not body:
        raise ProjectFileError(f"{path}: no points after the header")
    points = [r[header.index("point")] for r in body]
    xyz = np.column_stack(
        [
            column_floats(path, header, body, numbers, "x"),
            column_floats(path, header, body, numbers, "y"),
            column_floats(path, header, body, numbers, "z", default=np.nan),
        ]
    )
    return points, xyz


def locate_image_file(project: Project, strip_id: str, path, geometry: StripGeometry | None = None) -> LocatedPoints:
    """Ground coordinates of the image points in ``path``: ``point,line,pixel,x,y,z,reason``."""
    project.strip(strip_id)
    points, line, pixel = read_image_points(path)
    xyz, reasons = image_to_map(project, strip_id, line, pixel, geometry)
    rows = [
        [p, _text(li, 6), _text(pi, 6), _text(x, 4), _text(y, 4), _text(z, 4), r]
        for p, li, pi, (x, y, z), r in zip(points, line, pixel, xyz, reasons)
    ]
    return LocatedPoints(["point", "line", "pixel", "x", "y", "z", "reason"], rows)


def locate_ground_file(project: Project, strip_id: str, path, geometry: StripGeometry | None = None) -> LocatedPoints:
    """Image coordinates of the map points in ``path``: ``point,x,y,z,line,pixel,reason``."""
    project.strip(strip_id)
    points, xyz = read_map_points(path)
    xyz = fill_heights(project, xyz)
    line, pixel, reasons = map_to_image(project, strip_id, xyz, geometry)
    rows = [
        [p, _text(x, 4), _text(y, 4), _text(z, 4), _text(li, 6), _text(pi, 6), r]
        for p, (x, y, z), li, pi, r in zip(points, xyz, line, pixel, reasons)
    ]
    return LocatedPoints(["point", "x", "y", "z", "line", "pixel", "reason"], rows)


def variant_geometry(project: Project, strip_id: str, variant: str = "DG") -> StripGeometry:
    """The strip's geometry for ``variant``: its ``orientation.json`` when there is one; ``DG``
    without one is direct georeferencing, unchecked (lines beyond the trajectory are answered point
    by point, with their reason)."""
    project.strip(strip_id)  # an unknown strip is named before any orientation is read
    if variant.upper() == "DG" and not (results_folder(project, variant) / FILE_NAME).exists():
        return project.geometry(strip_id, check=False)
    return load_adjusted_geometry(project, variant, strip_id)


def locate_points(project_path, strip_id: str, variant: str = "DG", *, image=None, ground=None) -> LocatedPoints:
    """``scangeo locate``: the image points of the CSV ``image`` on the map, or the map points of
    ``ground`` in the image (give one), with the orientation of ``variant``."""
    if (image is None) == (ground is None):
        raise ProjectFileError("locate: give the image points or the ground points (one of them)")
    project = Project.from_user_input(project_path)
    geometry = variant_geometry(project, strip_id, variant)
    if image is not None:
        return locate_image_file(project, strip_id, image, geometry)
    return locate_ground_file(project, strip_id, ground, geometry)
