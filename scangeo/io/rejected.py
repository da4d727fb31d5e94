"""The measurements the cleaning stage set aside: ``PROJECT/results/cleaning/rejected.csv``.

``scangeo clean`` (:mod:`scangeo.strategy.cleaning`) writes the file; every later adjustment of the
project (diagnosis, compare, adjust, cross-validation) reads it through :func:`set_aside` and leaves
those measurements out. One row per measurement (format in docs/formats.md):

    kind,point,strip,line,pixel,x,y,z,w,mdb,separable,reason

``kind`` is ``image`` (a row of points.csv: ``point``, ``strip``, ``line``, ``pixel``) or ``ground``
(a row of ground.csv: ``point``, ``x``, ``y``, ``z``; ``strip``, ``line``, ``pixel`` empty). A
measurement is set aside only while it is unchanged: a corrected line/pixel (or coordinate) in the
project's file brings it back. Deleting the file (``scangeo clean PROJECT --restore``) restores all.
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from scangeo.atomic import write_csv
from scangeo.errors import ProjectFileError
from scangeo.io.points import GroundPoints, ImagePoints, column_floats, read_rows

log = logging.getLogger(__name__)

#: Where the cleaning stage keeps its results, relative to the project folder.
CLEANING_DIR = Path("results") / "cleaning"
REJECTED_FILE = CLEANING_DIR / "rejected.csv"
COLUMNS = ["kind", "point", "strip", "line", "pixel", "x", "y", "z", "w", "mdb", "separable", "reason"]
#: A measurement in the project's file matches a rejected one when it moved by less than this
#: (pixels or lines for image measurements, metres for ground coordinates).
SAME = 1e-3


@dataclass(frozen=True)
class RejectedMeasurement:
    """One measurement set aside by the cleaning.

    ``w``: the largest normalised residual of its rows when it was removed; ``mdb``: the minimal
    detectable blunder of the measurement (the largest of its rows, pixels/lines for ``image``,
    metres for ``ground``; inf when a blunder there cannot be detected); ``separable``: False when
    the adjustment could not tell which measurement of the point holds the blunder (every
    measurement of the point removed, ``reason`` says why).
    """

    kind: str
    point: str
    strip: str = ""
    line: float = math.nan
    pixel: float = math.nan
    xyz: tuple[float, float, float] = (math.nan, math.nan, math.nan)
    w: float = math.nan
    mdb: float = math.nan
    separable: bool = True
    reason: str = ""

    @property
    def key(self) -> tuple[str, str]:
        """``(point, strip)``; strip ``""`` for ground coordinates."""
        return (self.point, self.strip)

    def row(self) -> list:
        def f(x: float, fmt: str) -> str:
            return "" if math.isnan(x) else ("inf" if math.isinf(x) else format(x, fmt))

        return [self.kind, self.point, self.strip, f(self.line, ".4f"), f(self.pixel, ".4f"),
                *(f(c, ".4f") for c in self.xyz), f(self.w, ".3f"), f(self.mdb, ".4g"),
                "true" if self.separable else "false", self.reason]


def rejected_path(project_root) -> Path:
    return Path(project_root) / REJECTED_FILE


def write_rejected(path, rejected: list[RejectedMeasurement]) -> Path:
    """Write ``rejected.csv`` (atomically)."""
    return write_csv(path, COLUMNS, [r.row() for r in rejected])


def read_rejected(path) -> list[RejectedMeasurement]:
    """Read a ``rejected.csv``; a malformed row raises :class:`ProjectFileError` naming its line."""
    path = Path(path)
    header, body, numbers = read_rows(path, COLUMNS[:2], COLUMNS[2:])
    cols = {c: column_floats(path, header, body, numbers, c, math.nan)
            for c in ("line", "pixel", "x", "y", "z", "w") if c in header}

    def text(row, column: str) -> str:
        return row[header.index(column)] if column in header else ""

    out = []
    for i, row in enumerate(body):
        kind = text(row, "kind")
        if kind not in ("image", "ground"):
            raise ProjectFileError(f"{path} line {numbers[i]}: kind {kind!r} is not image or ground")
        value: dict[str, float] = {c: float(v[i]) for c, v in cols.items()}
        try:
            value["mdb"] = float(text(row, "mdb") or "nan")  # inf: a blunder there cannot be detected
        except ValueError:
            raise ProjectFileError(f"{path} line {numbers[i]}: mdb {text(row, 'mdb')!r} is not a number") from None
        if kind == "image" and not (text(row, "strip") and np.isfinite([value.get("line", math.nan),
                                                                        value.get("pixel", math.nan)]).all()):
            raise ProjectFileError(f"{path} line {numbers[i]}: an image measurement needs strip, line and pixel")
        out.append(RejectedMeasurement(
            kind, text(row, "point"), text(row, "strip"), value.get("line", math.nan), value.get("pixel", math.nan),
            (value.get("x", math.nan), value.get("y", math.nan), value.get("z", math.nan)),
            value.get("w", math.nan), value.get("mdb", math.nan), text(row, "separable").lower() != "false",
            text(row, "reason")))
    return out


def set_aside(project_root, points: ImagePoints, ground: GroundPoints
              ) -> tuple[ImagePoints, GroundPoints, int]:
    """``points`` and ``ground`` without the measurements of the project's ``rejected.csv`` (unchanged ones
    only), and how many were left out; as given when the project has no such file."""
    path = rejected_path(project_root)
    if not path.exists():
        return points, ground, 0
    rejected = read_rejected(path)
    image = {(r.point, r.strip): (r.line, r.pixel) for r in rejected if r.kind == "image"}
    coords = {r.point: r.xyz for r in rejected if r.kind == "ground"}
    keep = np.ones(len(points), bool)
    for i, key in enumerate(zip(points.point.astype(str), points.strip.astype(str))):
        lp = image.get(key)
        if lp is not None and abs(points.line[i] - lp[0]) < SAME and abs(points.pixel[i] - lp[1]) < SAME:
            keep[i] = False
    keep_g = np.ones(len(ground), bool)
    for i, p in enumerate(ground.point.astype(str)):
        xyz = coords.get(p)
        if xyz is not None and np.all(np.abs(ground.xyz[i] - np.asarray(xyz)) < SAME):
            keep_g[i] = False
    # a point left with a single measurement and no ground coordinates (its other measurement or its
    # coordinates set aside) is not determined: set aside with the others instead of failing the input
    # checks or being held by the solver's regularisation
    names = points.point.astype(str)
    lost = set(names[~keep]) | set(ground.point.astype(str)[~keep_g])
    given = set(ground.point.astype(str)[keep_g])
    left, count = np.unique(names[keep], return_counts=True)
    orphans = {p for p, c in zip(left, count) if c == 1 and p in lost and p not in given}
    keep &= ~np.isin(names, list(orphans))
    n = int((~keep).sum() + (~keep_g).sum())
    if n:
        log.info("%d measurements set aside by the cleaning (%s; scangeo clean --restore brings them back)", n, path)
        points = ImagePoints(points.point[keep], points.strip[keep], points.line[keep], points.pixel[keep],
                             points.sigma_px[keep], points.file_line[keep], points.source)
        ground = GroundPoints(ground.point[keep_g], ground.xyz[keep_g], ground.sigma_xy[keep_g],
                              ground.sigma_z[keep_g], ground.role[keep_g], ground.file_line[keep_g], ground.source)
    return points, ground, n


__all__ = ["CLEANING_DIR", "REJECTED_FILE", "RejectedMeasurement", "read_rejected", "rejected_path", "set_aside",
           "write_rejected"]
