"""Statistics of an adjustment: accounting, sigma0, precision, redundancy numbers, w-tests, significance.

With whitened rows (residual / sigma, Jacobian / sigma) and ``N = J^T J``:

- redundancy ``f = observations + pseudo-observations - unknowns`` (conditions eliminated by the
  parametrisation are already missing from the unknowns; the accounting lists them);
- ``sigma0 = sqrt(r^T r / f)`` (a posteriori standard deviation of unit weight);
- precision of unknowns: ``sigma0 * sqrt(diag N^-1)`` (a posteriori) from the selected inverse;
- redundancy numbers ``r_i = 1 - j_i N^-1 j_i^T`` (they sum to ``f``);
- Baarda's w-test ``w_i = r~_i / sqrt(r_i)`` (whitened residual over its standard deviation, sigma0
  a priori = 1); for a row left out of the adjustment (rejected), ``w_i = r~_i / sqrt(1 + h_i)``,
  the test of a predicted residual.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np
import scipy.sparse as sp
import scipy.stats

from scangeo.lsq.keys import Key
from scangeo.lsq.selinv import SparseInverse
from scangeo.lsq.solver import Solution

#: Below this redundancy number an observation is uncontrolled: its w-test is not computed.
MIN_REDUNDANCY = 1e-3


@dataclass(frozen=True)
class Accounting:
    """Numbers of observations, pseudo-observations, unknowns and conditions, and the redundancy."""

    observations: int
    pseudo_observations: int
    rejected: int
    unknowns: int
    conditions: int

    @property
    def parameters(self) -> int:
        """Unknowns before the conditions were eliminated."""
        return self.unknowns + self.conditions

    @property
    def redundancy(self) -> int:
        return self.observations + self.pseudo_observations - self.unknowns

    def as_dict(self) -> dict:
        return dict(observations=self.observations, pseudo_observations=self.pseudo_observations,
                    rejected=self.rejected, parameters=self.parameters, conditions=self.conditions,
                    unknowns=self.unknowns, redundancy=self.redundancy)


@dataclass(frozen=True)
class Coefficient:
    """An unknown with its a posteriori precision and significance test (``t = |value| / sigma``)."""

    key: Key
    component: str
    value: float
    sigma: float
    t: float
    significant: bool


class Statistics:
    """Statistics of a :class:`Solution`; expensive parts are computed on first use."""

    def __init__(self, solution: Solution) -> None:
        self.solution = solution
        s = solution
        obs = sum(int(a.sum()) for g, a in zip(s.groups, s.active) if g.kind == "observation")
        pseudo = sum(int(a.sum()) for g, a in zip(s.groups, s.active) if g.kind != "observation")
        rejected = sum(int((~a).sum()) for a in s.active)
        self.accounting = Accounting(obs, pseudo, rejected, s.layout.n, s.layout.conditions)

    @property
    def redundancy(self) -> int:
        return self.accounting.redundancy

    @cached_property
    def sigma0(self) -> float:
        """A posteriori sigma0 (NaN when the redundancy is 0)."""
        f = self.redundancy
        return float(np.sqrt(self.solution.system.cost / f)) if f > 0 else float("nan")

    @cached_property
    def inverse(self) -> SparseInverse:
        """Selected inverse of the scaled normal matrix."""
        return SparseInverse(self.solution.factor.ldl())

    def _scaled_jacobian(self) -> sp.csr_matrix:
        s = self.solution.system
        J = (s.jacobian @ sp.diags(1.0 / s.scale)).tocsr()
        J.eliminate_zeros()  # rejected rows: their couplings may be outside the factor's pattern
        return J

    @property
    def leverages(self) -> np.ndarray:
        """``h_i = j_i N^-1 j_i^T`` of every row of the stacked system (redundancy number ``1 - h_i``)."""
        return self._leverage

    @cached_property
    def _leverage(self) -> np.ndarray:
        """``h_i = j_i N^-1 j_i^T`` for every row; for rejected rows from their unweighted Jacobian."""
        s = self.solution
        h = self.inverse.quadratic_forms(self._scaled_jacobian())
        if any((~a).any() for a in s.active):  # rejected rows: their Jacobian was zeroed, relinearise
            values = s.parameters.values()
            for group, act, sl in zip(s.groups, s.active, s.system.row_slices):
                if act.all():
                    continue
                lin = group.linearise(values)
                J = (s.layout.matrix(lin.parts, group.n_rows).tocsr()[~act] @ sp.diags(1.0 / s.system.scale)).tocsr()
                h[sl][~act] = self._solved_quadratic_forms(J)
        return h

    def _solved_quadratic_forms(self, J: sp.csr_matrix) -> np.ndarray:
        """``diag(J N^-1 J^T)`` by solves (for rows whose couplings may be outside the pattern), each
        restricted to the row's own unknowns (:class:`~scangeo.lsq.partial_solve.PartialSolver`: exact,
        the work of the columns of the factor that reach them, not of a whole solve)."""
        solver = self.inverse.partial_solver()
        out = np.empty(J.shape[0])
        for i in range(J.shape[0]):
            a, b = J.indptr[i], J.indptr[i + 1]
            cols, vals = J.indices[a:b], J.data[a:b]
            out[i] = float(vals @ solver.solve(cols, vals[:, None], cols)[:, 0]) if b > a else 0.0
        return out

    def redundancy_numbers(self) -> list[np.ndarray]:
        """Per group, the redundancy number of each row (NaN for rejected rows)."""
        out = []
        for act, sl in zip(self.solution.active, self.solution.system.row_slices):
            r = 1.0 - self._leverage[sl]
            out.append(np.where(act, r, np.nan))
        return out

    def residuals(self) -> list[np.ndarray]:
        """Per group, the whitened residuals of every row, rejected rows included (predicted)."""
        s = self.solution
        values = s.parameters.values()
        return [np.where(a, s.system.residuals[sl], g.residuals(values) if not a.all() else 0.0)
                for g, a, sl in zip(s.groups, s.active, s.system.row_slices)]

    def w_tests(self) -> list[np.ndarray]:
        """Per group, Baarda's w of each row (NaN where the redundancy number is below MIN_REDUNDANCY)."""
        out = []
        for res, act, sl in zip(self.residuals(), self.solution.active, self.solution.system.row_slices):
            h = self._leverage[sl]
            r = 1.0 - h
            w = np.where(act, res / np.sqrt(np.maximum(r, MIN_REDUNDANCY)), res / np.sqrt(1.0 + h))
            out.append(np.where(act & (r < MIN_REDUNDANCY), np.nan, w))
        return out

    def covariance(self, key: Key, posterior: bool = True) -> np.ndarray:
        """Covariance block of the free components of ``key`` (NaN for pairs outside the pattern)."""
        s = self.solution
        cols = s.layout.columns(key)
        cols = cols[cols >= 0]
        scale = s.system.scale[cols]
        cov = self.inverse.block(cols) / np.outer(scale, scale)
        return cov * (self.sigma0 ** 2 if posterior else 1.0)

    def joint_covariance(self, keys: Sequence[Key], posterior: bool = True) -> np.ndarray:
        """The full covariance of the free components of several keys together, cross terms included
        (computed by solves restricted to them, exact also where the pattern has no entry).

        Parameters
        ----------
        keys : sequence of Key
            The blocks, in order; their free components in each block's order.
        posterior : bool
            Scaled by sigma0 a posteriori squared (False: the a priori covariance).

        Returns
        -------
        (m, m) ndarray
            ``m`` the number of free components of the keys.
        """
        s = self.solution
        cols = np.concatenate([s.layout.columns(k) for k in keys]) if keys else np.zeros(0, np.int64)
        cols = cols[cols >= 0]
        z = self.inverse.partial_solver().solve(cols, np.eye(cols.size), cols)
        scale = s.system.scale[cols]
        cov = 0.5 * (z + z.T) / np.outer(scale, scale)
        return cov * (self.sigma0 ** 2 if posterior else 1.0)

    def sigmas(self, key: Key, posterior: bool = True) -> np.ndarray:
        """Standard deviation of every component of ``key`` (NaN for fixed components)."""
        s = self.solution
        cols = s.layout.columns(key)
        out = np.full(cols.size, np.nan)
        f = cols >= 0
        z = self.inverse.diagonal()[cols[f]] / s.system.scale[cols[f]] ** 2
        out[f] = np.sqrt(z) * (self.sigma0 if posterior else 1.0)
        return out

    def significance(self, key: Key, alpha: float = 0.05) -> list[Coefficient]:
        """Two-sided t-test of every free component of ``key`` against zero."""
        block = self.solution.parameters[key]
        sig = self.sigmas(key)
        dof = max(self.redundancy, 1)
        crit = float(scipy.stats.t.ppf(1 - alpha / 2, dof))
        out = []
        for i in np.flatnonzero(block.free):
            t = abs(block.values[i]) / sig[i] if sig[i] > 0 else float("inf")
            value = float(block.values[i])
            out.append(Coefficient(key, block.names[i], value, float(sig[i]), float(t), bool(t > crit)))
        return out
