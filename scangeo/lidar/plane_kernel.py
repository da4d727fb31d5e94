"""Planes of many groups of returns with data snooping, compiled (numba): the one plane fit of the
laser adjustment (grid cells, row buffer, seeded pass, control patches).

Each group's plane is the total least-squares plane (normal = eigenvector of the smallest eigenvalue
of its points' covariance), its a posteriori sigma ``sqrt(lambda_min n / (n - 3))``. Data snooping
(Baarda): the normal distance of each point over the a priori sigma is its w (the redundancy numbers
of a plane fit to many points are ~1); in every round the point with the largest |w| of each group is
removed if |w| exceeds the critical value, and the planes are fitted again. Moments are summed about
the first return of each group (coordinates of any size stay precise), in loops over the returns, and
after the first round only the groups whose plane changed are visited again: about a tenth of the
0.5 s per million returns of the ``np.bincount`` version it replaced (``tests/benchmarks/lidar_adjust.py``),
which is what lets the patch search keep up with a strip read from disk.
"""

from __future__ import annotations

import numba
import numpy as np

from scangeo.lidar.planes import Planes


@numba.njit(cache=True)
def _references(xyz, group, m):
    """The first return of each group (moments are summed relative to it)."""
    ref = np.zeros((m, 3))
    seen = np.zeros(m, np.bool_)
    for i in range(group.size):
        g = group[i]
        if not seen[g]:
            seen[g] = True
            ref[g, 0], ref[g, 1], ref[g, 2] = xyz[i, 0], xyz[i, 1], xyz[i, 2]
    return ref


@numba.njit(cache=True)
def _moments(xyz, group, keep, active, ref, n, mean, cov):
    """Count, mean (relative to ``ref``) and covariance of the kept returns of the active groups."""
    m = n.size
    s = np.zeros((m, 9))
    for g in range(m):
        if active[g]:
            n[g] = 0.0
    for i in range(group.size):
        g = group[i]
        if not (keep[i] and active[g]):
            continue
        x, y, z = xyz[i, 0] - ref[g, 0], xyz[i, 1] - ref[g, 1], xyz[i, 2] - ref[g, 2]
        n[g] += 1.0
        s[g, 0] += x
        s[g, 1] += y
        s[g, 2] += z
        s[g, 3] += x * x
        s[g, 4] += x * y
        s[g, 5] += x * z
        s[g, 6] += y * y
        s[g, 7] += y * z
        s[g, 8] += z * z
    for g in range(m):
        if not active[g]:
            continue
        c = max(n[g], 1.0)
        mx, my, mz = s[g, 0] / c, s[g, 1] / c, s[g, 2] / c
        mean[g, 0], mean[g, 1], mean[g, 2] = mx, my, mz
        cov[g, 0, 0] = s[g, 3] / c - mx * mx
        cov[g, 0, 1] = cov[g, 1, 0] = s[g, 4] / c - mx * my
        cov[g, 0, 2] = cov[g, 2, 0] = s[g, 5] / c - mx * mz
        cov[g, 1, 1] = s[g, 6] / c - my * my
        cov[g, 1, 2] = cov[g, 2, 1] = s[g, 7] / c - my * mz
        cov[g, 2, 2] = s[g, 8] / c - mz * mz


@numba.njit(cache=True)
def _snoop(xyz, group, keep, active, ref, mean, normal, prior, critical):
    """Remove from every active group the return(s) of largest |w| when above ``critical``; a group
    that loses none becomes inactive. Returns how many returns were removed."""
    m = mean.shape[0]
    worst = np.zeros(m)
    w = np.zeros(group.size)
    for i in range(group.size):
        g = group[i]
        if not (keep[i] and active[g]):
            continue
        d = 0.0
        for k in range(3):
            d += (xyz[i, k] - ref[g, k] - mean[g, k]) * normal[g, k]
        w[i] = abs(d) / prior
        if w[i] > worst[g]:
            worst[g] = w[i]
    dropped = np.zeros(m, np.bool_)
    count = 0
    for i in range(group.size):
        g = group[i]
        if keep[i] and active[g] and w[i] > critical and w[i] >= worst[g]:
            keep[i] = False
            dropped[g] = True
            count += 1
    for g in range(m):
        active[g] = active[g] and dropped[g]
    return count


@numba.njit(cache=True)
def _times(xyz, time, group, keep, ref, mean, axes, n):
    """Mean time of each group's kept returns and dt per metre along its two in-plane axes."""
    m = n.size
    t_sum = np.zeros(m)
    for i in range(group.size):
        if keep[i]:
            t_sum[group[i]] += time[i]
    t_mean = t_sum / np.maximum(n, 1.0)
    num = np.zeros((m, 2))
    den = np.zeros((m, 2))
    for i in range(group.size):
        g = group[i]
        if not keep[i]:
            continue
        dt = time[i] - t_mean[g]
        for k in range(2):
            u = 0.0
            for j in range(3):
                u += (xyz[i, j] - ref[g, j] - mean[g, j]) * axes[g, k, j]
            num[g, k] += dt * u
            den[g, k] += u * u
    grad = num / np.maximum(den, 1e-12)
    return t_mean, grad


@numba.njit(cache=True)
def _totals(group, m):
    out = np.zeros(m)
    for i in range(group.size):
        out[group[i]] += 1.0
    return out


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

    ``xyz`` may be absolute map or project coordinates (metres or map units); centroids come back in
    the same frame. ``prior_sigma``: a priori normal-distance sigma (same unit) for snooping;
    ``time`` (n,) gives each plane's mean time and its gradient along the in-plane axes.
    """
    xyz = np.ascontiguousarray(xyz, float)
    group = np.ascontiguousarray(group, np.int64)
    keep = np.ones(group.size, np.bool_)
    active = np.ones(m, np.bool_)
    ref = _references(xyz, group, m)
    n, mean, cov = np.zeros(m), np.zeros((m, 3)), np.zeros((m, 3, 3))
    lam, vec = np.zeros((m, 3)), np.zeros((m, 3, 3))
    normal = np.zeros((m, 3))
    for r in range(rounds + 1):
        _moments(xyz, group, keep, active, ref, n, mean, cov)
        idx = np.flatnonzero(active)
        lam[idx], vec[idx] = np.linalg.eigh(cov[idx])
        normal[idx] = vec[idx, :, 0] * np.where(vec[idx, 2, 0] < 0, -1.0, 1.0)[:, None]
        if r == rounds or _snoop(xyz, group, keep, active, ref, mean, normal, prior_sigma, critical_value) == 0:
            break
    total = _totals(group, m)
    sigma = np.sqrt(np.maximum(lam[:, 0], 0.0) * n / np.maximum(n - 3, 1))
    axes = np.ascontiguousarray(np.stack([vec[:, :, 2], vec[:, :, 1]], axis=1))
    spread = np.sqrt(np.maximum(lam[:, [2, 1]], 0.0))
    if time is not None:
        t_mean, grad = _times(xyz, np.ascontiguousarray(time, float), group, keep, ref, mean, axes, n)
    else:
        t_mean, grad = np.zeros(m), np.zeros((m, 2))
    return Planes(n, total - n, ref + mean, normal, sigma, axes, spread, t_mean, grad)
