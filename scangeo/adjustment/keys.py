"""Typed keys of the unknowns: one small frozen dataclass per kind of parameter block.

A key names a block of unknowns (``Knots("12")`` are the spline knot values of strip 12,
``Ground("P17")`` the coordinates of ground point P17). Keys are hashable values, compared by kind
and fields; never build them from f-strings. ``key.label`` gives a readable name for reports.
"""
from __future__ import annotations

from dataclasses import dataclass, fields


@dataclass(frozen=True, slots=True)
class Key:
    """Base of every key. Subclasses are frozen dataclasses whose fields identify the block."""

    @property
    def label(self) -> str:
        """``Kind(field=value, ...)`` or ``Kind()`` for singletons, for reports and messages."""
        args = ", ".join(f"{f.name}={getattr(self, f.name)}" for f in fields(self))
        return f"{type(self).__name__}({args})"

    def __str__(self) -> str:
        return self.label


@dataclass(frozen=True, slots=True)
class Knots(Key):
    """Knot values of the orientation spline of one strip (``n_knots x 6``: x, y, z, roll, pitch, heading)."""

    strip: str


@dataclass(frozen=True, slots=True)
class Correction(Key):
    """Coefficients of the correction function of one GPS/IMU model (see ``scangeo.adjustment.models``)."""

    model: str


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
class Unknown(Key):
    """A generic named block, for problems outside the photogrammetric model (tests, laser strips)."""

    name: str


@dataclass(frozen=True, slots=True)
class Plane(Key):
    """A planar patch of laser strips (tilts u, v of its normal and offset d; see ``scangeo.lidar.groups``)."""

    patch: str


@dataclass(frozen=True, slots=True)
class RangeOffset(Key):
    """Laser range offset (metres): true range = measured + offset."""
