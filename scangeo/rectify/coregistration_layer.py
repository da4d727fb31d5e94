"""The co-registration layer of a platform's strip: the propagated 1-sigma relative ground displacement
of its rays against its flight line's reference strip, at every cell of its orthoimage.

An adjusted platform variant's ``coregistration.json`` (written beside its ``orientation.json`` by
``scangeo adjust``: :mod:`scangeo.adjustment.coregistration`) holds, per strip that has a reference, the
radial 1-sigma ``sigma_m`` (metres) on a regular grid of the strip's image: ``grid = [rows, columns]``
positions at lines ``linspace(0, lines - 1, rows)`` and pixels ``linspace(0, pixels - 1, columns)``, listed
(``line``, ``pixel``, ``sigma_m``) for the positions where it was propagated (the ray meets the DTM and
the reference sees the ground point). :class:`CoregistrationGrid` is that grid with NaN at the positions
left out; :meth:`CoregistrationGrid.values` interpolates it bilinearly in (line, pixel) at the cells'
image positions, which the rectifier's inverse map knows. A cell whose grid cell (the four positions
around its line and pixel) misses a position gets NaN: nothing is extrapolated beyond where the
displacement was propagated. Lines and pixels beyond the outermost positions (the image's outer
half-pixels) take the outermost positions' values.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from scangeo.errors import InputFileError

#: The schema of the co-registration files this module reads.
SCHEMA = "scangeo.coregistration/1"
#: Band description of the layer (one float32 band, metres, NaN nodata).
BAND = "coregistration_sigma_m"
#: ``NAME.tif`` -> ``NAME.coregistration.tif`` beside it.
SUFFIX = ".coregistration.tif"


def layer_path(orthoimage: Path) -> Path:
    """The co-registration layer beside a strip's orthoimage (``01.tif`` -> ``01.coregistration.tif``)."""
    orthoimage = Path(orthoimage)
    return orthoimage.with_name(orthoimage.stem + SUFFIX)


@dataclass(frozen=True)
class CoregistrationGrid:
    """The relative displacement of one strip on a regular grid of its image (module docstring).

    Parameters
    ----------
    strip, reference, flight_line : str
        The strip, the strip it is registered to (another sensor's, on the same flight line), the flight line.
    line : (rows,) ndarray
        Image lines of the grid's rows (0-based, pixel centres at integers), increasing.
    pixel : (columns,) ndarray
        Image pixels of the grid's columns, increasing.
    sigma : (rows, columns) ndarray
        The 1-sigma radial relative displacement, metres; NaN where it was not propagated.
    median_m, max_m : float or None
        The file's summary over the propagated positions, metres (None: none).
    """

    strip: str
    reference: str
    flight_line: str
    line: np.ndarray
    pixel: np.ndarray
    sigma: np.ndarray
    median_m: float | None = None
    max_m: float | None = None

    @classmethod
    def from_entry(cls, entry: dict, lines: int, pixels: int, source: str) -> CoregistrationGrid:
        """The grid of one ``strips[]`` entry of a co-registration file, over an image of ``lines`` x ``pixels``.

        Parameters
        ----------
        entry : dict
            The entry (``strip``, ``reference``, ``flight_line``, ``grid``, ``line``, ``pixel``, ``sigma_m``).
        lines, pixels : int
            The strip image's size.
        source : str
            Where the entry comes from, for errors (``FILE strips[3]``).

        Returns
        -------
        CoregistrationGrid
            NaN at the grid positions the entry does not list.

        Raises
        ------
        InputFileError
            A key missing or of the wrong kind, or a position that is not on the grid over this image.
        """
        rows, cols = _grid_shape(entry, source)
        line_axis = np.linspace(0.0, lines - 1.0, rows)
        pixel_axis = np.linspace(0.0, pixels - 1.0, cols)
        at = [np.asarray(_numbers(entry, key, source), dtype=float) for key in ("line", "pixel", "sigma_m")]
        if not at[0].size == at[1].size == at[2].size:
            raise InputFileError(f"{source}: 'line', 'pixel' and 'sigma_m' differ in length "
                                 f"({at[0].size}, {at[1].size}, {at[2].size})")
        sigma = np.full((rows, cols), np.nan)
        i, j = _node(at[0], line_axis), _node(at[1], pixel_axis)
        off = (np.abs(line_axis[i] - at[0]) > 1e-3) | (np.abs(pixel_axis[j] - at[1]) > 1e-3)
        if off.any():
            k = int(np.flatnonzero(off)[0])
            raise InputFileError(
                f"{source}: position {k} (line {at[0][k]:g}, pixel {at[1][k]:g}) is not on the {rows} x {cols} grid "
                f"over the strip's {lines} lines x {pixels} pixels (written for another image?)")
        if not (np.isfinite(at[2]).all() and (at[2] >= 0).all()):
            raise InputFileError(f"{source} 'sigma_m': expected finite numbers >= 0 (m)")
        sigma[i, j] = at[2]
        strip, reference, line = (str(entry.get(k, "")) for k in ("strip", "reference", "flight_line"))
        return cls(strip, reference, line, line_axis, pixel_axis, sigma, _optional(entry, "median_m", source),
                   _optional(entry, "max_m", source))

    def values(self, line: np.ndarray, pixel: np.ndarray) -> np.ndarray:
        """The bilinear interpolation of ``sigma`` at image positions (module docstring).

        Parameters
        ----------
        line, pixel : ndarray
            Image positions of the strip (any shape, the same); NaN allowed.

        Returns
        -------
        ndarray of float32
            Metres; NaN where a position is NaN or its grid cell misses a propagated position.
        """
        line, pixel = np.asarray(line, dtype=float), np.asarray(pixel, dtype=float)
        i, u = _cell(line, self.line)
        j, v = _cell(pixel, self.pixel)
        s = self.sigma
        i1, j1 = np.minimum(i + 1, s.shape[0] - 1), np.minimum(j + 1, s.shape[1] - 1)
        out = ((1 - u) * ((1 - v) * s[i, j] + v * s[i, j1]) + u * ((1 - v) * s[i1, j] + v * s[i1, j1]))
        # a missing corner makes the cell NaN even where its weight is 0
        missing = np.isnan(s[i, j]) | np.isnan(s[i, j1]) | np.isnan(s[i1, j]) | np.isnan(s[i1, j1])
        out[missing | ~np.isfinite(line) | ~np.isfinite(pixel)] = np.nan
        return out.astype(np.float32)

    def summary(self) -> dict:
        """The reference and the file's median and largest sigma (m): for the STAC items and the report."""
        return {"reference": self.reference, "flight_line": self.flight_line, "median_m": self.median_m,
                "max_m": self.max_m}


def _cell(x: np.ndarray, axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Index of the grid cell below ``x`` on ``axis`` and the fraction within it (clamped to the axis)."""
    if axis.size == 1:
        return np.zeros(x.shape, dtype=int), np.zeros(x.shape)
    step = (axis[-1] - axis[0]) / (axis.size - 1)
    f = np.clip(np.nan_to_num((x - axis[0]) / step), 0.0, axis.size - 1.0)
    i = np.minimum(np.floor(f).astype(int), axis.size - 2)
    return i, f - i


def _node(x: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """The nearest position of ``axis`` to each ``x``."""
    if axis.size == 1:
        return np.zeros(x.shape, dtype=int)
    step = (axis[-1] - axis[0]) / (axis.size - 1)
    return np.clip(np.round((x - axis[0]) / step), 0, axis.size - 1).astype(int)


def _grid_shape(entry: dict, source: str) -> tuple[int, int]:
    grid = entry.get("grid")
    if not (isinstance(grid, list) and len(grid) == 2 and all(isinstance(n, int) and n >= 1 for n in grid)):
        raise InputFileError(f"{source} 'grid': expected [rows, columns] of integers >= 1, found {grid!r}")
    return grid[0], grid[1]


def _numbers(entry: dict, key: str, source: str) -> list:
    value = entry.get(key)
    if not (isinstance(value, list) and all(isinstance(v, int | float) and not isinstance(v, bool) for v in value)):
        raise InputFileError(f"{source} '{key}': expected a list of numbers, found {type(value).__name__}")
    return value


def _optional(entry: dict, key: str, source: str) -> float | None:
    value = entry.get(key)
    if value is None:
        return None
    if not isinstance(value, int | float) or isinstance(value, bool) or not math.isfinite(value):
        raise InputFileError(f"{source} '{key}': expected a number (m) or null, found {value!r}")
    return float(value)


def read_coregistration(path: Path) -> dict[str, dict]:
    """The entries of a co-registration file by strip id (checked: the schema, each entry's strip and reference).

    Parameters
    ----------
    path : Path
        ``results/NAME/coregistration.json``.

    Returns
    -------
    dict of str to dict
        Strip id -> its entry (:meth:`CoregistrationGrid.from_entry` makes the grid).

    Raises
    ------
    InputFileError
        Not JSON, another schema, or an entry without its strip or reference.
    """
    path = Path(path)
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InputFileError(f"{path}: cannot read the co-registration file ({exc})") from exc
    if not isinstance(doc, dict) or doc.get("schema") != SCHEMA:
        found = doc.get("schema") if isinstance(doc, dict) else type(doc).__name__
        raise InputFileError(f"{path} 'schema': expected {SCHEMA!r}, found {found!r}")
    entries = doc.get("strips")
    if not isinstance(entries, list):
        raise InputFileError(f"{path} 'strips': expected a list, found {type(entries).__name__}")
    out = {}
    for k, entry in enumerate(entries):
        if not (isinstance(entry, dict) and isinstance(entry.get("strip"), str)
                and isinstance(entry.get("reference"), str)):
            raise InputFileError(f"{path} strips[{k}]: expected a table with 'strip' and 'reference' (strip ids)")
        out[entry["strip"]] = entry
    return out


__all__ = ["BAND", "SCHEMA", "SUFFIX", "CoregistrationGrid", "layer_path", "read_coregistration"]
