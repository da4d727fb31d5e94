"""The relative mounting of two sensors on one platform: a prior from an earlier calibration, and the
adjusted value with its precision.

Two sensors on one navigation system each have a boresight ``R_BS`` and a lever arm ``l_B`` in the body
frame. Their **relative mounting** is the rotation ``R_rel = R_BS(reference)^T R_BS(sensor)`` (sensor
frame into the reference sensor's frame) and the lever-arm difference ``l_B(sensor) - l_B(reference)``.
It is what a calibration of the rig determines well and what stays when the rig is flown again: a
prior on it lets a sensor without ground control take its mounting from its sister.

:class:`RelativeMountingPrior` observes it: the residual of the angles is the small rotation between the
adjusted and the given relative mounting, ``w = vee(E - E^T) / 2`` with ``E = R_given^T R_rel``
(``vee`` the axial vector; ``|w| = sin`` of the angle between the two, about the reference sensor's
x, y, z axes, which at small angles are roll, pitch and heading), whitened by the prior's sigmas; the
lever arm's is the difference itself. :func:`relative_mounting` is the adjusted relative mounting with
its covariance from the joint covariance of the two sensors' mountings.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from scangeo.adjustment.keys import Boresight, LeverArm
from scangeo.io.project import RelativeMounting
from scangeo.lsq.observations import Linearisation, ObservationGroup
from scangeo.lsq.parameters import JacobianPart
from scangeo.rotation import matrix_to_rph, rph_to_matrix, rph_to_matrix_with_derivatives


def _vee_skew(M: np.ndarray) -> np.ndarray:
    """The axial vector of the skew part of ``M`` (``(..., 3, 3) -> (..., 3)``)."""
    A = 0.5 * (M - np.swapaxes(M, -1, -2))
    return np.stack([A[..., 2, 1], A[..., 0, 2], A[..., 1, 0]], axis=-1)


class RelativeMountingPrior(ObservationGroup):
    """The prior of one ``[[relative_mountings]]`` entry: three angle rows (when its boresight is given)
    and three lever-arm rows (when its lever arm is given). Not snooped: it is a calibration's result,
    tested by the report's comparison of the adjusted value with it.

    Parameters
    ----------
    prior : RelativeMounting
        The sensors, the given relative rotation (radians) and lever-arm difference (metres, body
        frame) and their sigmas.
    """

    kind = "pseudo"
    snooped = False

    def __init__(self, prior: RelativeMounting) -> None:
        self.prior = prior
        self.name = f"relative mounting {prior.sensor} to {prior.reference}"
        self._angles = prior.boresight is not None
        self._lever = prior.lever_arm is not None
        sig, comps, units = [], [], []
        if self._angles:
            assert prior.boresight_sigma is not None  # project_schema: given together
            sig.append(prior.boresight_sigma)
            comps += ["roll", "pitch", "heading"]
            units += ["rad"] * 3
            self._R_given = rph_to_matrix(*np.asarray(prior.boresight, float))
        if self._lever:
            assert prior.lever_arm_sigma is not None
            sig.append(prior.lever_arm_sigma)
            comps += ["x", "y", "z"]
            units += ["m"] * 3
        self.sigma = np.concatenate(sig)
        n = self.sigma.size
        self._describe(np.repeat([f"{prior.sensor}-{prior.reference}"], n), np.array(comps), np.array(units),
                       np.zeros(n, dtype=int))
        self._keys = ([Boresight(prior.sensor), Boresight(prior.reference)] if self._angles else []) + (
            [LeverArm(prior.sensor), LeverArm(prior.reference)] if self._lever else [])

    def keys(self):
        return list(self._keys)

    def _angle_terms(self, values, derivatives: bool):
        b_s = np.asarray(values[Boresight(self.prior.sensor)], float)
        b_r = np.asarray(values[Boresight(self.prior.reference)], float)
        R_s, dR_s = rph_to_matrix_with_derivatives(*b_s)
        R_r, dR_r = rph_to_matrix_with_derivatives(*b_r)
        G = self._R_given.T
        w = _vee_skew(G @ R_r.T @ R_s)
        if not derivatives:
            return w, None, None
        d_s = np.stack([_vee_skew(G @ R_r.T @ dR_s[k]) for k in range(3)], axis=-1)     # (3, 3)
        d_r = np.stack([_vee_skew(G @ dR_r[k].T @ R_s) for k in range(3)], axis=-1)
        return w, d_s, d_r

    def residuals(self, values) -> np.ndarray:
        out = []
        if self._angles:
            out.append(self._angle_terms(values, False)[0])
        if self._lever:
            assert self.prior.lever_arm is not None
            out.append(np.asarray(values[LeverArm(self.prior.sensor)], float)
                       - np.asarray(values[LeverArm(self.prior.reference)], float) - self.prior.lever_arm)
        return np.concatenate(out) / self.sigma

    def linearise(self, values) -> Linearisation:
        parts = []
        row = 0
        rows3 = np.repeat(np.arange(3), 3)
        cols3 = np.tile(np.arange(3), 3)
        if self._angles:
            _, d_s, d_r = self._angle_terms(values, True)
            sig = self.sigma[:3, None]
            parts.append(JacobianPart([Boresight(self.prior.sensor)], rows3, cols3, (d_s / sig).ravel()))
            parts.append(JacobianPart([Boresight(self.prior.reference)], rows3, cols3, (d_r / sig).ravel()))
            row = 3
        if self._lever:
            eye = np.eye(3) / self.sigma[row:row + 3, None]
            parts.append(JacobianPart([LeverArm(self.prior.sensor)], rows3 + row, cols3, eye.ravel()))
            parts.append(JacobianPart([LeverArm(self.prior.reference)], rows3 + row, cols3, -eye.ravel()))
        return Linearisation(self.residuals(values), parts)


@dataclass(frozen=True)
class RelativeMountingEstimate:
    """The adjusted relative mounting of ``sensor`` to ``reference`` and its precision.

    ``boresight`` are roll, pitch, heading of ``R_rel = R_BS(reference)^T R_BS(sensor)`` (radians) and
    ``boresight_sigma`` their standard deviations; ``lever_arm`` the lever-arm difference (metres, body
    frame) and ``lever_arm_sigma`` its; ``prior``: the given value, or None.
    """

    sensor: str
    reference: str
    boresight: np.ndarray
    boresight_sigma: np.ndarray
    lever_arm: np.ndarray
    lever_arm_sigma: np.ndarray
    prior: RelativeMounting | None = None


def relative_rotation(b_sensor: np.ndarray, b_reference: np.ndarray) -> np.ndarray:
    """Roll, pitch, heading (rad) of ``R_BS(reference)^T R_BS(sensor)`` from the two boresights (rad)."""
    return np.array(matrix_to_rph(rph_to_matrix(*b_reference).T @ rph_to_matrix(*b_sensor)))


def relative_mounting(values, covariance: np.ndarray, sensor: str, reference: str,
                      prior: RelativeMounting | None = None) -> RelativeMountingEstimate:
    """The adjusted relative mounting with its covariance propagated from the two mountings'.

    Parameters
    ----------
    values : mapping of Key to ndarray
        The adjusted unknowns (``Boresight`` and ``LeverArm`` of both sensors).
    covariance : (12, 12) ndarray
        The joint covariance of ``Boresight(sensor)``, ``Boresight(reference)``, ``LeverArm(sensor)``,
        ``LeverArm(reference)`` (in that order; radians and metres); rows of fixed components zero.
    sensor, reference : str
        The two sensors' ids.
    prior : RelativeMounting, optional
        The prior given in project.toml.

    Returns
    -------
    RelativeMountingEstimate
        The relative rotation's angles and the lever-arm difference with their standard deviations.
    """
    b_s = np.asarray(values[Boresight(sensor)], float)
    b_r = np.asarray(values[Boresight(reference)], float)
    rel = relative_rotation(b_s, b_r)
    J = np.zeros((6, 12))
    h = 1e-7
    for k in range(6):  # the angles' derivatives by central differences (smooth, well-scaled: radians)
        e = np.zeros(6)
        e[k] = h
        up = relative_rotation(b_s + e[:3], b_r + e[3:])
        down = relative_rotation(b_s - e[:3], b_r - e[3:])
        J[:3, k] = (up - down) / (2 * h)
    J[3:, 6:9] = np.eye(3)
    J[3:, 9:12] = -np.eye(3)
    cov = J @ covariance @ J.T
    sig = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    lever = np.asarray(values[LeverArm(sensor)], float) - np.asarray(values[LeverArm(reference)], float)
    return RelativeMountingEstimate(sensor, reference, rel, sig[:3], lever, sig[3:], prior)


__all__ = ["RelativeMountingEstimate", "RelativeMountingPrior", "relative_mounting", "relative_rotation"]
