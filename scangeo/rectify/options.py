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

from scangeo.errors import ProjectFileError, RectifyOptionsError
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
    """How strips are rectified.

    Parameters
    ----------
    resolution : output cell size, map units; None: the nadir ground pixel (two significant
        digits).
    bounds : (xmin, ymin, xmax, ymax) of the output, map units; None: the strip footprint.
    resampling : ``nearest``, ``bilinear`` or ``cubic``.
    max_error_px : tolerance of the inverse map's validation sample, image pixels (a larger
        difference from the exact solution is logged as a warning).
    memory_budget_mb : memory a strip may use for its working arrays, MiB (sets the tile size).
    tile_size : output tile size, cells (None: from the memory budget).
    nodata : output nodata value (None: the source's, else 0 for integers, NaN for floats).
    occlusion : make ground hidden by terrain nodata.
    layers : optional layers among :data:`LAYERS`.
    igm, glt : also write the ENVI-style IGM (image -> map coordinates) and GLT.
    mosaic : also write a mosaic of all strips (batch runs only).
    geotiff : layout of the GeoTIFFs.
    """

    resolution: float | None = setting(None, gt=0, rule=_FINITE, unit="map unit", default_doc="nadir ground pixel",
                                       doc="output cell size (default: the nadir ground pixel, two significant digits)")
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
    mosaic: bool = setting(False, doc="also write a mosaic of all strips (batch runs only)")
    geotiff: GeoTiffProfile = setting(GeoTiffProfile(), doc="layout of the GeoTIFFs ([rectify.geotiff])")

    def __post_init__(self) -> None:
        check(self, RectifyOptionsError)

    @property
    def inverse_map(self) -> InverseMapOptions:
        return InverseMapOptions(max_error_px=self.max_error_px)

    @property
    def strip_layers(self) -> tuple[str, ...]:
        """Layers written per strip (the mosaic needs the view zenith angle)."""
        if self.mosaic and "view_zenith" not in self.layers:
            return self.layers + ("view_zenith",)
        return self.layers

    def replace(self, **changes) -> RectifyOptions:
        return dataclasses.replace(self, **changes)

    @classmethod
    def from_dict(cls, table: dict, source: str = "rectify options") -> RectifyOptions:
        """Options from a ``[rectify]`` TOML table; every key checked (:mod:`scangeo.io.schema`),
        errors naming ``source`` (the file) and the key."""
        try:
            return read(cls, table, source, "rectify")
        except ProjectFileError as exc:
            raise RectifyOptionsError(str(exc)) from exc
