"""Typed keys of the line-scanner block's unknowns: one small frozen dataclass per kind of parameter block.

A key names a block of unknowns (``Knots("12")`` are the spline knot values of strip 12,
``Ground("P17")`` the coordinates of ground point P17). The base class :class:`~scangeo.lsq.keys.Key`
is the engine's; ``Correction(model)`` lives with the GPS/IMU models in :mod:`scangeo.orientation.models`.
"""
from __future__ import annotations

from dataclasses import dataclass

from scangeo.lsq.keys import Key


@dataclass(frozen=True, slots=True)
class Knots(Key):
    """Knot values of the orientation spline of one strip (``n_knots x 6``: x, y, z, roll, pitch, heading)."""

    strip: str


@dataclass(frozen=True, slots=True)
class Ground(Key):
    """Coordinates of one ground point in the project frame P (x, y, z; metres)."""

    point: str


@dataclass(frozen=True, slots=True)
class Boresight(Key):
    """Boresight angles of the sensor in the body frame (roll, pitch, heading; radians)."""


@dataclass(frozen=True, slots=True)
class LeverArm(Key):
    """Lever arm from the navigation reference point to the projection centre (body frame, metres)."""


@dataclass(frozen=True, slots=True)
class TimeOffset(Key):
    """Sensor-to-navigation time offset (seconds)."""


@dataclass(frozen=True, slots=True)
class ScanIndex(Key):
    """Whiskbroom index error: an additive scan-angle offset (radians)."""


@dataclass(frozen=True, slots=True)
class ScanScale(Key):
    """Whiskbroom scan-angle scale error (dimensionless, relative)."""


@dataclass(frozen=True, slots=True)
class AcrossOffset(Key):
    """Pushbroom across-track offset of the look angles' tangents (radians near the centre of the field;
    ``scangeo.sensors.models.Pushbroom``)."""


@dataclass(frozen=True, slots=True)
class AcrossScale(Key):
    """Pushbroom across-track scale of the look angles' tangents about the centre pixel (relative)."""


@dataclass(frozen=True, slots=True)
class AlongOffset(Key):
    """Pushbroom along-track offset of the detector line's look angles' tangents (radians)."""


#: The calibration blocks in report order, with their names in ``calibrate = [...]`` and orientation.json's
#: ``calibrated``, and the unit of their values (rad, m, s or 1).
CALIBRATION_KEYS: tuple[tuple[Key, str, str], ...] = (
    (Boresight(), "boresight", "rad"), (LeverArm(), "lever_arm", "m"), (TimeOffset(), "time_offset", "s"),
    (ScanIndex(), "index_error", "rad"), (ScanScale(), "scale_error", "1"),
    (AcrossOffset(), "across_offset", "rad"), (AcrossScale(), "across_scale", "1"),
    (AlongOffset(), "along_offset", "rad"),
)
