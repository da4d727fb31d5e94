"""Error vectors per error source at the start, middle and end of a scan line, and in total.

The sources group the terms of :class:`~scangeo.lidar.laser_equation.SystematicErrors`:

==========  ==========================================================
range       ``range_offset``
scanner     ``index_error``, ``scan_angle_error``, ``plane_lean``, ``plane_skew``
mounting    ``mounting``
imu         ``imu``
lever_arm   ``lever_arm``
gps         ``gps``, ``sync_offset``
deflection  ``deflection``
==========  ==========================================================
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from scangeo.lidar.laser_equation import (
    FlightGeometry,
    SystematicErrors,
    apparent_plane_tilt,
    error_vectors,
    height_error_on_terrain,
)

#: Error sources and the fields of SystematicErrors each one groups, in report order.
SOURCES: dict[str, tuple[str, ...]] = {
    "range": ("range_offset",),
    "scanner": ("index_error", "scan_angle_error", "plane_lean", "plane_skew"),
    "mounting": ("mounting",),
    "imu": ("imu",),
    "lever_arm": ("lever_arm",),
    "gps": ("gps", "sync_offset"),
    "deflection": ("deflection",),
}


@dataclass(frozen=True)
class LineErrors:
    """Error vectors (computed minus true; along, across, vertical up; metres) along one scan line.

    ``start``/``middle``/``end`` are the right edge, nadir and left edge; ``plane_tilt`` (rad) is the
    apparent across-track tilt of a horizontal plane (positive: rises to the right);
    ``height_on_terrain`` the height error relative to the sloped terrain at the three positions.
    """

    start: np.ndarray
    middle: np.ndarray
    end: np.ndarray
    plane_tilt: float
    height_on_terrain: np.ndarray

    def as_dict(self) -> dict:
        """JSON-ready: metres, the tilt in degrees."""
        return {
            "start": [float(v) for v in self.start],
            "middle": [float(v) for v in self.middle],
            "end": [float(v) for v in self.end],
            "plane_tilt_deg": float(np.degrees(self.plane_tilt)),
            "height_on_terrain": [float(v) for v in self.height_on_terrain],
        }


def line_errors(geometry: FlightGeometry, errors: SystematicErrors) -> LineErrors:
    """Error vectors of one scan line at its start, middle and end (see :class:`LineErrors`)."""
    err_F, true_F = error_vectors(geometry, errors)
    mid = geometry.pulses // 2
    dh = height_error_on_terrain(geometry, err_F)
    return LineErrors(
        start=err_F[0], middle=err_F[mid], end=err_F[-1],
        plane_tilt=apparent_plane_tilt(err_F, true_F),
        height_on_terrain=dh[[0, mid, -1]],
    )


def given_sources(errors: SystematicErrors) -> list[str]:
    """The sources of which at least one term is non-zero, in report order."""
    names = []
    for name, terms in SOURCES.items():
        values = np.concatenate([np.atleast_1d(getattr(errors, t)) for t in terms])
        if np.any(values != 0.0):
            names.append(name)
    return names


def error_budget_by_source(
    geometry: FlightGeometry, errors: SystematicErrors, sources: list[str] | None = None
) -> dict[str, LineErrors]:
    """Line errors of each source alone and of all together (key ``"total"``).

    Parameters
    ----------
    geometry : FlightGeometry
    errors : SystematicErrors
    sources : list of str, optional
        Sources to report (default: those with a non-zero term).
    """
    names = given_sources(errors) if sources is None else sources
    result = {name: line_errors(geometry, errors.only(SOURCES[name])) for name in names}
    result["total"] = line_errors(geometry, errors)
    return result
