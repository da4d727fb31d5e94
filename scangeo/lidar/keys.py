"""Typed keys of the laser strip adjustment's own unknowns (the calibration keys it shares with the
image block, ``Boresight``, ``LeverArm``, ``ScanIndex``, live in :mod:`scangeo.adjustment.keys`)."""
from __future__ import annotations

from dataclasses import dataclass

from scangeo.lsq.keys import Key


@dataclass(frozen=True, slots=True)
class Plane(Key):
    """A planar patch of laser strips (tilts u, v of its normal and offset d; see ``scangeo.lidar.groups``)."""

    patch: str


@dataclass(frozen=True, slots=True)
class RangeOffset(Key):
    """Laser range offset (metres): true range = measured + offset; ``sensor`` the laser's id on a platform
    (``""``: the one sensor of a laser project)."""

    sensor: str = ""


@dataclass(frozen=True, slots=True)
class StripHeight(Key):
    """The height error of a strip in the 1D strip adjustment: offset (m) and, optionally, along- and
    across-track tilts (m/m) (``scangeo.lidar.strip_adjustment``)."""

    strip: str
