"""A strip as matching sees it: its geometry on the DTM and one grey image, rectified in chips.

The matching image is the mean of the chosen bands (:func:`matching_bands`: by default the
project's bands between 400 and 2500 nm, never a thermal band), held in memory as float32 (a
7,000-line strip of 716 pixels takes 20 MB). A chip is a small grid of ground cells (map CRS, the
project's DTM heights): every cell's (line, pixel) comes from the exact ground -> image of the strip
(:meth:`CoreStripGeometry.ground_to_image`, the same function rectification uses) and the grey value
is resampled there bicubically, so a position on the chip carries back into the raw image exactly.
"""
from __future__ import annotations

import logging
import warnings
from dataclasses import dataclass

import cv2
import numpy as np
import rasterio

from scangeo.errors import InputFileError, ProjectFileError
from scangeo.io.project import Project
from scangeo.match.options import DEFAULT_BAND_RANGE_NM, MatchOptions
from scangeo.orientation.file import Orientation, load_orientation
from scangeo.rectify.core_geometry import CoreStripGeometry

log = logging.getLogger(__name__)

#: wavelength (nm) from which a band counts as thermal
THERMAL_NM = 3000.0


@dataclass(frozen=True)
class ChipGrid:
    """A small ground grid: cell centres ``x0 + col * res``, ``y0 - row * res`` (map units)."""

    x0: float
    y0: float
    res: float
    rows: int
    cols: int

    def xs(self) -> np.ndarray:
        return self.x0 + self.res * np.arange(self.cols)

    def ys(self) -> np.ndarray:
        return self.y0 - self.res * np.arange(self.rows)

    def to_map(self, col, row) -> tuple[np.ndarray, np.ndarray]:
        return self.x0 + self.res * np.asarray(col, float), self.y0 - self.res * np.asarray(row, float)

    @classmethod
    def around(cls, xmin: float, ymin: float, xmax: float, ymax: float, res: float, margin: int) -> ChipGrid:
        """The grid covering a box plus ``margin`` cells on every side."""
        cols = int(np.ceil((xmax - xmin) / res)) + 1 + 2 * margin
        rows = int(np.ceil((ymax - ymin) / res)) + 1 + 2 * margin
        return cls(xmin - margin * res, ymax + margin * res, res, rows, cols)


@dataclass
class Chip:
    """One strip's image on a chip grid with the raw (line, pixel) of every cell (NaN: not seen)."""

    grid: ChipGrid
    image: np.ndarray  # float32 (rows, cols), NaN off the strip
    line: np.ndarray
    pixel: np.ndarray

    def raw_at(self, col: float, row: float) -> tuple[float, float]:
        """(line, pixel) at a chip position, bilinear between cells (exact at cells)."""
        m = np.array([[col]], np.float32), np.array([[row]], np.float32)
        ln = cv2.remap(self.line.astype(np.float32), *m, cv2.INTER_LINEAR)[0, 0]
        px = cv2.remap(self.pixel.astype(np.float32), *m, cv2.INTER_LINEAR)[0, 0]
        return float(ln), float(px)

    def scale_at(self, col: int, row: int) -> float:
        """Image pixels per chip cell near a cell (rms of the local Jacobian's singular values)."""
        r = min(max(row, 1), self.grid.rows - 2)
        c = min(max(col, 1), self.grid.cols - 2)
        J = np.array([[self.line[r, c + 1] - self.line[r, c - 1], self.line[r + 1, c] - self.line[r - 1, c]],
                      [self.pixel[r, c + 1] - self.pixel[r, c - 1], self.pixel[r + 1, c] - self.pixel[r - 1, c]]])
        value = float(np.sqrt(0.5 * np.sum((0.5 * J) ** 2)))
        return value if np.isfinite(value) else 1.0


def matching_bands(project: Project, count: int, options: MatchOptions, source: str, strip_id: str) -> list[int]:
    """1-based bands of a strip's image averaged into its matching image (see :class:`MatchOptions`)."""
    if options.bands:
        bad = [b for b in options.bands if b > count]
        if bad:
            raise InputFileError(f"{source}: band {bad[0]} asked for matching, the image has {count}")
        return list(options.bands)
    sensor = project.scanner_of(strip_id)
    waves = sensor.wavelengths_nm
    if len(waves) == count:
        lo, hi = DEFAULT_BAND_RANGE_NM
        chosen = [i + 1 for i, w in enumerate(waves) if lo <= w <= hi]
        if chosen:
            return chosen
        return [i + 1 for i, w in enumerate(waves) if w < THERMAL_NM] or [1]
    names = [n.lower() for n in sensor.bands]
    if len(names) == count:
        return [i + 1 for i, n in enumerate(names) if "therm" not in n] or [1]
    return list(range(1, count + 1))


def read_matching_image(project: Project, strip_id: str, options: MatchOptions) -> np.ndarray:
    """The strip's grey matching image, float32 (lines, pixels), NaN at the image's nodata."""
    cfg = project.strip(strip_id)
    if cfg.image is None:
        raise ProjectFileError(f"{project.root / 'project.toml'} [strips id={strip_id}]: no image to match on")
    try:
        with warnings.catch_warnings():  # a raw scanner image has no georeferencing
            warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)
            with rasterio.open(cfg.image) as src:
                bands = matching_bands(project, src.count, options, str(cfg.image), strip_id)
                grey = np.zeros((src.height, src.width), np.float32)
                bad = np.zeros((src.height, src.width), bool)
                for b in bands:
                    data = src.read(b)
                    if src.nodata is not None:
                        bad |= data == src.nodata
                    grey += data.astype(np.float32)
    except rasterio.errors.RasterioIOError as exc:
        raise InputFileError(f"{cfg.image}: cannot read the image ({exc})") from exc
    grey /= len(bands)
    grey[bad] = np.nan
    return grey


class MatchStrip:
    """One strip for matching: its geometry for a variant and its grey image."""

    def __init__(self, project: Project, variant: str, strip_id: str, options: MatchOptions,
                 image: np.ndarray | None = None, orientation: Orientation | None = None) -> None:
        self.id = strip_id
        # DG, or the adjusted orientation of a variant (results/NAME/orientation.json); ``orientation``:
        # that of ``variant`` already read (it holds every strip: reading it per strip grows with the block)
        orientation = orientation if orientation is not None else load_orientation(project, variant)
        self.geometry = CoreStripGeometry(orientation.geometry(strip_id), project.dtm)
        self.dtm = project.dtm
        self._image = image
        self._project = project
        self._options = options

    @property
    def image(self) -> np.ndarray:
        if self._image is None:
            self._image = read_matching_image(self._project, self.id, self._options)
        return self._image

    def heights(self, grid: ChipGrid) -> np.ndarray:
        return np.asarray(self.dtm.height_on_lattice(grid.xs(), grid.ys()), float)

    def chip(self, grid: ChipGrid, heights: np.ndarray | None = None) -> Chip:
        """The strip rectified onto ``grid`` (bicubic), NaN where the strip does not see the ground."""
        H = self.heights(grid) if heights is None else heights
        X, Y = np.meshgrid(grid.xs(), grid.ys())
        line, pixel = self.geometry.ground_to_image(X.ravel(), Y.ravel(), H.ravel())
        line, pixel = line.reshape(X.shape), pixel.reshape(X.shape)
        image = self.image
        with np.errstate(invalid="ignore"):
            seen = (line >= 0) & (line <= image.shape[0] - 1) & (pixel >= 0) & (pixel <= image.shape[1] - 1)
        seen &= np.isfinite(H)
        chip = cv2.remap(image, np.where(seen, pixel, -10).astype(np.float32),
                         np.where(seen, line, -10).astype(np.float32), cv2.INTER_CUBIC,
                         borderMode=cv2.BORDER_CONSTANT, borderValue=np.nan)
        chip[~seen] = np.nan
        return Chip(grid, chip, np.where(seen, line, np.nan), np.where(seen, pixel, np.nan))

    def image_of(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Exact raw (line, pixel) of map points on the DTM (NaN: not seen)."""
        x, y = np.asarray(x, float), np.asarray(y, float)
        H = np.asarray(self.dtm.height_at_map(x, y), float)
        return self.geometry.ground_to_image(x, y, H)

    def sees(self, x: np.ndarray, y: np.ndarray, margin_px: float = 0.0) -> np.ndarray:
        """Map points the strip images at least ``margin_px`` inside its border."""
        line, pixel = self.image_of(x, y)
        n_lines, n_pixels = self.geometry.lines, self.geometry.pixels
        with np.errstate(invalid="ignore"):
            return ((line >= margin_px) & (line <= n_lines - 1 - margin_px) & (pixel >= margin_px)
                    & (pixel <= n_pixels - 1 - margin_px))
