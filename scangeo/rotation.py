"""Rotation matrices from roll, pitch, heading and back; their derivatives.

Convention (docs/conventions.md): ``R_LB = Rz(heading) Ry(pitch) Rx(roll)`` rotates body-frame vectors
(x forward, y right, z down) into a north-east-down frame. Angles in radians. All functions are
vectorised: angles of shape ``(n,)`` give matrices of shape ``(n, 3, 3)``.
"""
from __future__ import annotations

import numpy as np

#: Rotation from a north-east-down frame to an east-north-up frame (and back: it is symmetric).
R_ENU_NED = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])


def rot_x(angle: np.ndarray | float) -> np.ndarray:
    """Rotation about x by ``angle`` (rad): ``(..., 3, 3)``."""
    a = np.asarray(angle, dtype=float)
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    return np.stack([np.stack([o, z, z], -1), np.stack([z, c, -s], -1), np.stack([z, s, c], -1)], -2)


def rot_y(angle: np.ndarray | float) -> np.ndarray:
    """Rotation about y by ``angle`` (rad): ``(..., 3, 3)``."""
    a = np.asarray(angle, dtype=float)
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    return np.stack([np.stack([c, z, s], -1), np.stack([z, o, z], -1), np.stack([-s, z, c], -1)], -2)


def rot_z(angle: np.ndarray | float) -> np.ndarray:
    """Rotation about z by ``angle`` (rad): ``(..., 3, 3)``."""
    a = np.asarray(angle, dtype=float)
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    return np.stack([np.stack([c, -s, z], -1), np.stack([s, c, z], -1), np.stack([z, z, o], -1)], -2)


def rph_to_matrix(roll, pitch, heading) -> np.ndarray:
    """``Rz(heading) Ry(pitch) Rx(roll)`` for angles in radians: ``(..., 3, 3)``."""
    return rot_z(heading) @ rot_y(pitch) @ rot_x(roll)


def matrix_to_rph(R: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Roll, pitch, heading (rad) of ``R = Rz(h) Ry(p) Rx(r)``; heading in (-pi, pi]."""
    R = np.asarray(R, dtype=float)
    pitch = -np.arcsin(np.clip(R[..., 2, 0], -1.0, 1.0))
    roll = np.arctan2(R[..., 2, 1], R[..., 2, 2])
    heading = np.arctan2(R[..., 1, 0], R[..., 0, 0])
    return roll, pitch, heading


def rph_to_matrix_with_derivatives(roll, pitch, heading) -> tuple[np.ndarray, np.ndarray]:
    """The matrix and its partial derivatives w.r.t. (roll, pitch, heading).

    Returns
    -------
    R : (..., 3, 3)
    dR : (..., 3, 3, 3) float array; ``dR[..., k, :, :]`` is dR/d(angle k), k = roll, pitch, heading.
    """
    Rx, Ry, Rz = rot_x(roll), rot_y(pitch), rot_z(heading)
    # d/da Rx(a) = Rx(a) [e_x]x etc.
    Kx = np.array([[0.0, 0, 0], [0, 0, -1], [0, 1, 0]])
    Ky = np.array([[0.0, 0, 1], [0, 0, 0], [-1, 0, 0]])
    Kz = np.array([[0.0, -1, 0], [1, 0, 0], [0, 0, 0]])
    RzRy = Rz @ Ry
    R = RzRy @ Rx
    d_roll = R @ Kx
    d_pitch = Rz @ (Ry @ Ky) @ Rx
    d_heading = Kz @ R
    return R, np.stack([d_roll, d_pitch, d_heading], axis=-3)


def small_rotation(angles: np.ndarray) -> np.ndarray:
    """Exact rotation ``Rz(c) Ry(b) Rx(a)`` for boresight-style small angles ``(a, b, c)`` (rad)."""
    a = np.asarray(angles, dtype=float)
    return rph_to_matrix(a[..., 0], a[..., 1], a[..., 2])


def unwrap_heading(heading: np.ndarray) -> np.ndarray:
    """Heading made continuous across +-pi (rad), keeping the first value."""
    return np.unwrap(np.asarray(heading, dtype=float))
