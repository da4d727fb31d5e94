"""The orientation spline: a uniform cubic B-spline (C2) of ``s(t) = [x, y, z, roll, pitch, heading]``.

Positions in metres in the project frame (navigation reference point), angles in radians w.r.t. the
project NED frame (see ``scangeo.trajectory.stream``), heading unwrapped. The coefficients are the
unknowns of the adjustment; ``basis_matrix`` maps them linearly to values (or derivatives) at any
times, and ``knot_times``/``knot_value_matrix`` give the values at the knot epochs.

Segment ``j`` covers ``[t0 + j*dt, t0 + (j+1)*dt)`` and uses coefficients ``j .. j+3``; coefficient
``k`` is centred on the knot epoch ``t0 + (k-1)*dt``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.sparse as sp

from scangeo.errors import TrajectoryError

COMPONENTS = ("x", "y", "z", "roll", "pitch", "heading")


def bspline_basis(u: np.ndarray, derivative: int = 0) -> np.ndarray:
    """Uniform cubic B-spline basis (n, 4) at local parameters u in [0, 1] (per unit of u)."""
    u = np.asarray(u, dtype=float)
    if derivative == 0:
        u2, u3 = u * u, u * u * u
        return np.stack([(1 - u) ** 3, 3 * u3 - 6 * u2 + 4, -3 * u3 + 3 * u2 + 3 * u + 1, u3], -1) / 6.0
    if derivative == 1:
        u2 = u * u
        return np.stack([-(1 - u) ** 2, 3 * u2 - 4 * u, -3 * u2 + 2 * u + 1, u2], -1) / 2.0
    if derivative == 2:
        return np.stack([1 - u, 3 * u - 2, -3 * u + 1, u], -1)
    raise ValueError("derivative must be 0, 1 or 2")


@dataclass(frozen=True)
class OrientationSpline:
    """Uniform cubic B-spline of the 6D orientation.

    Parameters
    ----------
    t0 : start of the first segment, seconds.
    spacing : knot spacing, seconds.
    coef : (K, 6) coefficients (m, m, m, rad, rad, rad); K >= 4.
    """

    t0: float
    spacing: float
    coef: np.ndarray

    def __post_init__(self) -> None:
        if self.coef.ndim != 2 or self.coef.shape[0] < 4:
            raise TrajectoryError(f"a cubic spline needs at least 4 coefficients, got shape {self.coef.shape}")
        if not self.spacing > 0:
            raise TrajectoryError(f"knot spacing must be positive, got {self.spacing}")

    # --- layout -------------------------------------------------------------------------------
    @property
    def n_coef(self) -> int:
        return int(self.coef.shape[0])

    @property
    def t_end(self) -> float:
        """End of the last segment (seconds)."""
        return self.t0 + (self.n_coef - 3) * self.spacing

    @property
    def knot_times(self) -> np.ndarray:
        """Epoch on which each coefficient is centred, (K,) seconds."""
        return self.t0 + (np.arange(self.n_coef) - 1.0) * self.spacing

    @staticmethod
    def layout(t_start: float, t_end: float, spacing: float) -> tuple[float, int]:
        """(t0, K) of a spline covering [t_start, t_end] with the given spacing."""
        segments = max(int(np.ceil((t_end - t_start) / spacing - 1e-9)), 1)
        return float(t_start), segments + 3

    def segment(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Segment index (clamped to the spline) and local parameter u of times t."""
        s = (np.asarray(t, dtype=float) - self.t0) / self.spacing
        j = np.clip(np.floor(s), 0, self.n_coef - 4).astype(np.intp)
        return j, s - j

    def covers(self, t: np.ndarray) -> np.ndarray:
        """True where t lies inside [t0, t_end]."""
        t = np.asarray(t, dtype=float)
        return (t >= self.t0) & (t <= self.t_end)

    # --- evaluation ---------------------------------------------------------------------------
    def evaluate(self, t: np.ndarray, derivative: int = 0) -> np.ndarray:
        """Values (n, 6) (derivative 0) or time derivatives (per s, per s^2) at times t."""
        j, u = self.segment(t)
        B = bspline_basis(u, derivative) / self.spacing**derivative
        idx = j[:, None] + np.arange(4)
        return np.einsum("nk,nkc->nc", B, self.coef[idx])

    def basis_matrix(self, t: np.ndarray, derivative: int = 0) -> sp.csr_matrix:
        """Sparse (n, K) matrix A with ``evaluate(t, d) == A @ coef``."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        j, u = self.segment(t)
        B = bspline_basis(u, derivative) / self.spacing**derivative
        rows = np.repeat(np.arange(len(t)), 4)
        cols = (j[:, None] + np.arange(4)).ravel()
        return sp.csr_matrix((B.ravel(), (rows, cols)), shape=(len(t), self.n_coef))

    def knot_value_matrix(self) -> sp.csr_matrix:
        """Sparse (K-2, K) matrix giving the values at the interior knot epochs t0 + i*dt."""
        times = self.t0 + np.arange(self.n_coef - 2) * self.spacing
        return self.basis_matrix(times)

    def with_coef(self, coef: np.ndarray) -> OrientationSpline:
        return OrientationSpline(self.t0, self.spacing, np.asarray(coef, dtype=float))

    # --- fitting ------------------------------------------------------------------------------
    @classmethod
    def fit(cls, time: np.ndarray, values: np.ndarray, spacing: float, t_range=None,
            weights: np.ndarray | None = None) -> OrientationSpline:
        """Least-squares fit to samples (time (n,), values (n, c)).

        A very small third-difference regulariser keeps segments without samples determined.
        """
        time = np.asarray(time, dtype=float)
        values = np.asarray(values, dtype=float)
        t_start, t_stop = t_range if t_range is not None else (time[0], time[-1])
        t0, K = cls.layout(t_start, t_stop, spacing)
        proto = cls(t0, spacing, np.zeros((K, values.shape[1])))
        A = proto.basis_matrix(time)
        w = np.ones(len(time)) if weights is None else np.asarray(weights, dtype=float)
        rhs = A.T @ (w[:, None] * values)
        D = sp.diags([-1.0, 3.0, -3.0, 1.0], [0, 1, 2, 3], shape=(K - 3, K))  # third differences
        reg = 1e-12 * max(float(w.sum()) / K, 1.0)
        Nsp = (A.T @ sp.diags(w) @ A + reg * (D.T @ D)).tocsr()
        ab = np.zeros((4, K))  # upper banded storage, bandwidth 3
        for k in range(4):
            ab[3 - k, k:] = Nsp.diagonal(k)
        coef = scipy.linalg.solveh_banded(ab, rhs)
        return cls(t0, float(spacing), coef)

    @classmethod
    def from_trajectory(cls, trajectory, spacing: float, t_range=None) -> OrientationSpline:
        """Fit to a ProjectTrajectory (positions and project-NED angles)."""
        values = np.column_stack([trajectory.p_P, trajectory.angles_P])
        return cls.fit(trajectory.time, values, spacing, t_range=t_range)
