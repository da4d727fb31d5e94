"""1D strip adjustment: a height offset per strip (optionally along- and across-track tilts).

Each strip ``s`` has a straight axis (centre ``(x0, y0)``, heading) and a height error

    e_s(x, y) = offset_s + tilt_along_s * u + tilt_across_s * v

with ``(u, v)`` the along/across coordinates (metres) of ``(x, y)`` relative to the strip centre
(``u`` in the flight direction, ``v`` to the right). Observations (heights in metres):

* tie area between strips i and j at (x, y): ``h_i - h_j = e_i(x, y) - e_j(x, y) + noise``;
* control area seen by strip s at (x, y): ``h_s - H_control = e_s(x, y) + noise``.

The strip errors are unknowns of the common least-squares engine (:mod:`scangeo.lsq`, one
:class:`~scangeo.lidar.keys.StripHeight` per strip; the tie and control areas are observation groups),
solved by sparse Cholesky; their covariance ``sigma^2 (A^T P A)^-1`` comes from the factor's selected
inverse, per strip (the covariances between strips are not formed, nor is a dense inverse). The
covariance needs only the configuration (positions, which strips see each area, sigmas), so
:func:`offset_covariance` serves network design without observations; the same solution gives the
redundancy numbers and minimal detectable blunders of the areas (:func:`design_reliability`).
The corrected heights are ``h - e``.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from scangeo.errors import LidarError
from scangeo.lidar.keys import StripHeight
from scangeo.lsq.engine import Adjustment, SnoopingOptions, adjust
from scangeo.lsq.observations import Linearisation, ObservationGroup
from scangeo.lsq.parameters import JacobianPart, Parameters
from scangeo.lsq.reliability import Reliability, compute_reliability
from scangeo.lsq.solver import SolverOptions


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
    one column when tilts are off); ``covariance[s]`` (k, k) the a priori covariance of strip s's
    parameters (m^2, m^2/m, m^2/m^2; from the selected inverse); ``offset_sigma`` the a priori
    standard deviations of the offsets (m); ``sigma0`` a posteriori (dimensionless, 1 when the
    sigmas are right); ``residuals`` (m, model minus observation) ties first, then controls.
    """

    params: np.ndarray
    covariance: np.ndarray
    offset_sigma: np.ndarray
    sigma0: float
    redundancy: int
    residuals: np.ndarray = field(repr=False)


COMPONENTS = ("offset", "tilt_along", "tilt_across")


def _terms(strips: Sequence[Strip], s: np.ndarray, x: np.ndarray, y: np.ndarray, k: int) -> np.ndarray:
    """(m, k) design terms ``[1, u, v][:k]`` of strips ``s`` (indices) at (x, y) (m)."""
    out = np.ones((s.size, k))
    if k > 1:
        x0 = np.array([st.x0 for st in strips])[s]
        y0 = np.array([st.y0 for st in strips])[s]
        h = np.array([st.heading for st in strips])[s]
        dx, dy = x - x0, y - y0
        out[:, 1] = dx * np.sin(h) + dy * np.cos(h)
        out[:, 2] = dx * np.cos(h) - dy * np.sin(h)
    return out


class HeightAreas(ObservationGroup):
    """Height differences of areas: ``e_i(x, y) - e_j(x, y) = dh`` (tie, ``j >= 0``) or ``e_i(x, y) = dh``
    (control, ``j = -1``), metres, one row and one observation unit per area."""

    def __init__(self, name: str, keys: list[StripHeight], terms_i: np.ndarray, i: np.ndarray,
                 terms_j: np.ndarray, j: np.ndarray, dh: np.ndarray, sigma: np.ndarray, ids: Sequence[str]) -> None:
        self.name = name
        self._all_keys = keys
        self._i, self._j = i, j
        self._ti, self._tj = terms_i, terms_j
        self.dh = np.asarray(dh, float)
        self.sigma = np.asarray(sigma, float)
        self._describe(list(ids), "dh", "m")
        used = np.unique(np.concatenate([i, j[j >= 0]]))
        self._keys = [keys[u] for u in used]

    def keys(self) -> Sequence[StripHeight]:
        return self._keys

    def _model(self, values) -> np.ndarray:
        table = np.array([values[k] for k in self._all_keys], float)
        f = np.einsum("mk,mk->m", self._ti, table[self._i])
        tie = self._j >= 0
        f[tie] -= np.einsum("mk,mk->m", self._tj[tie], table[self._j[tie]])
        return f

    def residuals(self, values) -> np.ndarray:
        return (self._model(values) - self.dh) / self.sigma

    def linearise(self, values) -> Linearisation:
        m, k = self._ti.shape
        rows = np.repeat(np.arange(m), k)
        cols = np.tile(np.arange(k), m)
        parts = [JacobianPart(self._all_keys, rows, cols, (self._ti / self.sigma[:, None]).ravel(),
                              np.repeat(self._i, k))]
        tie = np.flatnonzero(self._j >= 0)
        if tie.size:
            parts.append(JacobianPart(self._all_keys, np.repeat(tie, k), np.tile(np.arange(k), tie.size),
                                      (-self._tj[tie] / self.sigma[tie, None]).ravel(), np.repeat(self._j[tie], k)))
        return Linearisation(self.residuals(values), parts)


def observation_groups(
    strips: list[Strip], ties: list[TieArea], controls: list[ControlArea], tilts: bool = False
) -> tuple[Parameters, list[ObservationGroup]]:
    """The unknowns (one :class:`StripHeight` per strip, zero) and the tie and control groups."""
    k = 3 if tilts else 1
    n = len(strips)
    names = [s.name for s in strips]
    if len(set(names)) != n:
        raise LidarError(f"strip names must be unique: {sorted(x for x in set(names) if names.count(x) > 1)} repeat")
    keys = [StripHeight(name) for name in names]
    params = Parameters()
    for key in keys:
        params.add(key, np.zeros(k), True, names=COMPONENTS[:k])
    groups: list[ObservationGroup] = []
    for what, areas in (("tie areas", ties), ("control areas", controls)):
        if not areas:
            continue
        i = np.array([a.i if isinstance(a, TieArea) else a.s for a in areas], np.int64)
        j = np.array([a.j if isinstance(a, TieArea) else -1 for a in areas], np.int64)
        bad = np.flatnonzero((i < 0) | (i >= n) | (j < -1) | (j >= n) | ((j >= 0) & (what == "control areas")))
        if bad.size:
            a = areas[bad[0]]
            raise LidarError(f"{what[:-1]} {bad[0]} at ({a.x}, {a.y}): strip index out of 0..{n - 1}")
        if np.any(i == j):
            r = int(np.flatnonzero(i == j)[0])
            raise LidarError(f"tie area {r} at ({areas[r].x}, {areas[r].y}) ties strip {i[r]} to itself")
        sigma = np.array([a.sigma for a in areas], float)
        if np.any(~(sigma > 0)):
            raise LidarError("every tie and control area needs a sigma > 0")
        x = np.array([a.x for a in areas], float)
        y = np.array([a.y for a in areas], float)
        ti = _terms(strips, i, x, y, k)
        tj = _terms(strips, np.maximum(j, 0), x, y, k)
        ids = [f"{what[:-6]} {r}" for r in range(len(areas))]
        groups.append(HeightAreas(what, keys, ti, i, tj, j, np.array([a.dh for a in areas], float), sigma, ids))
    return params, groups


def _solve(strips: list[Strip], ties: list[TieArea], controls: list[ControlArea], tilts: bool) -> Adjustment:
    """The adjustment in the engine (no data snooping); raises when it is singular."""
    params, groups = observation_groups(strips, ties, controls, tilts)
    if not groups:
        raise LidarError("the strip adjustment has no tie or control area")
    result = adjust(params, groups, SolverOptions(), SnoopingOptions(enabled=False))
    if result.solution.regularisation:
        undetermined = ", ".join(f"{n.key.label} {n.component}" for n in result.solution.regularisation[:6])
        raise LidarError(
            "the strip adjustment is singular: some strips are not tied to control "
            "(add control areas, or tie areas linking every strip to a controlled one; tilts need "
            f"areas spread along and across each strip); undetermined: {undetermined}"
        )
    return result


def _covariances(result: Adjustment, strips: list[Strip]) -> np.ndarray:
    """(n, k, k) a priori covariance blocks per strip (m^2, m^2/m, m^2/m^2): the selected inverse's
    entries, and where a pair lies outside the factor's pattern (an exact zero in the normal matrix,
    e.g. areas on a cross strip's axis) a solve with the factor restricted to the strip's columns."""
    stats = result.statistics
    layout, scale = result.solution.layout, result.solution.system.scale
    out = []
    for s in strips:
        key = StripHeight(s.name)
        cov = stats.covariance(key, posterior=False)
        if not np.isfinite(cov).all():
            cols = layout.columns(key)
            z = stats.inverse.partial_solver().solve(cols, np.eye(cols.size), cols)
            cov = z / np.outer(scale[cols], scale[cols])
        out.append((cov + cov.T) / 2)
    return np.array(out)


def offset_covariance(
    strips: list[Strip], ties: list[TieArea], controls: list[ControlArea], tilts: bool = False
) -> np.ndarray:
    """A priori covariance (n, k, k) of each strip's parameters from the configuration alone (network
    design): offset (m^2) and with ``tilts`` the along and across tilts; the observations do not enter."""
    return _covariances(_solve(strips, ties, controls, tilts), strips)


def design_reliability(
    strips: list[Strip], ties: list[TieArea], controls: list[ControlArea], tilts: bool = False
) -> Reliability:
    """Redundancy numbers and minimal detectable blunders (m) of every tie and control area from the
    configuration alone (:func:`scangeo.lsq.reliability.compute_reliability`, internal reliability)."""
    result = _solve(strips, ties, controls, tilts)
    return compute_reliability(result.solution, result.statistics, external=False)


def adjust_strips(
    strips: list[Strip], ties: list[TieArea], controls: list[ControlArea], tilts: bool = False
) -> StripAdjustment:
    """Least-squares height offsets (and tilts) of the strips with their covariance.

    The covariance is the a priori one, ``(A^T P A)^-1`` with the given sigmas, per strip; multiply by
    ``sigma0**2`` for the a posteriori one.
    """
    result = _solve(strips, ties, controls, tilts)
    values = result.parameters.values()
    params = np.array([values[StripHeight(s.name)] for s in strips])
    stats = result.statistics
    v = np.concatenate([r * g.sigma for r, g in zip(stats.residuals(), result.solution.groups)
                        if isinstance(g, HeightAreas)])
    redundancy = stats.redundancy
    sigma0 = float(stats.sigma0) if redundancy > 0 else float("nan")
    cov = _covariances(result, strips)
    return StripAdjustment(params=params, covariance=cov, offset_sigma=np.sqrt(cov[:, 0, 0]), sigma0=sigma0,
                           redundancy=redundancy, residuals=v)
