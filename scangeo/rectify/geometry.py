"""What rectification needs to know about a strip: the narrow interface to the geometry core.

The rectifier never touches trajectories, splines or sensor models directly. It asks a
:class:`MapStripGeometry` (map coordinates in, image coordinates out, and the reverse) and so works
the same for direct georeferencing, for an adjusted orientation, and for the analytic geometries
of the tests. :mod:`scangeo.rectify.core_geometry` implements it on the geometry core.

Coordinates: map ``x, y`` in the map CRS of the output grid (metres), heights ``H`` orthometric
metres; image ``line`` and ``pixel`` 0-based with pixel centres at integers (docs/conventions.md).
"""
from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np

from scangeo.errors import GeometryError


@runtime_checkable
class MapStripGeometry(Protocol):
    """The geometry of one strip, as rectification uses it."""

    #: number of image lines and pixels per line
    lines: int
    pixels: int
    #: the map CRS (WKT or anything rasterio accepts)
    crs: str

    def ground_to_image(self, x: np.ndarray, y: np.ndarray, H: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(line, pixel) float arrays that saw the map points (x, y, H); NaN where no line did.

        Points beyond the swath's sides may come back NaN or as pixels outside ``[0, pixels)``;
        both are treated as unseen. Occlusion is not considered here.
        """
        ...

    def image_to_ground(self, line: np.ndarray, pixel: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Map (x, y, H) where the rays of (line, pixel) first meet the DTM; NaN where they miss."""
        ...

    def sensor_position(self, line: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Map (x, y, H) of the projection centre at the time of the (fractional) lines."""
        ...

    def height(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """DTM height H (orthometric metres) at map points; NaN where the DTM has none."""
        ...

    def scan_angle(self, pixel: np.ndarray) -> np.ndarray:
        """Across-track look angle of pixels in the sensor frame, radians (positive to the right)."""
        ...

    def time(self, line: np.ndarray, pixel: np.ndarray) -> np.ndarray:
        """Acquisition time of (line, pixel), seconds of the project's time base."""
        ...


def footprint_bounds(geometry: MapStripGeometry, samples: int = 64) -> tuple[float, float, float, float]:
    """(xmin, ymin, xmax, ymax) of the strip's footprint on the DTM, map units.

    The border of the image (first and last pixel of every ``lines / samples``-th line, and the
    first and last line at every few pixels) is projected onto the DTM with ``image_to_ground``.
    """
    lines, pixels = geometry.lines, geometry.pixels
    along = np.unique(np.linspace(0, lines - 1, max(2, samples)).round())
    across = np.unique(np.linspace(0, pixels - 1, max(2, samples // 4)).round())
    line = np.concatenate([along, along, np.zeros_like(across), np.full_like(across, lines - 1)])
    pixel = np.concatenate([np.zeros_like(along), np.full_like(along, pixels - 1), across, across])
    # half a pixel beyond the border: the outer pixels' footprints reach that far
    line = np.clip(line, 0, lines - 1) + np.where(line == 0, -0.5, np.where(line == lines - 1, 0.5, 0.0))
    pixel = pixel + np.where(pixel == 0, -0.5, np.where(pixel == pixels - 1, 0.5, 0.0))
    x, y, _ = geometry.image_to_ground(line, pixel)
    ok = np.isfinite(x) & np.isfinite(y)
    if not ok.any():
        raise GeometryError("the strip's footprint does not meet the DTM anywhere")
    return float(x[ok].min()), float(y[ok].min()), float(x[ok].max()), float(y[ok].max())


def nadir_ground_pixel(geometry: MapStripGeometry) -> float:
    """Mean of the across- and along-track ground pixel size at nadir of the middle line, metres."""
    line0 = (geometry.lines - 1) / 2.0
    nadir = float(np.argmin(np.abs(geometry.scan_angle(np.arange(geometry.pixels, dtype=float)))))
    nadir = min(max(nadir, 0.0), geometry.pixels - 2.0)
    line0 = min(line0, geometry.lines - 2.0)
    x, y, _ = geometry.image_to_ground(
        np.array([line0, line0, line0 + 1.0]), np.array([nadir, nadir + 1.0, nadir])
    )
    across = float(np.hypot(x[1] - x[0], y[1] - y[0]))
    along = float(np.hypot(x[2] - x[0], y[2] - y[0]))
    return 0.5 * (across + along)
