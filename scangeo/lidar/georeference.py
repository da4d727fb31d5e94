"""The laser equation in the project frame P, its derivatives, and the recovery of a return's
original observations (time, range, scan angle) from its point, the trajectory and the calibration.

    p_P = p_nav(t) + R_PB(t) (R_BS (rho + dr) u_S(theta + dtheta) + a_S + l_B)
    u_S(theta) = (0, sin theta, cos theta),   a_S = (along, 0, 0)

``p_nav`` and ``R_PB = R_ENU_NED Rz(heading) Ry(pitch) Rx(roll)`` come from the GPS/IMU (angles
w.r.t. the project NED frame, :class:`~scangeo.trajectory.stream.ProjectTrajectory`) plus the
correction functions of the GPS/IMU models; ``R_BS = Rz(b3) Ry(b2) Rx(b1)`` is the boresight, ``l_B``
the lever arm, ``dr`` the range offset, ``dtheta`` the scan-angle (index) offset. The scanner frame
S has x along track, y to the right, z down (docs/lidar.md section 1). ``along`` is the return's
small distance from the nominal scan plane that the recovery leaves (zero when the time is solved
for), so that the nominal calibration reproduces the given point exactly.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from scangeo.errors import LidarError
from scangeo.rotation import R_ENU_NED, rph_to_matrix, rph_to_matrix_with_derivatives
from scangeo.trajectory.stream import ProjectTrajectory


@dataclass(frozen=True)
class Calibration:
    """Boresight (roll, pitch, heading; rad), lever arm (body, m), range offset (m), index (rad)."""

    boresight: np.ndarray
    lever_arm: np.ndarray
    range_offset: float = 0.0
    scan_index: float = 0.0

    @classmethod
    def of(cls, boresight=(0.0, 0.0, 0.0), lever_arm=(0.0, 0.0, 0.0), range_offset=0.0, scan_index=0.0) -> Calibration:
        return cls(np.asarray(boresight, float), np.asarray(lever_arm, float), float(range_offset), float(scan_index))


@dataclass
class Polar:
    """Original observations of returns: time (s), range (m), scan angle (rad), along offset (m)."""

    time: np.ndarray
    range: np.ndarray
    angle: np.ndarray
    along: np.ndarray

    def take(self, index) -> Polar:
        return Polar(self.time[index], self.range[index], self.angle[index], self.along[index])


class TrajectorySampler:
    """Linear interpolation of a project-frame trajectory (positions and angles) at any times."""

    def __init__(self, trajectory: ProjectTrajectory, name: str = "") -> None:
        self.trajectory = trajectory
        self.name = name or trajectory.source

    @property
    def span(self) -> tuple[float, float]:
        return float(self.trajectory.time[0]), float(self.trajectory.time[-1])

    def check_covers(self, t: np.ndarray, what: str) -> None:
        lo, hi = self.span
        if t.size and (t.min() < lo or t.max() > hi):
            raise LidarError(
                f"{what}: GPS times {t.min():.3f}..{t.max():.3f} s are not covered by the trajectory "
                f"{self.name} ({lo:.3f}..{hi:.3f} s)"
            )

    def at(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Positions (n, 3) and angles (n, 3) at times ``t``."""
        tr = self.trajectory
        t = np.asarray(t, float)
        pos = np.column_stack([np.interp(t, tr.time, tr.p_P[:, k]) for k in range(3)])
        ang = np.column_stack([np.interp(t, tr.time, tr.angles_P[:, k]) for k in range(3)])
        return pos, ang


def beam(angle: np.ndarray) -> np.ndarray:
    """Unit beam vectors u_S (n, 3) of scan angles (rad)."""
    a = np.asarray(angle, float)
    return np.column_stack([np.zeros_like(a), np.sin(a), np.cos(a)])


def scanner_vectors(polar: Polar, cal: Calibration) -> np.ndarray:
    """r_S (n, 3): (rho + dr) u_S(theta + dtheta) + (along, 0, 0)."""
    r = (polar.range + cal.range_offset)[:, None] * beam(polar.angle + cal.scan_index)
    r[:, 0] += polar.along
    return r


def body_rotations(angles: np.ndarray) -> np.ndarray:
    """R_PB (n, 3, 3) of roll, pitch, heading w.r.t. the project NED frame."""
    return R_ENU_NED @ rph_to_matrix(angles[:, 0], angles[:, 1], angles[:, 2])


def georeference(pos: np.ndarray, angles: np.ndarray, polar: Polar, cal: Calibration) -> np.ndarray:
    """Points p_P (n, 3) of returns with navigation positions and angles (n, 3) at their times."""
    R_BS = rph_to_matrix(*cal.boresight)
    v = scanner_vectors(polar, cal) @ R_BS.T + cal.lever_arm
    return pos + np.einsum("nij,nj->ni", body_rotations(angles), v)


@dataclass
class Derivatives:
    """dp/d(unknown) of returns: ``attitude`` (n, 3, 3) columns roll, pitch, heading; ``boresight``
    (n, 3, 3); ``lever_arm`` (n, 3, 3); ``range`` (n, 3); ``index`` (n, 3). dp/d position is I."""

    points: np.ndarray
    attitude: np.ndarray
    boresight: np.ndarray
    lever_arm: np.ndarray
    range: np.ndarray
    index: np.ndarray


def derivatives(pos: np.ndarray, angles: np.ndarray, polar: Polar, cal: Calibration) -> Derivatives:
    """The points and their derivatives w.r.t. attitude, boresight, lever arm, range and index offsets."""
    R_NB, dR_NB = rph_to_matrix_with_derivatives(angles[:, 0], angles[:, 1], angles[:, 2])
    R_PB = R_ENU_NED @ R_NB
    R_BS, dR_BS = rph_to_matrix_with_derivatives(*cal.boresight)
    r_S = scanner_vectors(polar, cal)
    v = r_S @ R_BS.T + cal.lever_arm
    points = pos + np.einsum("nij,nj->ni", R_PB, v)
    att = np.stack([np.einsum("ij,njk,nk->ni", R_ENU_NED, dR_NB[:, k], v) for k in range(3)], axis=2)
    bore = np.stack([np.einsum("nij,jk,nk->ni", R_PB, dR_BS[k], r_S) for k in range(3)], axis=2)
    a = polar.angle + cal.scan_index
    u = beam(a)
    du = np.column_stack([np.zeros_like(a), np.cos(a), -np.sin(a)]) * (polar.range + cal.range_offset)[:, None]
    rng = np.einsum("nij,nj->ni", R_PB, u @ R_BS.T)
    idx = np.einsum("nij,nj->ni", R_PB, du @ R_BS.T)
    return Derivatives(points, att, bore, R_PB, rng, idx)


def scanner_frame(points: np.ndarray, pos: np.ndarray, angles: np.ndarray, cal: Calibration) -> np.ndarray:
    """``R_BS^T (R_PB^T (p - p_nav) - l_B)`` (n, 3): the returns in the scanner frame."""
    R_BS = rph_to_matrix(*cal.boresight)
    body = np.einsum("nji,nj->ni", body_rotations(angles), points - pos) - cal.lever_arm
    return body @ R_BS


def recover(
    points: np.ndarray,
    t: np.ndarray,
    sampler: TrajectorySampler,
    cal: Calibration,
    solve_time: bool = False,
    iterations: int = 4,
) -> Polar:
    """The original observations of points p_P (n, 3) at GPS times ``t`` (start values when
    ``solve_time``: the time is then moved until the point lies in the scan plane, ``along = 0``).

    The nominal calibration ``cal`` and the trajectory reproduce the points exactly:
    ``georeference(*sampler.at(polar.time), polar, cal) == points``.
    """
    t = np.array(t, float)
    points = np.asarray(points, float)
    if solve_time:
        for _ in range(iterations):
            h = 1e-3
            s0 = scanner_frame(points, *sampler.at(t), cal)[:, 0]
            s1 = scanner_frame(points, *sampler.at(t + h), cal)[:, 0]
            slope = (s1 - s0) / h
            ok = np.abs(slope) > 1e-6
            t = t - np.where(ok, s0 / np.where(ok, slope, 1.0), 0.0)
            lo, hi = sampler.span
            t = np.clip(t, lo, hi)
    s = scanner_frame(points, *sampler.at(t), cal)
    rho_yz = np.hypot(s[:, 1], s[:, 2])
    angle = np.arctan2(s[:, 1], s[:, 2]) - cal.scan_index
    return Polar(t, rho_yz - cal.range_offset, angle, s[:, 0])
