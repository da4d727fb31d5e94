"""Typed keys of the unknowns: the base class, and a generic named key.

A key names a block of unknowns. Keys are hashable values, compared by kind and fields; never build
them from f-strings. ``key.label`` gives a readable name for reports. The keys of the line-scanner
block (``Knots``, ``Ground``, ``Boresight``, ...) live in :mod:`scangeo.adjustment.keys`, the key of a
GPS/IMU model's correction (``Correction``) in :mod:`scangeo.orientation.models`.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, fields


@dataclass(frozen=True, slots=True)
class Key:
    """Base of every key. Subclasses are frozen dataclasses whose fields identify the block."""

    @property
    def label(self) -> str:
        """``Kind(field=value, ...)`` or ``Kind()`` for singletons, for reports and messages; a field that is
        the empty string is left out (the one sensor of a one-sensor project: ``Boresight()``)."""
        args = ", ".join(f"{f.name}={getattr(self, f.name)}" for f in fields(self) if getattr(self, f.name) != "")
        return f"{type(self).__name__}({args})"

    def __str__(self) -> str:
        return self.label


@dataclass(frozen=True, slots=True)
class Unknown(Key):
    """A generic named block, for problems outside the photogrammetric model (tests, laser strips)."""

    name: str


#: Maps an observation's id (``ObservationGroup.ids``) to the key of the point it measures, e.g.
#: ``Ground`` of the line-scanner block. The engine uses it where it needs "the point an observation
#: belongs to" (the note on a point regularised after a non-separable blunder; the external
#: reliability on the observation's own point). None: observations have no point.
PointKey = Callable[[str], Key]
