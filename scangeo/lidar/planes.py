"""Planes fitted to many groups of points at once (one group per patch or grid cell), with data snooping.

Every group's moments are accumulated with ``np.bincount`` (no Python loop per group); the plane is
the total least-squares plane (normal = eigenvector of the smallest eigenvalue of the points'
covariance), its a posteriori sigma ``sqrt(lambda_min n / (n - 3))``. Data snooping (Baarda): the
normal distance of each point over the a priori sigma is its w (the redundancy numbers of a plane
fit to many points are ~1); in every round the point with the largest |w| of each group is removed
if |w| exceeds the critical value, and the planes are fitted again.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class Planes:
    """Planes of ``m`` groups (coordinates relative to the caller's per-group reference).

    count : points used; rejected : points removed by data snooping; centroid (m, 3); normal (m, 3)
    (upward, z >= 0); sigma (m,) a posteriori normal-distance sigma; axes (m, 2, 3) in-plane
    principal directions; spread (m, 2) standard deviations of the points along them; time (m,)
    mean time; time_gradient (m, 2) dt per metre along the axes.
    """

    count: np.ndarray
    rejected: np.ndarray
    centroid: np.ndarray
    normal: np.ndarray
    sigma: np.ndarray
    axes: np.ndarray
    spread: np.ndarray
    time: np.ndarray
    time_gradient: np.ndarray

    def take(self, index) -> Planes:
        return Planes(*(getattr(self, f)[index] for f in self.__dataclass_fields__))


def _moments(xyz: np.ndarray, group: np.ndarray, m: int, keep: np.ndarray):
    w = keep.astype(float)
    n = np.bincount(group, w, m)
    s = np.stack([np.bincount(group, w * xyz[:, k], m) for k in range(3)], axis=1)
    mean = s / np.maximum(n, 1)[:, None]
    cov = np.empty((m, 3, 3))
    for i in range(3):
        for j in range(i, 3):
            v = np.bincount(group, w * xyz[:, i] * xyz[:, j], m) / np.maximum(n, 1) - mean[:, i] * mean[:, j]
            cov[:, i, j] = cov[:, j, i] = v
    return n, mean, cov


def fit_planes(
    xyz: np.ndarray,
    group: np.ndarray,
    m: int,
    prior_sigma: float,
    time: np.ndarray | None = None,
    critical_value: float = 3.29,
    rounds: int = 5,
) -> Planes:
    """Fit a plane to each of the ``m`` groups of points ``xyz`` (n, 3); ``group`` (n,) in 0..m-1.

    Coordinates should be small (relative to a reference near each group) for numerical precision.
    """
    xyz = np.asarray(xyz, float)
    group = np.asarray(group, np.int64)
    keep = np.ones(group.size, bool)
    for r in range(rounds + 1):
        n, mean, cov = _moments(xyz, group, m, keep)
        lam, vec = np.linalg.eigh(cov)
        normal = vec[:, :, 0] * np.where(vec[:, 2, 0] < 0, -1.0, 1.0)[:, None]
        if r == rounds:
            break
        d = np.einsum("ij,ij->i", xyz - mean[group], normal[group])
        w = np.where(keep, np.abs(d) / prior_sigma, 0.0)
        worst = np.zeros(m)
        np.maximum.at(worst, group, w)
        drop = keep & (w > critical_value) & (w >= worst[group])
        if not drop.any():
            break
        keep &= ~drop
    total = np.bincount(group, minlength=m)
    sigma = np.sqrt(np.maximum(lam[:, 0], 0.0) * n / np.maximum(n - 3, 1))
    axes = np.stack([vec[:, :, 2], vec[:, :, 1]], axis=1)
    spread = np.sqrt(np.maximum(lam[:, [2, 1]], 0.0))
    t_mean = np.zeros(m)
    grad = np.zeros((m, 2))
    if time is not None:
        w = keep.astype(float)
        t_mean = np.bincount(group, w * time, m) / np.maximum(n, 1)
        dt = time - t_mean[group]
        for k in range(2):
            u = np.einsum("ij,ij->i", xyz - mean[group], axes[group, k])
            grad[:, k] = np.bincount(group, w * dt * u, m) / np.maximum(np.bincount(group, w * u * u, m), 1e-12)
    return Planes(n, total - n, mean, normal, sigma, axes, spread, t_mean, grad)


#: anchors per patch and strip (the paper's four; see :func:`anchors`)
ANCHORS = 4


def anchors(planes: Planes) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The four anchor points per plane that carry the plane fit's information (see docs/lidar.md).

    Anchors at ``+a, -a`` along the first in-plane principal axis and ``+b, -b`` along the second,
    with ``(a, b) = sqrt(2)`` times the standard deviations of the returns along them, each with sigma
    ``2 sigma / sqrt(n)``: estimating offset and two tilts from the four anchors gives the same
    variances as from the ``n`` returns. Returns points (m, 4, 3) (the caller's coordinates), their
    times (m, 4) and sigmas (m,).
    """
    a = np.sqrt(2.0) * planes.spread  # (m, 2)
    sign = np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]])  # (4, 2): along axis 1, axis 2
    step = sign[None, :, :] * a[:, None, :]  # (m, 4, 2)
    pts = planes.centroid[:, None, :] + np.einsum("mkj,mjc->mkc", step, planes.axes)
    t = planes.time[:, None] + np.einsum("mkj,mj->mk", step, planes.time_gradient)
    sig = planes.sigma * 2.0 / np.sqrt(np.maximum(planes.count, 1))
    return pts, t, sig
