"""An orientation document in memory: what ``orientation.json`` holds (:class:`Orientation`, one
:class:`StripOrientation` per strip, the :class:`MapReference`); :mod:`scangeo.orientation.file` reads
and writes it (through :mod:`scangeo.orientation.codec`) and finds the one of a variant.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from scangeo.errors import OrientationFileError
from scangeo.frames import ProjectFrame
from scangeo.orientation.models import GpsImuModel, ModelSet
from scangeo.sensors.models import Pushbroom, Whiskbroom
from scangeo.sensors.strip import Mounting, StripGeometry
from scangeo.timing import LineTiming
from scangeo.trajectory.spline import OrientationSpline

#: the schema this version writes and reads
SCHEMA = "scangeo.orientation/1"
FILE_NAME = "orientation.json"
#: the variant name of direct georeferencing (the GPS/IMU as measured; needs no results folder)
DIRECT = "DG"

SensorModel = Whiskbroom | Pushbroom


@dataclass(frozen=True)
class StripOrientation:
    """One strip: its orientation spline (navigation reference point, project frame), line timing
    and number of image lines."""

    id: str
    lines: int
    timing: LineTiming
    spline: OrientationSpline


@dataclass(frozen=True)
class MapReference:
    """The project frame P (east-north-up at a geodetic origin on WGS84), the map CRS (WKT) and
    the geoid that relates the map's orthometric heights to ellipsoidal ones."""

    frame: ProjectFrame
    crs: str
    geoid_undulation_m: float | None = None
    geoid_file: str | None = None


@dataclass(frozen=True)
class Orientation:
    """The orientation of a variant: what ``orientation.json`` holds (see the module doc).

    ``coefficients`` maps a GPS/IMU model id to its coefficients (in the order of
    ``GpsImuModel.names()``; metres and radians); ``calibrated`` names the calibration values
    the adjustment estimated (the others are the project's). ``path`` is the file it was read
    from (None when built in memory).
    """

    variant: str
    adjusted: bool
    sensor: SensorModel
    mounting: Mounting
    strips: Mapping[str, StripOrientation]
    reference: MapReference
    models: tuple[GpsImuModel, ...] = ()
    coefficients: dict[str, np.ndarray] = field(default_factory=dict)
    calibrated: tuple[str, ...] = ()
    sigma0: float | None = None
    path: Path | None = None

    def strip(self, strip_id: str) -> StripOrientation:
        try:
            return self.strips[strip_id]
        except KeyError:
            where = self.path or f"the orientation of {self.variant}"
            raise OrientationFileError(
                f"{where}: no strip {strip_id!r} (strips: {', '.join(self.strips)})") from None

    def geometry(self, strip_id: str) -> StripGeometry:
        """The strip's geometry: spline, timing, lines, sensor with its calibration, mounting."""
        s = self.strip(strip_id)
        return StripGeometry(self.sensor, s.spline, s.timing, s.lines, self.mounting, strip_id)

    def breaks(self, strip_id: str) -> list[float]:
        """Break epochs (s) of the strip's split GPS/IMU models: where a sub-model follows another."""
        return sorted(m.t_start for m in self.models if m.follows is not None and strip_id in m.strips)

    def correction(self, strip_id: str, t: np.ndarray, p_gps: np.ndarray) -> np.ndarray:
        """The correction function c(t) (n, 6: m, rad) of the strip's GPS/IMU models at times t
        (``p_gps`` the GPS positions there, for models with a rigid rotation); the orientation is
        the GPS/IMU plus it."""
        coefficients = {m.key: self.coefficients[m.id] for m in self.models}
        return ModelSet(list(self.models)).correction(strip_id, t, p_gps, coefficients)


def strip_geometries(doc: Orientation) -> dict[str, StripGeometry]:
    """The geometry of every strip of an orientation."""
    return {sid: doc.geometry(sid) for sid in doc.strips}


__all__ = ["DIRECT", "FILE_NAME", "SCHEMA", "MapReference", "Orientation", "SensorModel", "StripOrientation",
           "strip_geometries"]
