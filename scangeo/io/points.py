"""Point files: image measurements (``points.csv``) and ground coordinates (``ground.csv``).

``points.csv``: ``point,strip,line,pixel[,sigma_px]`` -- one image measurement per row.
``ground.csv``: ``point,x,y,z,sigma_xy,sigma_z,role`` -- map CRS, orthometric z; role one of
``control`` (x, y, z known), ``check`` (known, not used in the adjustment), ``height`` (only z
known), ``planimetric`` (only x, y known). A point measured in 2+ strips and absent from ground.csv
is a tie point.
"""
from __future__ import annotations

import csv
import io
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from scangeo.atomic import write_csv
from scangeo.errors import ProjectFileError
from scangeo.textfile import read_text

ROLES = ("control", "check", "height", "planimetric")


def read_rows(path: Path, required: list[str], optional: list[str]) -> tuple[list[str], list[list[str]], list[int]]:
    text = read_text(path, "a CSV file", ProjectFileError)
    try:
        rows = list(csv.reader(io.StringIO(text, newline="")))
    except csv.Error as exc:
        raise ProjectFileError(f"{path}: not a CSV file ({exc})") from None
    if not rows:
        raise ProjectFileError(f"{path}: empty (expected a header {','.join(required)})")
    header = [h.strip().lower() for h in rows[0]]
    missing = [c for c in required if c not in header]
    if missing:
        raise ProjectFileError(
            f"{path} line 1: missing column{'s' if len(missing) > 1 else ''} {', '.join(missing)} "
            f"(expected {','.join(required + ['[' + o + ']' for o in optional])}, found {','.join(header)})"
        )
    body, numbers = [], []
    for i, row in enumerate(rows[1:], start=2):
        if not row or all(not c.strip() for c in row):
            continue
        if len(row) != len(header):
            raise ProjectFileError(f"{path} line {i}: {len(row)} fields, expected {len(header)}")
        body.append([c.strip() for c in row])
        numbers.append(i)
    return header, body, numbers


def column_floats(path, header, body, numbers, column, default=None) -> np.ndarray:
    if column not in header:
        return np.full(len(body), np.nan if default is None else default)
    k = header.index(column)
    out = np.empty(len(body))
    for r, row in enumerate(body):
        text = row[k]
        if text == "" and default is not None:
            out[r] = default
            continue
        try:
            out[r] = float(text)
        except ValueError:
            raise ProjectFileError(f"{path} line {numbers[r]}: {column} {text!r} is not a number") from None
        if not np.isfinite(out[r]):
            raise ProjectFileError(f"{path} line {numbers[r]}: {column} is not finite")
    return out


@dataclass(frozen=True)
class ImagePoints:
    """Image measurements: arrays of equal length; ``file_line`` for messages."""

    point: np.ndarray
    strip: np.ndarray
    line: np.ndarray
    pixel: np.ndarray
    sigma_px: np.ndarray
    file_line: np.ndarray
    source: str = "<points>"

    def __len__(self) -> int:
        return len(self.point)

    @classmethod
    def read(cls, path, default_sigma_px: float = 0.3) -> ImagePoints:
        path = Path(path)
        header, body, numbers = read_rows(path, ["point", "strip", "line", "pixel"], ["sigma_px"])
        point = np.array([r[header.index("point")] for r in body], dtype=object)
        strip = np.array([r[header.index("strip")] for r in body], dtype=object)
        sigma = column_floats(path, header, body, numbers, "sigma_px", default_sigma_px)
        bad = np.flatnonzero(sigma <= 0)
        if bad.size:
            raise ProjectFileError(f"{path} line {numbers[bad[0]]}: sigma_px must be positive")
        pts = cls(point, strip, column_floats(path, header, body, numbers, "line"),
                  column_floats(path, header, body, numbers, "pixel"), sigma, np.array(numbers), str(path))
        seen: dict[tuple, int] = {}
        for i, key in enumerate(zip(point, strip)):
            if key in seen:
                raise ProjectFileError(
                    f"{path} line {numbers[i]}: point {key[0]} in strip {key[1]} "
                    f"was already measured on line {seen[key]}"
                )
            seen[key] = numbers[i]
        return pts

    def check_strips(self, strip_ids) -> None:
        """Raise if a measurement names a strip the project does not have."""
        known = set(map(str, strip_ids))
        for i, s in enumerate(self.strip):
            if s not in known:
                raise ProjectFileError(
                    f"{self.source} line {self.file_line[i]}: strip {s!r} is not in the project "
                    f"(strips: {', '.join(sorted(known))})"
                )

    def write(self, path) -> None:
        write_csv(
            path,
            ["point", "strip", "line", "pixel", "sigma_px"],
            zip(
                self.point,
                self.strip,
                (f"{v:.4f}" for v in self.line),
                (f"{v:.4f}" for v in self.pixel),
                (f"{v:g}" for v in self.sigma_px),
            ),
        )


@dataclass(frozen=True)
class GroundPoints:
    """Ground coordinates of control/check/height/planimetric points (map CRS, orthometric z)."""

    point: np.ndarray
    xyz: np.ndarray
    sigma_xy: np.ndarray
    sigma_z: np.ndarray
    role: np.ndarray
    file_line: np.ndarray
    source: str = "<ground>"

    def __len__(self) -> int:
        return len(self.point)

    @classmethod
    def read(cls, path) -> GroundPoints:
        path = Path(path)
        header, body, numbers = read_rows(path, ["point", "x", "y", "z", "sigma_xy", "sigma_z", "role"], [])
        role = np.array([r[header.index("role")].lower() for r in body], dtype=object)
        for i, r in enumerate(role):
            if r not in ROLES:
                raise ProjectFileError(f"{path} line {numbers[i]}: role {r!r} is not one of {', '.join(ROLES)}")
        point = np.array([r[header.index("point")] for r in body], dtype=object)
        ids, counts = np.unique(point.astype(str), return_counts=True)
        if (counts > 1).any():
            dup = ids[counts > 1][0]
            raise ProjectFileError(f"{path}: point {dup} appears more than once")
        xyz = np.column_stack([column_floats(path, header, body, numbers, c) for c in ("x", "y", "z")])
        sxy = column_floats(path, header, body, numbers, "sigma_xy")
        sz = column_floats(path, header, body, numbers, "sigma_z")
        for name, arr in (("sigma_xy", sxy), ("sigma_z", sz)):
            bad = np.flatnonzero(arr <= 0)
            if bad.size:
                raise ProjectFileError(f"{path} line {numbers[bad[0]]}: {name} must be positive")
        return cls(point, xyz, sxy, sz, role, np.array(numbers), str(path))

    def write(self, path) -> None:
        write_csv(
            path,
            ["point", "x", "y", "z", "sigma_xy", "sigma_z", "role"],
            (
                [p, f"{x:.4f}", f"{y:.4f}", f"{z:.4f}", f"{sx:g}", f"{sz:g}", r]
                for p, (x, y, z), sx, sz, r in zip(self.point, self.xyz, self.sigma_xy, self.sigma_z, self.role)
            ),
        )


