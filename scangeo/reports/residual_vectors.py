"""Check-point residuals of one variant as vectors on the ground (for plots and the GeoPackage).

Read from the variant's ``PROJECT/results/NAME/residuals.csv`` (the rows of group ``check points``:
residual = model - measured, along track in lines and across track in pixels, with their w-test
and flag), the measured image positions from ``points.csv`` and the check points' map coordinates
from ``ground.csv``.

The ground vector of a residual is the ground error of the adjusted orientation at the check
point: where the orientation puts the measured image point minus the point's given coordinates,
``-J (d_line, d_pixel)`` with ``J`` the derivative of the adjusted image -> ground map at the
measurement (central differences of half a line and half a pixel on the project DTM). Using the
derivative instead of intersecting the measured ray with the DTM keeps the DTM's height error
out of the vector.
"""
from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from scangeo.errors import ProjectFileError
from scangeo.io.points import GroundPoints, ImagePoints
from scangeo.io.project import Project
from scangeo.orientation.file import load_orientation


@dataclass(frozen=True)
class ResidualVectors:
    """Check-point measurements of one variant (arrays of equal length n).

    ``point``, ``strip`` ids; ``x, y, z`` the given map coordinates (m); ``line, pixel`` as measured;
    ``d_line, d_pixel`` residuals (model - measured; NaN where the point could not be projected);
    ``w_line, w_pixel`` their w-tests; ``flagged``; ``dx_m, dy_m`` the ground error vector (map axes, m).
    """

    variant: str
    point: np.ndarray
    strip: np.ndarray
    x: np.ndarray
    y: np.ndarray
    z: np.ndarray
    line: np.ndarray
    pixel: np.ndarray
    d_line: np.ndarray
    d_pixel: np.ndarray
    w_line: np.ndarray
    w_pixel: np.ndarray
    flagged: np.ndarray
    dx_m: np.ndarray
    dy_m: np.ndarray

    def __len__(self) -> int:
        return len(self.point)

    def of_strip(self, strip_id: str) -> ResidualVectors:
        sel = self.strip == strip_id
        return ResidualVectors(self.variant, *(getattr(self, k)[sel] for k in _ARRAYS))


_ARRAYS = ("point", "strip", "x", "y", "z", "line", "pixel", "d_line", "d_pixel", "w_line", "w_pixel", "flagged",
           "dx_m", "dy_m")


def _float(text: str) -> float:
    return float(text) if text not in ("", None) else np.nan


def read_check_rows(path: Path) -> dict[tuple[str, str], dict[str, tuple[float, float, bool]]]:
    """``(point, strip) -> {component: (residual, w, flagged)}`` of the check rows of a residuals.csv."""
    if not path.exists():
        raise ProjectFileError(f"{path}: no residuals (run 'scangeo adjust' or 'scangeo compare' first)")
    out: dict = {}
    with open(path, newline="", encoding="utf-8") as f:
        reader = csv.DictReader(f)
        need = {"group", "id", "strip", "component", "residual", "w", "flagged"}
        if not need <= set(reader.fieldnames or []):
            raise ProjectFileError(f"{path}: expected the columns {', '.join(sorted(need))}")
        for row in reader:
            if row["group"] != "check points":
                continue
            out.setdefault((row["id"], row["strip"]), {})[row["component"]] = (
                _float(row["residual"]), _float(row["w"]), row["flagged"].strip() == "1")
    return out


def ground_jacobian(geometry, dtm, line: np.ndarray, pixel: np.ndarray) -> np.ndarray:
    """d(map x, y)/d(line, pixel) (n, 2, 2) of a strip geometry on a DTM, by central differences."""
    frame = dtm.map_frame
    h = 0.5

    def xy(dl, dp):
        p_P, _ = geometry.image_to_ground(line + dl, pixel + dp, dtm)
        x, y, _ = frame.project_to_map(p_P)
        return np.column_stack([x, y])

    J = np.empty((len(line), 2, 2))
    J[:, :, 0] = (xy(h, 0.0) - xy(-h, 0.0)) / (2 * h)
    J[:, :, 1] = (xy(0.0, h) - xy(0.0, -h)) / (2 * h)
    return J


def check_vectors(project: Project, variant: str, geometry_of=None) -> ResidualVectors:
    """The check-point residual vectors of ``variant`` (its results in PROJECT/results/NAME).

    ``geometry_of(strip_id)`` gives the variant's adjusted strip geometry (default: from the
    results folder's ``orientation.json``, :func:`scangeo.orientation.file.load_orientation`).
    """
    folder = project.root / "results" / variant
    rows = read_check_rows(folder / "residuals.csv")
    points = ImagePoints.read(project.root / "points.csv")
    ground = GroundPoints.read(project.root / "ground.csv")
    where = {str(p): i for i, p in enumerate(ground.point)}
    meas = {(str(p), str(s)): (ln, q) for p, s, ln, q in zip(points.point, points.strip, points.line, points.pixel)}
    keys = [k for k in rows if k[0] in where and k in meas]
    n = len(keys)
    def pick(comp, i):
        return np.array([rows[k].get(comp, (np.nan, np.nan, False))[i] for k in keys], dtype=float)
    xyz = ground.xyz[[where[k[0]] for k in keys]] if n else np.zeros((0, 3))
    line = np.array([meas[k][0] for k in keys], float)
    pixel = np.array([meas[k][1] for k in keys], float)
    d_line, d_pixel = pick("line", 0), pick("pixel", 0)
    flagged = np.array([any(c[2] for c in rows[k].values()) for k in keys], bool)
    strip = np.array([k[1] for k in keys], dtype=object)
    dx, dy = np.full(n, np.nan), np.full(n, np.nan)
    if geometry_of is None:
        geometry_of = load_orientation(project, variant).geometry
    for sid in dict.fromkeys(strip):
        sel = np.flatnonzero(strip == sid)
        J = ground_jacobian(geometry_of(sid), project.dtm, line[sel], pixel[sel])
        d = -np.einsum("nij,nj->ni", J, np.column_stack([d_line[sel], d_pixel[sel]]))
        dx[sel], dy[sel] = d[:, 0], d[:, 1]
    return ResidualVectors(variant, np.array([k[0] for k in keys], dtype=object), strip, xyz[:, 0], xyz[:, 1],
                           xyz[:, 2], line, pixel, d_line, d_pixel, pick("line", 1), pick("pixel", 1), flagged, dx, dy)


__all__ = ["ResidualVectors", "check_vectors", "ground_jacobian", "read_check_rows"]
