"""Rectification settings: a typed frozen dataclass, readable from a TOML table.

A ``[rectify]`` table (a settings file given with ``--config``) holds the same keys as
:class:`RectifyOptions`; ``[rectify.geotiff]`` those of :class:`GeoTiffProfile`. Both are settings
dataclasses of :mod:`scangeo.io.schema`: every key's type, range and unit is checked, and an error
names the file and the key (``rectify.toml [rectify.igm]: expected true or false, found 'false'``).
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import ClassVar

from scangeo.errors import RectifyOptionsError
from scangeo.io.schema import Rule, check, read, setting
from scangeo.rectify.geotiff import GeoTiffProfile
from scangeo.rectify.inverse_map import InverseMapOptions
from scangeo.rectify.resample import RESAMPLING

_FINITE = Rule(math.isfinite, "finite")

#: optional per-cell layers (written as bands of NAME.layers.tif, float32, NaN nodata)
LAYERS = {
    "scan_angle": "scan angle of the pixel in the sensor frame, degrees (positive right)",
    "view_zenith": "angle between the ray to the sensor and the vertical, degrees",
    "time": "acquisition time, seconds of the project's time base",
    "ground_pixel": "ground pixel size: square root of the ground area of the image pixel, metres",
    "image_line": "image line the cell was resampled at (the inverse map; 0-based, pixel centres at integers)",
    "image_pixel": "image pixel the cell was resampled at (the inverse map)",
}


@dataclass(frozen=True)
class RectifyOptions:
    """How strips are rectified (docs/rectify.md; the ``[rectify]`` table of the settings file).

    Built in Python or read from a file, every field is checked the same way (:mod:`scangeo.io.schema`).

    Parameters
    ----------
    resolution : float or None
        Output cell size, map units; None: the nadir ground pixel (two significant digits; of a platform's
        strips, the finest of its sensors').
    bounds : tuple of 4 float or None
        (xmin, ymin, xmax, ymax) of the output, map CRS; None: the strip's footprint.
    resampling : str
        ``nearest``, ``bilinear`` or ``cubic``.
    max_error_px : float
        Tolerance of the inverse map's validation sample, image pixels (a larger difference from the
        exact solution is logged as a warning).
    memory_budget_mb : float
        Memory a strip may use for its working arrays, MiB (sets the tile size).
    tile_size : int or None
        Output tile size, cells, a multiple of 16 (None: from the memory budget).
    nodata : float or None
        Output nodata value (None: the source's, else 0 for integers, NaN for floats).
    occlusion : bool
        Make ground hidden by terrain nodata.
    layers : tuple of str
        Optional per-cell layers among :data:`LAYERS` (written to NAME.layers.tif).
    igm, glt : bool
        Also write the ENVI-style IGM (image -> map coordinates) and GLT (map -> image).
    mosaic : bool
        Also write a mosaic of the strips rectified (batch runs only; the cell closest to nadir wins).
    geotiff : GeoTiffProfile
        Layout of the GeoTIFFs.

    Raises
    ------
    RectifyOptionsError
        A field of the wrong type or out of range (``RectifyOptions.max_error_px: expected a number > 0
        (px), found 0``).
    """

    schema_error: ClassVar[type[Exception]] = RectifyOptionsError

    resolution: float | None = setting(None, gt=0, rule=_FINITE, unit="map unit", default_doc="nadir ground pixel",
                                       doc="output cell size (default: the nadir ground pixel, two significant digits; "
                                           "a platform's: the finest sensor's)")
    bounds: tuple[float, float, float, float] | None = setting(
        None, unit="map unit", default_doc="strip footprint", doc="xmin, ymin, xmax, ymax of the output")
    resampling: str = setting("bilinear", choices=tuple(RESAMPLING), doc="resampling of the image")
    max_error_px: float = setting(0.05, gt=0, doc="tolerance of the inverse map's validation sample")
    memory_budget_mb: float = setting(1024.0, ge=16, doc="memory a strip may use for its working arrays")
    tile_size: int | None = setting(None, ge=16, multiple_of=16, unit="cell", default_doc="from the memory budget",
                                    doc="output tile size")
    nodata: float | None = setting(None, default_doc="the source's", unit="1", allow_nan=True,
                                   doc="output nodata value (default: the source's, else 0 or NaN)")
    occlusion: bool = setting(True, doc="make ground hidden by terrain nodata")
    layers: tuple[str, ...] = setting((), choices=tuple(LAYERS), doc="optional per-cell layers (NAME.layers.tif)")
    igm: bool = setting(False, doc="also write the ENVI-style IGM (image -> map coordinates)")
    glt: bool = setting(False, doc="also write the ENVI-style GLT (map -> image)")
    mosaic: bool = setting(True, doc="also write a mosaic of the strips rectified (batch runs only)")
    geotiff: GeoTiffProfile = setting(GeoTiffProfile(), doc="layout of the GeoTIFFs ([rectify.geotiff])")

    def __post_init__(self) -> None:
        check(self)

    @property
    def inverse_map(self) -> InverseMapOptions:
        """The inverse map's options.

        Returns
        -------
        InverseMapOptions
            Its validation tolerance, ``max_error_px``.
        """
        return InverseMapOptions(max_error_px=self.max_error_px)

    @property
    def strip_layers(self) -> tuple[str, ...]:
        """The layers written per strip.

        Returns
        -------
        tuple of str
            ``layers``, with ``view_zenith`` added when the mosaic needs it.
        """
        if self.mosaic and "view_zenith" not in self.layers:
            return self.layers + ("view_zenith",)
        return self.layers

    def replace(self, **changes) -> RectifyOptions:
        """These options with some fields changed (checked as when built).

        Parameters
        ----------
        **changes
            Field -> new value.

        Returns
        -------
        RectifyOptions
            A new instance.
        """
        return dataclasses.replace(self, **changes)

    @classmethod
    def from_dict(cls, table: dict, source: str = "rectify options") -> RectifyOptions:
        """Options from a parsed ``[rectify]`` TOML table; every key checked (:mod:`scangeo.io.schema`).

        Parameters
        ----------
        table : dict
            The table's keys and values (``geotiff``: a table of :class:`GeoTiffProfile`'s keys).
        source : str
            The file's name, for errors (``source [rectify.KEY]: expected ..., found ...``).

        Returns
        -------
        RectifyOptions
            The options.

        Raises
        ------
        RectifyOptionsError
            An unknown key, or a value of the wrong type or out of range.
        """
        return read(cls, table, source, "rectify")
