"""The general laser equation and its systematic error terms, for one scan line over a plane.

    p_W = t_GPS + R_G R_N (R_M R_L r + t_L)

* ``r = (0, 0, rho)``: the range vector in the scanner frame (z down along the beam at scan angle 0).
* ``R_L = Rz(skew) Ry(lean) Rx(-theta)``: the scan-angle rotation (theta > 0 to the right of the
  flight direction, so the beam is ``(0, sin theta, cos theta)``) with the two scan-plane tilts.
* ``R_M``: mounting (boresight) rotation, body frame; nominally identity.
* ``R_N = Rz(heading) Ry(pitch) Rx(roll)``: IMU attitude of the body in the local-level NED frame.
* ``t_L``: lever arm (body frame, metres); ``t_GPS``: position of the navigation point (NED, metres).
* ``R_G``: deflection of the vertical (the INS levels to the plumb line; identity when corrected).

Error convention (the same for every term): a systematic error ``delta`` is the part of the true
value that the processing ignores, ``true = used + delta``; the error vector is the computed point
minus the true point, in flight axes (along = flight direction, across = to the right, vertical =
up). With this convention a range offset ``dr`` (true range = measured + dr) gives
``(0, -dr sin theta, dr cos theta)``, i.e. ``(0, 0, dr)`` at nadir.

The scan line runs from the right edge (start, pulse 0, ``theta = +tau``) to the left edge (end,
pulse n-1, ``theta = -tau``), ``tau`` = half the total scan angle. Pulse ``i`` of ``n`` has the true
scan angle ``index + (fov + fov_error) * (1/2 - i/(n-1))``.
"""
from __future__ import annotations

from dataclasses import dataclass, fields, replace

import numpy as np

from scangeo.errors import LidarError
from scangeo.rotation import rot_x, rot_y, rot_z, rph_to_matrix


@dataclass(frozen=True)
class FlightGeometry:
    """A level flight line over a plane.

    Parameters
    ----------
    height : float
        Flying height above the terrain at nadir, metres.
    fov : float
        Total scan angle, radians (the swath edges are at +-fov/2).
    pulses : int
        Pulses per scan line (pulse i of n).
    heading, roll, pitch : float
        Measured attitude of the body in NED, radians (heading from north, clockwise).
    slope_along, slope_across : float
        Terrain gradient (dh/dx, dimensionless) along and across the flight direction; the terrain
        height is ``slope_along * along + slope_across * across`` relative to the nadir point.
    speed : float
        Ground speed, m/s (used by the synchronisation error only).
    """

    height: float
    fov: float
    pulses: int = 101
    heading: float = 0.0
    roll: float = 0.0
    pitch: float = 0.0
    slope_along: float = 0.0
    slope_across: float = 0.0
    speed: float = 60.0

    def __post_init__(self) -> None:
        if not self.height > 0:
            raise LidarError(f"flying height: {self.height} m (expected > 0)")
        if not 0 < self.fov < np.pi:
            raise LidarError(f"total scan angle: {np.degrees(self.fov):.3f} deg (expected 0 < fov < 180)")
        if self.pulses < 3 or self.pulses % 2 == 0:
            raise LidarError(f"pulses per line: {self.pulses} (expected an odd number >= 3, for a nadir pulse)")

    def nominal_scan_angles(self) -> np.ndarray:
        """Scan angle (rad) of each pulse as the processing assumes it: +fov/2 (start) .. -fov/2 (end)."""
        return self.fov * (0.5 - np.arange(self.pulses) / (self.pulses - 1))

    def R_W_F(self) -> np.ndarray:
        """Rotation from flight axes (x along, y right, z down) to NED."""
        return rot_z(self.heading)


@dataclass(frozen=True)
class SystematicErrors:
    """Systematic errors of a laser scanner system: ``true = used + delta`` (see module docstring).

    Angles in radians, lengths in metres, times in seconds.
    """

    range_offset: float = 0.0
    index_error: float = 0.0
    scan_angle_error: float = 0.0          # error of the total scan angle
    plane_lean: float = 0.0                # scan-plane tilt about the across axis (beam leans forward)
    plane_skew: float = 0.0                # scan-plane tilt about the beam's nadir axis (z)
    mounting: tuple[float, float, float] = (0.0, 0.0, 0.0)     # roll, pitch, heading (body)
    imu: tuple[float, float, float] = (0.0, 0.0, 0.0)          # roll, pitch, heading
    lever_arm: tuple[float, float, float] = (0.0, 0.0, 0.0)    # body x, y, z
    gps: tuple[float, float, float] = (0.0, 0.0, 0.0)          # north, east, down
    sync_offset: float = 0.0                                   # navigation time error, s
    deflection: tuple[float, float] = (0.0, 0.0)               # xi (north), eta (east), rad

    def only(self, names: tuple[str, ...]) -> SystematicErrors:
        """A copy keeping only the named fields (the others zero)."""
        zero = SystematicErrors()
        return replace(zero, **{name: getattr(self, name) for name in names})

    def scaled(self, factor: float) -> SystematicErrors:
        """Every term multiplied by ``factor``."""
        values = {}
        for f in fields(self):
            v = getattr(self, f.name)
            values[f.name] = tuple(factor * x for x in v) if isinstance(v, tuple) else factor * v
        return SystematicErrors(**values)  # type: ignore[arg-type]  # same fields, scaled


NO_ERRORS = SystematicErrors()


def _points(geometry: FlightGeometry, errors: SystematicErrors) -> tuple[np.ndarray, np.ndarray]:
    """True and computed points (NED, metres, nadir point of the sensor at the origin's height 0).

    Returns ``(p_true, p_computed)`` of shape ``(pulses, 3)``.
    """
    g, e = geometry, errors
    R_WF = g.R_W_F()
    n = g.pulses
    frac = 0.5 - np.arange(n) / (n - 1)
    theta_used = g.fov * frac
    theta_true = e.index_error + (g.fov + e.scan_angle_error) * frac

    def scanner(theta: np.ndarray, lean: float, skew: float) -> np.ndarray:
        return rot_z(skew) @ rot_y(lean) @ rot_x(-theta)

    def R_N(delta: tuple[float, float, float]) -> np.ndarray:
        return rph_to_matrix(g.roll + delta[0], g.pitch + delta[1], g.heading + delta[2])

    xi, eta = e.deflection
    # the plumb line's down direction leans north by xi and east by eta (relative to the normal)
    R_G_true = rot_x(-eta) @ rot_y(xi)
    S_true = np.array([0.0, 0.0, -g.height])
    l_true = np.asarray(e.lever_arm, dtype=float)
    R_NM_true = R_G_true @ R_N(e.imu) @ rph_to_matrix(*e.mounting)
    u_true = (R_NM_true @ scanner(theta_true, e.plane_lean, e.plane_skew))[:, :, 2]
    A_true = S_true + R_G_true @ R_N(e.imu) @ l_true
    # terrain plane: z_down = -(s . x_h), s in NED from the slopes in flight axes
    s_W = R_WF @ np.array([g.slope_along, g.slope_across, 0.0])
    normal = np.array([s_W[0], s_W[1], 1.0])
    denom = u_true @ normal
    if np.any(denom <= 1e-9):
        raise LidarError("a beam does not reach the terrain plane (scan angle or slope too large)")
    rho_true = -(A_true @ normal) / denom
    p_true = A_true + rho_true[:, None] * u_true

    rho_used = rho_true - e.range_offset
    S_used = S_true - np.asarray(e.gps, dtype=float) - R_WF @ np.array([g.speed * e.sync_offset, 0.0, 0.0])
    u_used = (R_N((0.0, 0.0, 0.0)) @ scanner(theta_used, 0.0, 0.0))[:, :, 2]
    p_used = S_used + rho_used[:, None] * u_used
    return p_true, p_used


def error_vectors(geometry: FlightGeometry, errors: SystematicErrors) -> tuple[np.ndarray, np.ndarray]:
    """Error vector (computed minus true) of every pulse of one scan line, in flight axes.

    Parameters
    ----------
    geometry : FlightGeometry
    errors : SystematicErrors

    Returns
    -------
    err_F : (pulses, 3) float array, metres, (along, across, vertical up).
    true_F : (pulses, 3) float array, metres, the true points in the same axes (origin: nadir point
        on the terrain).
    """
    p_true, p_used = _points(geometry, errors)
    R_FW = geometry.R_W_F().T
    flip = np.array([1.0, 1.0, -1.0])
    err_F = ((p_used - p_true) @ R_FW.T) * flip
    true_F = (p_true @ R_FW.T) * flip
    return err_F, true_F


def height_error_on_terrain(geometry: FlightGeometry, err_F: np.ndarray) -> np.ndarray:
    """Height error relative to the terrain at the computed planimetric position (metres).

    On a slope a planimetric error adds the secondary height error ``-(s_along dx + s_across dy)``:
    ``dh = dz - s_along * d_along - s_across * d_across``.
    """
    return err_F[:, 2] - geometry.slope_along * err_F[:, 0] - geometry.slope_across * err_F[:, 1]


def apparent_plane_tilt(err_F: np.ndarray, true_F: np.ndarray) -> float:
    """Across-track tilt (rad) of the computed surface of a plane, relative to the true plane.

    Positive when the computed surface rises to the right of the flight direction. From the two
    swath edges: ``atan(d(vertical error) / d(computed across))``.
    """
    y = true_F[:, 1] + err_F[:, 1]
    return float(np.arctan2(err_F[0, 2] - err_F[-1, 2], y[0] - y[-1]))
