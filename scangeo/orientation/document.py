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

    Parameters
    ----------
    variant : str
        The variant's name.
    adjusted : bool
        False for DG (the GPS/IMU as measured, fitted by the spline).
    sensor : SensorModel
        The sensor model with its calibration (index and scale error of a whiskbroom).
    mounting : Mounting
        Lever arm (metres, body frame), boresight (radians), time offset (seconds).
    strips : mapping of str to StripOrientation
        Per strip: lines, line timing, the orientation spline (project frame: x, y, z in metres, roll,
        pitch, heading in radians).
    reference : MapReference
        The map CRS and the project frame's origin.
    models : tuple of GpsImuModel
        The GPS/IMU models of the variant (strips, time span, degrees, breaks).
    coefficients : dict
        GPS/IMU model id -> its coefficients (in the order of ``GpsImuModel.names()``; metres and radians).
    calibrated : tuple of str
        The calibration values the adjustment estimated (the others are the project's).
    sigma0 : float or None
        sigma0 a posteriori of the adjustment (None for DG).
    path : Path or None
        The file it was read from (None when built in memory).
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
        """One strip's orientation.

        Parameters
        ----------
        strip_id : str
            The strip's id.

        Returns
        -------
        StripOrientation
            Its lines, line timing and spline (project frame).

        Raises
        ------
        OrientationFileError
            No such strip in the orientation.
        """
        try:
            return self.strips[strip_id]
        except KeyError:
            where = self.path or f"the orientation of {self.variant}"
            raise OrientationFileError(
                f"{where}: no strip {strip_id!r} (strips: {', '.join(self.strips)})") from None

    def geometry(self, strip_id: str) -> StripGeometry:
        """A strip's geometry: spline, timing, lines, sensor with its calibration, mounting.

        Parameters
        ----------
        strip_id : str
            The strip's id.

        Returns
        -------
        StripGeometry
            Ground <-> image of the strip, project frame.
        """
        s = self.strip(strip_id)
        return StripGeometry(self.sensor, s.spline, s.timing, s.lines, self.mounting, strip_id)

    def breaks(self, strip_id: str) -> list[float]:
        """Where the strip's split GPS/IMU models break: where a sub-model follows another.

        Parameters
        ----------
        strip_id : str
            The strip's id.

        Returns
        -------
        list of float
            Break epochs, seconds of the project's time base (empty: not split).
        """
        return sorted(m.t_start for m in self.models if m.follows is not None and strip_id in m.strips)

    def correction(self, strip_id: str, t: np.ndarray, p_gps: np.ndarray) -> np.ndarray:
        """The correction function of the strip's GPS/IMU models: the orientation is the GPS/IMU plus it.

        Parameters
        ----------
        strip_id : str
            The strip's id.
        t : (n,) ndarray
            Times, seconds of the project's time base.
        p_gps : (n, 3) ndarray
            The GPS positions at those times, metres, project frame (for models with a rigid rotation).

        Returns
        -------
        (n, 6) ndarray
            c(t): x, y, z (metres, project frame), roll, pitch, heading (radians).
        """
        coefficients = {m.key: self.coefficients[m.id] for m in self.models}
        return ModelSet(list(self.models)).correction(strip_id, t, p_gps, coefficients)


def strip_geometries(doc: Orientation) -> dict[str, StripGeometry]:
    """The geometry of every strip of an orientation."""
    return {sid: doc.geometry(sid) for sid in doc.strips}


__all__ = ["DIRECT", "FILE_NAME", "SCHEMA", "MapReference", "Orientation", "SensorModel", "StripOrientation",
           "strip_geometries"]
