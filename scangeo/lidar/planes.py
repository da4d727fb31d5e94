"""Planes of many groups of points (one group per patch or grid cell) and the anchors that carry them.

The fit itself (total least squares with data snooping) is :func:`scangeo.lidar.plane_kernel.fit_planes`,
the one implementation the grid cells, the row buffer and the seeded pass share.
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

    @classmethod
    def concat(cls, parts: list[Planes]) -> Planes:
        """The planes of several fits, one after the other."""
        return cls(*(np.concatenate([getattr(p, f) for p in parts]) for f in cls.__dataclass_fields__))


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
