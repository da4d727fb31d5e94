"""HySpex sensor-model files: the look angles of every detector pixel.

A HySpex sensor model is a text file with a header line ``pixel vinkelx vinkely`` and one row per
detector pixel: the pixel index (0-based), the across-track angle ``vinkelx`` and the along-track
angle ``vinkely``, radians, whitespace-separated. A camera mounted rotated by 180 degrees comes with
a "180deg_rotated" file whose ``vinkelx`` has the opposite sign. PARGE's status file keeps the same
two angles in ``sensarr`` (columns 1 and 2).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from scangeo.errors import MissingFileError, ParGeFileError
from scangeo.textfile import read_text


@dataclass(frozen=True)
class HySpexSensorModel:
    """The look angles of a HySpex camera, as the file gives them (radians)."""

    path: Path
    vinkelx: np.ndarray
    vinkely: np.ndarray

    @property
    def pixels(self) -> int:
        return len(self.vinkelx)

    @classmethod
    def read(cls, path, pixels: int | None = None) -> HySpexSensorModel:
        """Read and check a sensor-model file; ``pixels``: the count the image has (checked)."""
        path = Path(path)
        if not path.exists():
            raise MissingFileError(f"{path}: no such sensor-model file")
        text = read_text(path, "a HySpex sensor model: 'pixel vinkelx vinkely' and one row per pixel",
                         ParGeFileError)
        rows = [line.split() for line in text.splitlines()]
        rows = [r for r in rows if r]
        if not rows or [c.lower() for c in rows[0][:3]] != ["pixel", "vinkelx", "vinkely"]:
            found = " ".join(rows[0]) if rows else "an empty file"
            raise ParGeFileError(f"{path} line 1: expected the header 'pixel vinkelx vinkely', found {found!r}")
        values = np.empty((len(rows) - 1, 3))
        for i, row in enumerate(rows[1:], start=2):
            if len(row) < 3:
                raise ParGeFileError(f"{path} line {i}: {len(row)} fields, expected 3 (pixel vinkelx vinkely)")
            try:
                values[i - 2] = [float(v) for v in row[:3]]
            except ValueError:
                raise ParGeFileError(f"{path} line {i}: {' '.join(row[:3])!r} is not three numbers") from None
        if not np.isfinite(values).all():
            raise ParGeFileError(f"{path}: a look angle is not finite")
        n = len(values)
        if n == 0:
            raise ParGeFileError(f"{path}: no pixel rows after the header")
        if not np.array_equal(values[:, 0], np.arange(n)):
            raise ParGeFileError(f"{path}: the pixel column is not 0, 1, ..., {n - 1} in order")
        if pixels is not None and n != pixels:
            raise ParGeFileError(f"{path}: {n} pixels, but the image has {pixels} (a sensor model of another "
                                 "camera or binning?)")
        if np.abs(values[:, 1:]).max() >= np.pi / 2:
            raise ParGeFileError(f"{path}: look angles of {np.abs(values[:, 1:]).max():g} rad or more; "
                                 "expected radians within +-pi/2")
        return cls(path, values[:, 1].copy(), values[:, 2].copy())


__all__ = ["HySpexSensorModel"]
