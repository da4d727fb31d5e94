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

#: the schema of a one-sensor project's orientation (this version writes and reads it)
SCHEMA = "scangeo.orientation/1"
#: the schema of a platform's orientation: per sensor its model and mounting, per strip its sensor and
#: flight line (this version writes it for projects of several sensors, and reads both)
PLATFORM_SCHEMA = "scangeo.orientation/2"
FILE_NAME = "orientation.json"
#: the variant name of direct georeferencing (the GPS/IMU as measured; needs no results folder)
DIRECT = "DG"

SensorModel = Whiskbroom | Pushbroom


@dataclass(frozen=True)
class StripOrientation:
    """One strip: its orientation spline (navigation reference point, project frame: its flight line's),
    line timing and number of image lines, the sensor that recorded it and its flight line (``""``: the
    strip's own)."""

    id: str
    lines: int
    timing: LineTiming
    spline: OrientationSpline
    sensor: str = ""
    flight_line: str = ""


@dataclass(frozen=True)
class SensorSetup:
    """One sensor of an orientation: its model with its calibration, its mounting (lever arm in metres,
    body frame; boresight in radians; time offset in seconds), and the names of the values the
    adjustment estimated (the others are the project's)."""

    model: SensorModel
    mounting: Mounting
    calibrated: tuple[str, ...] = ()


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
    sensors : mapping of str to SensorSetup
        Per sensor id (``""``: the one sensor of a one-sensor project) its model with its calibration
        (index and scale error of a whiskbroom, offsets and scale of a pushbroom) and its mounting.
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
        The calibration values the adjustment estimated, of any sensor (the others are the project's).
    sigma0 : float or None
        sigma0 a posteriori of the adjustment (None for DG).
    path : Path or None
        The file it was read from (None when built in memory).
    """

    variant: str
    adjusted: bool
    sensors: Mapping[str, SensorSetup]
    strips: Mapping[str, StripOrientation]
    reference: MapReference
    models: tuple[GpsImuModel, ...] = ()
    coefficients: dict[str, np.ndarray] = field(default_factory=dict)
    calibrated: tuple[str, ...] = ()
    sigma0: float | None = None
    path: Path | None = None

    @property
    def is_platform(self) -> bool:
        """Whether the orientation is a platform's.

        Returns
        -------
        bool
            True for several sensors, or one with an id (schema ``scangeo.orientation/2``).
        """
        return len(self.sensors) != 1 or next(iter(self.sensors)) != ""

    def _one(self) -> SensorSetup:
        if len(self.sensors) != 1:
            where = self.path or f"the orientation of {self.variant}"
            raise OrientationFileError(f"{where}: an orientation of {len(self.sensors)} sensors "
                                       f"({', '.join(self.sensors)}); a strip's is Orientation.sensor_of(strip)")
        return next(iter(self.sensors.values()))

    @property
    def sensor(self) -> SensorModel:
        """The sensor model of a one-sensor orientation.

        Returns
        -------
        SensorModel
            The whiskbroom or pushbroom model with its calibration.

        Raises
        ------
        OrientationFileError
            A platform's orientation (its strips' sensors: :meth:`sensor_of`).
        """
        return self._one().model

    @property
    def mounting(self) -> Mounting:
        """The mounting of a one-sensor orientation.

        Returns
        -------
        Mounting
            Lever arm (metres, body frame), boresight (radians), time offset (seconds).

        Raises
        ------
        OrientationFileError
            A platform's orientation (its strips' sensors: :meth:`sensor_of`).
        """
        return self._one().mounting

    def sensor_of(self, strip_id: str) -> SensorSetup:
        """The sensor of a strip: its model with its calibration and its mounting.

        Parameters
        ----------
        strip_id : str
            The strip's id.

        Returns
        -------
        SensorSetup
            Model, mounting, calibrated names.
        """
        sid = self.strip(strip_id).sensor
        try:
            return self.sensors[sid]
        except KeyError:
            where = self.path or f"the orientation of {self.variant}"
            raise OrientationFileError(f"{where}: strip {strip_id} names sensor {sid!r}, which it does not hold "
                                       f"(sensors: {', '.join(self.sensors)})") from None

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
        setup = self.sensor_of(strip_id)
        return StripGeometry(setup.model, s.spline, s.timing, s.lines, setup.mounting, strip_id)

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
        line = self._flight_line(strip_id)
        return sorted(m.t_start for m in self.models if m.follows is not None and line in m.strips)

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
        return ModelSet(list(self.models)).correction(self._flight_line(strip_id), t, p_gps, coefficients)

    def _flight_line(self, strip_id: str) -> str:
        """The flight line a strip's GPS/IMU models serve (its own id when it has its own)."""
        return self.strip(strip_id).flight_line or strip_id


def strip_geometries(doc: Orientation) -> dict[str, StripGeometry]:
    """The geometry of every strip of an orientation."""
    return {sid: doc.geometry(sid) for sid in doc.strips}


__all__ = ["DIRECT", "FILE_NAME", "PLATFORM_SCHEMA", "SCHEMA", "MapReference", "Orientation", "SensorModel",
           "SensorSetup", "StripOrientation", "strip_geometries"]
