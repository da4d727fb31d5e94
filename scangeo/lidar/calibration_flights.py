"""Forward/reverse flights: which errors cancel, and recovery of attitude errors from planimetric
differences alone.

Pattern (level flight, flat terrain, world axes north/east/up, metres):

* A: flown north along the line east = 0;
* B: flown south along the same line (the reverse flight);
* C: flown north along the line east = ``offset`` (a parallel strip, same direction).

``D_AB(e)`` and ``D_AC(e)`` are the differences of the computed positions of the same ground point at
east ``e`` (A minus B, A minus C): what matching the point clouds measures. With the error convention
of :mod:`scangeo.lidar.laser_equation` (true = used + delta, error = computed - true):

* pitch   ``= -D_AB,north(0) / (2 H)``   (nadir: along-track difference over the height)
* roll    ``= +D_AB,east(0) / (2 H)``    (nadir: across-track difference over the height)
* heading ``= D_AC,north(offset/2) / offset``

A rotation about the vertical is the same rotation for both directions, so a heading error cancels
in the forward/reverse pair: the difference of ``D_AB,north`` at the two swath edges over the swath
width (:attr:`AttitudeRecovery.heading_from_edges`) stays zero; heading needs the parallel strip C.

What cancels in A-B: every world-fixed error (GPS offset, deflection of the vertical), the errors
symmetric about nadir (range offset, scan-angle error), the vertical lever arm. What does not:
every body-fixed rotation (IMU attitude, mounting, index error, scan-plane tilts: inseparable, they
add up), and body-fixed horizontal shifts (lever arm x/y, time synchronisation: ``shift / H``).
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from scangeo.errors import LidarError
from scangeo.lidar.laser_equation import FlightGeometry, SystematicErrors, error_vectors

#: The example flights of ``scangeo lidar forward-reverse`` (docs/lidar.md, section 2): 1500 m above
#: ground, 40 deg total scan angle, 2001 pulses per line.
EXAMPLE_GEOMETRY = FlightGeometry(height=1500.0, fov=float(np.radians(40.0)), pulses=2001)

#: The errors of the example flights: an IMU attitude error (0.03, -0.02, 0.05 deg) to recover, and
#: errors that cancel in the forward/reverse pair: a 0.2 m range offset, a 0.05 deg scan-angle error,
#: a GPS offset (0.3, -0.2, 0.4 m north, east, down) and a 0.1 m vertical lever-arm error.
EXAMPLE_ERRORS = SystematicErrors(
    imu=tuple(float(v) for v in np.radians((0.03, -0.02, 0.05))),  # type: ignore[arg-type]  # three values
    range_offset=0.2, scan_angle_error=float(np.radians(0.05)), gps=(0.3, -0.2, 0.4), lever_arm=(0.0, 0.0, 0.1),
)


def world_errors(
    geometry: FlightGeometry, errors: SystematicErrors, line_east: float = 0.0
) -> tuple[np.ndarray, np.ndarray]:
    """Errors (north, east, up; m) of one scan line against the true ground east coordinate.

    Returns ``(east, err_W)`` sorted by east; ``line_east`` shifts the flight line (m).
    """
    err_F, true_F = error_vectors(geometry, errors)
    c, s = np.cos(geometry.heading), np.sin(geometry.heading)

    def to_world(v: np.ndarray) -> np.ndarray:
        return np.c_[c * v[:, 0] - s * v[:, 1], s * v[:, 0] + c * v[:, 1], v[:, 2]]

    east = to_world(true_F)[:, 1] + line_east
    order = np.argsort(east)
    return east[order], to_world(err_F)[order]


def _at(east: np.ndarray, err: np.ndarray, e: float) -> np.ndarray:
    if not east[0] <= e <= east[-1]:
        raise LidarError(f"ground position east = {e:.1f} m is outside a strip ({east[0]:.1f} .. {east[-1]:.1f} m)")
    return np.array([np.interp(e, east, err[:, k]) for k in range(3)])


@dataclass(frozen=True)
class AttitudeRecovery:
    """Attitude errors (rad) recovered from planimetric differences, and the differences used (m)."""

    roll: float
    pitch: float
    heading: float
    heading_from_edges: float
    d_ab_nadir: np.ndarray
    d_ac_middle: np.ndarray


def recover_attitude(
    geometry: FlightGeometry, errors: SystematicErrors, offset: float | None = None
) -> AttitudeRecovery:
    """Simulate A, B, C with ``errors`` and recover roll, pitch, heading from planimetric differences.

    Parameters
    ----------
    geometry : FlightGeometry
        Height, scan angle, speed of the flights; its heading is ignored (A and C fly north, B south).
    errors : SystematicErrors
        All systematic errors present during the three flights.
    offset : float, optional
        East offset of strip C, m (default: half the swath width).
    """
    H = geometry.height
    swath = 2 * H * np.tan(geometry.fov / 2)
    offset = swath / 2 if offset is None else offset
    north = replace(geometry, heading=0.0, roll=0.0, pitch=0.0)
    south = replace(north, heading=np.pi)
    eA, wA = world_errors(north, errors)
    eB, wB = world_errors(south, errors)
    eC, wC = world_errors(north, errors, line_east=offset)
    d_ab = _at(eA, wA, 0.0) - _at(eB, wB, 0.0)
    d_ac = _at(eA, wA, offset / 2) - _at(eC, wC, offset / 2)
    edge = 0.45 * swath
    heading_edges = ((_at(eA, wA, edge) - _at(eB, wB, edge))[0] - (_at(eA, wA, -edge) - _at(eB, wB, -edge))[0]) / (
        2 * edge
    )
    return AttitudeRecovery(
        roll=float(d_ab[1] / (2 * H)),
        pitch=float(-d_ab[0] / (2 * H)),
        heading=float(d_ac[0] / offset),
        heading_from_edges=float(heading_edges),
        d_ab_nadir=d_ab,
        d_ac_middle=d_ac,
    )


def body_fixed_attitude(errors: SystematicErrors, height: float, speed: float) -> np.ndarray:
    """What :func:`recover_attitude` is expected to return (rad): IMU + mounting attitude, the index
    error in roll, the scan-plane lean in pitch and skew in heading, and the body-fixed horizontal
    shifts (lever arm x/y, speed * sync offset) over the height in pitch/roll."""
    e = errors
    roll = e.imu[0] + e.mounting[0] - e.index_error - e.lever_arm[1] / height
    pitch = e.imu[1] + e.mounting[1] + e.plane_lean + (e.lever_arm[0] + speed * e.sync_offset) / height
    heading = e.imu[2] + e.mounting[2] + e.plane_skew
    return np.array([roll, pitch, heading])
