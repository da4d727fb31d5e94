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
