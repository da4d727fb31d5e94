"""GPS/IMU samples as observations of the orientation spline through a GPS/IMU model.

At every knot epoch ``t_k`` of a flight line's spline the GPS/IMU (positions of the navigation reference
point in P, metres; roll, pitch, heading w.r.t. the project NED frame, radians) observes

    gpsimu(t_k) = s(t_k) - c_m(t_k) + v

with ``s`` the spline (``Knots(flight_line)``: every strip on the flight line follows it) and ``c_m``
the correction function of the serving model (``Correction(model)``, see ``scangeo.orientation.models``).
The group is linear: its Jacobian is built once.
Rows are epoch-major: ``x, y, z, roll, pitch, heading`` of epoch 0, then epoch 1, ...
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from scangeo.adjustment.keys import Knots
from scangeo.lsq.observations import Linearisation, ObservationGroup
from scangeo.lsq.parameters import JacobianPart
from scangeo.orientation.models import ModelSet
from scangeo.trajectory.spline import COMPONENTS, OrientationSpline

UNITS = ("m", "m", "m", "rad", "rad", "rad")


class GpsImuSamples(ObservationGroup):
    """GPS/IMU of one flight line at epochs ``times`` (s). Not tested by data snooping: its errors are the
    correction function's business, and an epoch removed would leave knots undetermined.

    Parameters
    ----------
    flight_line : the flight line's id (a strip with its own trajectory: the strip's id).
    spline : the flight line's spline (its layout: t0, spacing, number of coefficients).
    times : (n,) epochs, seconds.
    values : (n, 6) the GPS/IMU there (m, m, m, rad, rad, rad; project frame).
    sigma : (6,) a priori standard deviations (m and rad).
    models : the GPS/IMU models (may serve none of the epochs: direct use, no correction).
    """

    snooped = False

    def __init__(self, flight_line: str, spline: OrientationSpline, times: np.ndarray, values: np.ndarray,
                 sigma, models: ModelSet) -> None:
        self.name = f"gpsimu {flight_line}"
        self.flight_line = flight_line
        self.key = Knots(flight_line)
        self.times = np.asarray(times, float)
        self.values = np.asarray(values, float)
        n = self.times.size
        sig6 = np.broadcast_to(np.asarray(sigma, float), (6,))
        self.sigma = np.tile(sig6, n)
        self._describe(np.repeat([f"{flight_line}@{t:.3f}" for t in self.times], 6), np.tile(COMPONENTS, n),
                       np.tile(UNITS, n), np.repeat(np.arange(n), 6))
        B = spline.basis_matrix(self.times).tocoo()  # (n, K)
        # knots: coefficient (k, c) is component k*6 + c of Knots(flight_line)
        r = (B.row[:, None] * 6 + np.arange(6)).ravel()
        c = (B.col[:, None] * 6 + np.arange(6)).ravel()
        v = np.repeat(B.data, 6)
        self._knot_part = JacobianPart([self.key], r, c, v / self.sigma[r])
        self._basis = sp.csr_matrix(B)
        self._corrections = models.design(flight_line, self.times, self.values[:, :3])
        self._corr_parts = []
        for key, rows, D in self._corrections:
            rr = np.broadcast_to((rows[:, None] * 6 + np.arange(6))[:, :, None], D.shape)
            cc = np.broadcast_to(np.arange(D.shape[2])[None, None, :], D.shape)
            self._corr_parts.append(JacobianPart([key], rr.ravel(), cc.ravel(), (-D / sig6[None, :, None]).ravel()))
        self._keys = [self.key] + [k for k, _, _ in self._corrections]

    def keys(self):
        return list(dict.fromkeys(self._keys))

    def spline_values(self, values) -> np.ndarray:
        coef = np.asarray(values[self.key], float).reshape(-1, 6)
        return self._basis @ coef

    def correction(self, values) -> np.ndarray:
        c = np.zeros((self.times.size, 6))
        for key, rows, D in self._corrections:
            c[rows] += D @ np.asarray(values[key], float)
        return c

    def residuals(self, values) -> np.ndarray:
        r = self.spline_values(values) - self.correction(values) - self.values
        return r.ravel() / self.sigma

    def linearise(self, values) -> Linearisation:
        return Linearisation(self.residuals(values), [self._knot_part] + self._corr_parts)
