"""1D strip adjustment: a height offset per strip (optionally along- and across-track tilts).

Each strip ``s`` has a straight axis (centre ``(x0, y0)``, heading) and a height error

    e_s(x, y) = offset_s + tilt_along_s * u + tilt_across_s * v

with ``(u, v)`` the along/across coordinates (metres) of ``(x, y)`` relative to the strip centre
(``u`` in the flight direction, ``v`` to the right). Observations (heights in metres):

* tie area between strips i and j at (x, y): ``h_i - h_j = e_i(x, y) - e_j(x, y) + noise``;
* control area seen by strip s at (x, y): ``h_s - H_control = e_s(x, y) + noise``.

The least-squares estimate of the strip errors comes with its covariance ``sigma^2 (A^T P A)^-1``;
the corrected heights are ``h - e``. The covariance needs only the configuration (positions, which
strips see each area, sigmas), so :func:`offset_covariance` serves network design without
observations.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from scangeo.errors import LidarError


@dataclass(frozen=True)
class Strip:
    """A strip's axis: centre (x0, y0) in metres (x east, y north) and heading (rad, from north)."""

    name: str
    x0: float
    y0: float
    heading: float

    def along_across(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Along (flight direction) and across (to the right) coordinates, metres."""
        dx, dy = np.asarray(x) - self.x0, np.asarray(y) - self.y0
        s, c = np.sin(self.heading), np.cos(self.heading)
        return dx * s + dy * c, dx * c - dy * s


@dataclass(frozen=True)
class TieArea:
    """Height difference ``h_i - h_j`` (m) of strips ``i``, ``j`` (indices) in a flat patch at (x, y)."""

    i: int
    j: int
    x: float
    y: float
    dh: float = 0.0
    sigma: float = 0.05


@dataclass(frozen=True)
class ControlArea:
    """Height difference ``h_s - H_control`` (m) of strip ``s`` at a control area at (x, y)."""

    s: int
    x: float
    y: float
    dh: float = 0.0
    sigma: float = 0.05


@dataclass(frozen=True)
class StripAdjustment:
    """Result of a 1D strip adjustment.

    ``params[s]`` = (offset m, tilt_along, tilt_across) of strip s (tilts dimensionless, m/m;
    zero-width columns when tilts are off); ``covariance`` of the flattened parameters in m^2;
    ``offset_sigma`` the standard deviations of the offsets (m); ``sigma0`` a posteriori
    (dimensionless, 1 when the sigmas are right); ``residuals`` (m) ties first, then controls.
    """

    params: np.ndarray
    covariance: np.ndarray
    offset_sigma: np.ndarray
    sigma0: float
    redundancy: int
    residuals: np.ndarray = field(repr=False)


def design_matrix(
    strips: list[Strip], ties: list[TieArea], controls: list[ControlArea], tilts: bool = False
) -> tuple[sp.csr_matrix, np.ndarray, np.ndarray]:
    """Sparse design matrix, observations and sigmas (m) of the tie and control areas.

    Columns are ``[offset, (tilt_along, tilt_across)]`` per strip, strip after strip.
    """
    k = 3 if tilts else 1
    n = len(strips)
    rows, cols, vals, obs, sig = [], [], [], [], []

    def add(r: int, s: int, x: float, y: float, sign: float) -> None:
        if not 0 <= s < n:
            raise LidarError(f"strip index {s} in an area, expected 0..{n - 1}")
        terms = [1.0]
        if tilts:
            u, v = strips[s].along_across(np.asarray(x), np.asarray(y))
            terms += [float(u), float(v)]
        for t, value in enumerate(terms):
            rows.append(r)
            cols.append(k * s + t)
            vals.append(sign * value)

    for r, tie in enumerate(ties):
        if tie.i == tie.j:
            raise LidarError(f"tie area {r} at ({tie.x}, {tie.y}) ties strip {tie.i} to itself")
        add(r, tie.i, tie.x, tie.y, 1.0)
        add(r, tie.j, tie.x, tie.y, -1.0)
        obs.append(tie.dh)
        sig.append(tie.sigma)
    for r, ctl in enumerate(controls, start=len(ties)):
        add(r, ctl.s, ctl.x, ctl.y, 1.0)
        obs.append(ctl.dh)
        sig.append(ctl.sigma)
    A = sp.csr_matrix((vals, (rows, cols)), shape=(len(obs), k * n))
    return A, np.asarray(obs, dtype=float), np.asarray(sig, dtype=float)


def _normal_inverse(A: sp.csr_matrix, sigma: np.ndarray) -> tuple[sp.csc_matrix, np.ndarray]:
    """Normal matrix ``A^T P A`` (P = diag 1/sigma^2) and its dense inverse; raises when singular."""
    if np.any(sigma <= 0):
        raise LidarError("every tie and control area needs a sigma > 0")
    P = sp.diags(1.0 / sigma**2)
    N = (A.T @ P @ A).tocsc()
    diag = N.diagonal()
    if np.all(diag > 0):
        # equilibrate (offsets in m, tilts in m/m) so that the rank test does not depend on units
        D = sp.diags(1.0 / np.sqrt(diag))
        try:
            lu = spla.splu((D @ N @ D).tocsc())
        except RuntimeError:
            lu = None
        if lu is not None and np.abs(lu.U.diagonal()).min() > 1e-10:
            Q = D @ lu.solve(D @ np.eye(N.shape[0]))
            return N, np.asarray((Q + Q.T) / 2)
    raise LidarError(
        "the strip adjustment is singular: some strips are not tied to control "
        "(add control areas, or tie areas linking every strip to a controlled one; tilts need "
        "areas spread along and across each strip)"
    )


def offset_covariance(
    strips: list[Strip], ties: list[TieArea], controls: list[ControlArea], tilts: bool = False
) -> np.ndarray:
    """Covariance (m^2) of the strip parameters from the configuration alone (network design)."""
    A, _, sigma = design_matrix(strips, ties, controls, tilts)
    return _normal_inverse(A, sigma)[1]


def adjust_strips(
    strips: list[Strip], ties: list[TieArea], controls: list[ControlArea], tilts: bool = False
) -> StripAdjustment:
    """Least-squares height offsets (and tilts) of the strips with their covariance.

    The covariance is the a priori one, ``(A^T P A)^-1`` with the given sigmas; multiply by
    ``sigma0**2`` for the a posteriori one.
    """
    A, l, sigma = design_matrix(strips, ties, controls, tilts)  # noqa: E741 (l: observations, as in the literature)
    N, Q = _normal_inverse(A, sigma)
    x = Q @ (A.T @ (l / sigma**2))
    v = A @ x - l
    redundancy = A.shape[0] - A.shape[1]
    sigma0 = float(np.sqrt(np.sum((v / sigma) ** 2) / redundancy)) if redundancy > 0 else float("nan")
    k = 3 if tilts else 1
    return StripAdjustment(
        params=x.reshape(len(strips), k), covariance=Q,
        offset_sigma=np.sqrt(np.diag(Q)[::k]), sigma0=sigma0, redundancy=redundancy, residuals=v,
    )
