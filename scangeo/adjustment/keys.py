"""Typed keys of the line-scanner block's unknowns: one small frozen dataclass per kind of parameter block.

A key names a block of unknowns (``Knots("12")`` are the spline knot values of flight line 12,
``Ground("P17")`` the coordinates of ground point P17, ``Boresight("swir")`` the boresight of sensor
swir). The base class :class:`~scangeo.lsq.keys.Key` is the engine's; ``Correction(model)`` lives with
the GPS/IMU models in :mod:`scangeo.orientation.models`.

The platform's unknowns belong to what they describe: the orientation spline (``Knots``) and the GPS/IMU
corrections to the **flight line** (every sensor recording on it shares them), the mounting (boresight,
lever arm, time offset) and the interior calibration to the **sensor** (``sensor`` is its id, ``""``
for the one sensor of a one-sensor project, whose keys then read as before: ``Boresight()``).
"""
from __future__ import annotations

from dataclasses import dataclass

from scangeo.lsq.keys import Key


@dataclass(frozen=True, slots=True)
class Knots(Key):
    """Knot values of the orientation spline of one flight line (``n_knots x 6``: x, y, z, roll, pitch,
    heading of the navigation reference point); a strip with its own trajectory is a flight line of its id."""

    flight_line: str


@dataclass(frozen=True, slots=True)
class Ground(Key):
    """Coordinates of one ground point in the project frame P (x, y, z; metres)."""

    point: str


@dataclass(frozen=True, slots=True)
class Boresight(Key):
    """Boresight angles of the sensor in the body frame (roll, pitch, heading; radians)."""

    sensor: str = ""


@dataclass(frozen=True, slots=True)
class LeverArm(Key):
    """Lever arm from the navigation reference point to the projection centre (body frame, metres)."""

    sensor: str = ""


@dataclass(frozen=True, slots=True)
class TimeOffset(Key):
    """Sensor-to-navigation time offset (seconds)."""

    sensor: str = ""


@dataclass(frozen=True, slots=True)
class ScanIndex(Key):
    """Whiskbroom index error: an additive scan-angle offset (radians)."""

    sensor: str = ""


@dataclass(frozen=True, slots=True)
class ScanScale(Key):
    """Whiskbroom scan-angle scale error (dimensionless, relative)."""

    sensor: str = ""


@dataclass(frozen=True, slots=True)
class AcrossOffset(Key):
    """Pushbroom across-track offset of the look angles' tangents (radians near the centre of the field;
    ``scangeo.sensors.models.Pushbroom``)."""

    sensor: str = ""


@dataclass(frozen=True, slots=True)
class AcrossScale(Key):
    """Pushbroom across-track scale of the look angles' tangents about the centre pixel (relative)."""

    sensor: str = ""


@dataclass(frozen=True, slots=True)
class AlongOffset(Key):
    """Pushbroom along-track offset of the detector line's look angles' tangents (radians)."""

    sensor: str = ""


def calibration_keys(sensor: str = "") -> tuple[tuple[Key, str, str], ...]:
    """The calibration blocks of one sensor in report order, with their names in ``calibrate = [...]`` and
    orientation.json's ``calibrated``, and the unit of their values (rad, m, s or 1).

    Parameters
    ----------
    sensor : str
        The sensor's id (``""``: the one sensor of a one-sensor project).

    Returns
    -------
    tuple of (Key, str, str)
        Key, name, unit.
    """
    return (
        (Boresight(sensor), "boresight", "rad"), (LeverArm(sensor), "lever_arm", "m"),
        (TimeOffset(sensor), "time_offset", "s"), (ScanIndex(sensor), "index_error", "rad"),
        (ScanScale(sensor), "scale_error", "1"), (AcrossOffset(sensor), "across_offset", "rad"),
        (AcrossScale(sensor), "across_scale", "1"), (AlongOffset(sensor), "along_offset", "rad"),
    )


#: The calibration blocks of the one sensor of a one-sensor project (:func:`calibration_keys`).
CALIBRATION_KEYS: tuple[tuple[Key, str, str], ...] = calibration_keys()


def calibration_name(key: Key) -> tuple[str, str] | None:
    """The name and unit of a calibration block of any sensor (None: not a calibration key).

    Parameters
    ----------
    key : Key
        A key of the block.

    Returns
    -------
    tuple of (str, str) or None
        Its name in ``calibrate = [...]`` and its unit.
    """
    sensor = getattr(key, "sensor", None)
    if not isinstance(sensor, str):
        return None
    for k, name, unit in calibration_keys(sensor):
        if k == key:
            return name, unit
    return None
