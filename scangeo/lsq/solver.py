"""Gauss-Newton with Levenberg-Marquardt damping, sparse normal equations, regularisation on the fly.

Every iteration linearises all observation groups at the current values, forms the normal equations
``N dx = -J^T r`` (Jacobi-scaled to a unit diagonal), factorises them by sparse Cholesky and steps. A
step that does not lower the cost is retried with damping ``(N + lambda I)``. The iteration stops when
the largest step is below ``step_tolerance`` in units of ``1/sqrt(N_ii)`` (a lower bound of each
unknown's standard deviation), or ``dx^T N dx`` (the step's squared length measured in standard
deviations of the unknowns, i.e. the cost decrease it promises) is below ``chi2_tolerance`` (1e-3: a
step of about 3 % of a standard deviation), or the cost no longer decreases.

Regularisation on the fly: an unknown without any observation (zero column), or whose scaled pivot
falls below ``pivot_tolerance`` (it is, numerically, a combination of others), gets the
pseudo-observation ``x = current value`` with its block's ``regularisation_sigma``; the solution
lists every such unknown with the sigma used and the reason. The adjustment never fails on a rank
defect.
"""
from __future__ import annotations

import logging
import time
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from scangeo.errors import AdjustmentError
from scangeo.lsq.factor import Factor, Factorizer, NotPositiveDefinite
from scangeo.lsq.keys import Key
from scangeo.lsq.observations import ObservationGroup, PseudoObservations
from scangeo.lsq.parameters import Layout, Parameters
from scangeo.progress import ProgressCallback, no_progress

log = logging.getLogger(__name__)

#: A relative cost increase below this is rounding, not a failed step (the iteration has converged).
FLOOR = 1e-9


@dataclass(frozen=True)
class SolverOptions:
    """Options of the Gauss-Newton iteration.

    backend : ``"auto"`` (CHOLMOD when installed, else SuperLU), ``"cholmod"`` or ``"superlu"``.
    pivot_tolerance : scaled pivots below it mark an unknown as undetermined (regularised).
    """

    max_iterations: int = 30
    step_tolerance: float = 1e-3
    cost_tolerance: float = 1e-10
    chi2_tolerance: float = 1e-3
    backend: str = "auto"
    pivot_tolerance: float = 1e-10
    damping: bool = True
    max_damping_steps: int = 12


@dataclass(frozen=True)
class RegularisationNote:
    """One unknown the solver had to regularise: ``key[component] = value +- sigma``."""

    key: Key
    component: str
    sigma: float
    reason: str


@dataclass(frozen=True)
class IterationInfo:
    number: int
    cost: float
    max_scaled_step: float
    damping: float
    seconds: float


@dataclass
class System:
    """The stacked, whitened system at one point: residuals, Jacobian, scaled normal matrix."""

    residuals: np.ndarray          # (m,) whitened, rejected rows set to 0
    jacobian: sp.csr_matrix        # (m, n), rejected rows zero
    scale: np.ndarray              # (n,) sqrt(diag N), the Jacobi scaling
    normal: sp.csc_matrix          # D^-1 N D^-1
    gradient: np.ndarray           # D^-1 J^T r
    row_slices: list[slice]        # rows of each group in the stack

    @property
    def cost(self) -> float:
        return float(self.residuals @ self.residuals)


@dataclass
class Solution:
    """The adjusted unknowns and the final system, input to the statistics."""

    parameters: Parameters
    layout: Layout
    groups: list[ObservationGroup]      # observation and pseudo-observation groups, priors and regularisation last
    active: list[np.ndarray]            # per group, rows in the adjustment (data snooping removes rows)
    system: System
    factor: Factor
    iterations: list[IterationInfo]
    converged: bool
    regularisation: list[RegularisationNote] = field(default_factory=list)

    def values(self) -> dict[Key, np.ndarray]:
        return self.parameters.values()


def prior_group(parameters: Parameters) -> PseudoObservations | None:
    """The pseudo-observations of every free component that has a finite prior sigma."""
    keys, comps, vals, sig, names = [], [], [], [], []
    for b in parameters:
        if b.prior_sigma is None or b.prior_values is None:
            continue
        for i in np.flatnonzero(b.free & np.isfinite(b.prior_sigma)):
            keys.append(b.key)
            comps.append(i)
            vals.append(b.prior_values[i])
            sig.append(b.prior_sigma[i])
            names.append(b.names[i])
    if not keys:
        return None
    return PseudoObservations("priors", keys, np.array(comps), np.array(vals), np.array(sig), names)


@dataclass
class _Outcome:
    """What one iteration ended with: the values after it, the cost reported, its largest scaled
    step and damping, whether to stop and whether that is convergence, and whether its system and
    factor are the solution's (a negligible step)."""

    values: dict
    cost: float
    max_step: float
    damping: float = 0.0
    done: bool = False
    converged: bool = False
    keep_system: bool = False


#: Why an unknown is regularised when no observation determines it, and when every observation that
#: determined it was removed (data snooping: expected, said at INFO).
UNOBSERVED = "no observation determines it"
REMOVED = "every observation that determined it was removed"


class Solver:
    """Solves ``min sum ||r_g(x)||^2`` over the free unknowns of ``parameters``."""

    def __init__(self, parameters: Parameters, groups: Sequence[ObservationGroup],
                 options: SolverOptions = SolverOptions(), callback: ProgressCallback = no_progress) -> None:
        self.parameters = parameters.copy()
        self.layout = Layout.of(self.parameters)
        self.groups = list(groups)
        prior = prior_group(self.parameters)
        if prior is not None:
            self.groups.append(prior)
        self.options = options
        self.callback = callback
        self.factorizer = Factorizer(options.backend)
        self.regularisation: list[RegularisationNote] = []
        self._regularised: dict[int, int] = {}   # column -> times tightened
        self._observed = np.zeros(self.layout.n, bool)  # columns some active observation has determined

    # -- assembly -------------------------------------------------------------------------------
    def linearisation(self, values, active: list[np.ndarray]) -> tuple[np.ndarray, sp.csr_matrix, list[slice]]:
        """Stacked whitened residuals and Jacobian (rows not active set to zero) and each group's rows."""
        res, jac, slices, start = [], [], [], 0
        for group, act in zip(self.groups, active):
            lin = group.linearise(values)
            J = self.layout.matrix(lin.parts, group.n_rows)
            r = np.where(act, lin.residuals, 0.0)
            if not act.all():  # zero the rejected rows' entries (in place: no sparse product)
                J.data *= np.repeat(act, np.diff(J.indptr))
            res.append(r)
            jac.append(J)
            slices.append(slice(start, start + group.n_rows))
            start += group.n_rows
        J = sp.vstack(jac, format="csr") if jac else sp.csr_matrix((0, self.layout.n))
        r = np.concatenate(res) if res else np.zeros(0)
        return r, J, slices

    def system(self, values, active: list[np.ndarray]) -> System:
        r, J, slices = self.linearisation(values, active)
        N = (J.T.tocsr() @ J).tocsc()
        d = np.sqrt(np.maximum(N.diagonal(), 0.0))
        scale = np.where(d > 0, d, 1.0)
        # D^-1 N D^-1 on N's own pattern
        N.data /= scale[N.indices] * np.repeat(scale, np.diff(N.indptr))
        return System(r, J, scale, N, (J.T @ r) / scale, slices)

    def regularisation_sigma(self, column: int) -> tuple[Key, int, float]:
        """The key, component and regularisation sigma (1 when the block sets none) of a column."""
        key, i = self.layout.locate(column)
        reg = self.parameters[key].regularisation_sigma
        return key, i, float(reg[i]) if reg is not None else 1.0

    def _regularise(self, values, columns: np.ndarray, reason: str, tighten: float = 1.0,
                    removed: np.ndarray | None = None) -> PseudoObservations:
        """Pseudo-observations holding ``columns`` at their values; ``removed`` marks those whose observations
        were all taken out (data snooping): expected, logged at INFO instead of WARNING."""
        keys, comps, vals, sig, names = [], [], [], [], []
        for k, col in enumerate(columns):
            key, i, sigma = self.regularisation_sigma(int(col))
            block = self.parameters[key]
            sigma /= tighten
            keys.append(key)
            comps.append(i)
            vals.append(values[key][i])
            sig.append(sigma)
            names.append(block.names[i])
            why = REMOVED if removed is not None and removed[k] else reason
            self.regularisation.append(RegularisationNote(key, block.names[i], sigma, why))
            self._regularised[int(col)] = self._regularised.get(int(col), -1) + 1
            log.log(logging.INFO if why == REMOVED else logging.WARNING,
                    "regularised %s[%s] with sigma %g: %s", key.label, block.names[i], sigma, why)
        return PseudoObservations("regularisation", keys, np.array(comps), np.array(vals), np.array(sig), names)

    def factorize(self, values, active: list[np.ndarray]) -> tuple[System, Factor]:
        """The system at ``values`` and its factor, regularising undetermined unknowns as needed."""
        while True:
            system = self.system(values, active)
            raw_diag = np.asarray((system.jacobian.multiply(system.jacobian)).sum(axis=0)).ravel()
            empty = np.flatnonzero(raw_diag <= 0.0)
            self._observed |= raw_diag > 0.0
            reason = UNOBSERVED
            if empty.size == 0:
                try:
                    factor = self.factorizer.factorize(system.normal)
                    pivots = factor.pivots()
                except NotPositiveDefinite as exc:
                    factor, pivots = None, exc.pivots
                bad = np.flatnonzero(~(pivots > self.options.pivot_tolerance))
                if bad.size == 0 and factor is not None:
                    return system, factor
                if bad.size == 0:  # the Cholesky failed, the LDL^T pivots are all just above the tolerance
                    bad = np.array([int(np.argmin(pivots))])
                empty = bad
                reason = (
                    "singular or nearly singular normal equations "
                    f"(scaled pivot below {self.options.pivot_tolerance:g})"
                )
            tighten = 1.0
            fresh = np.array([c for c in empty if int(c) not in self._regularised], dtype=np.int64)
            if fresh.size == 0:  # already regularised, still undetermined: a pseudo-observation 100x tighter
                rounds = max(self._regularised[int(c)] for c in empty) + 1
                if rounds > 4:
                    raise NotPositiveDefinite("regularisation did not make the normal equations regular", pivots)
                fresh, tighten = empty, 100.0**rounds
            removed = self._observed[fresh] if reason == UNOBSERVED else None
            group = self._regularise(values, fresh, reason, tighten, removed)
            self.groups.append(group)
            active = active + [np.ones(group.n_rows, bool)]

    # -- iteration ------------------------------------------------------------------------------
    def solve(self, active: list[np.ndarray] | None = None) -> Solution:
        """Iterate to convergence from the current values; ``active`` rows per group (default all).

        Every iteration (:meth:`_iterate`) factorises the system at the current values, takes the
        Gauss-Newton step and keeps it if it lowers the cost (damped until it does); the iteration
        ends when the step is negligible or the cost stops falling. The final system and factor
        (:meth:`_finish`) are those of the solution, for the statistics.
        """
        opts = self.options
        values = self.parameters.values()
        active = [] if active is None else list(active)
        self._cover(active)
        iterations: list[IterationInfo] = []
        outcome = _Outcome(values, 0.0, 0.0)
        final = None
        for it in range(1, opts.max_iterations + 1):
            t0 = time.perf_counter()
            outcome, system, factor = self._iterate(values, active)
            values = outcome.values
            iterations.append(IterationInfo(it, outcome.cost, outcome.max_step, outcome.damping,
                                            time.perf_counter() - t0))
            log.info("iteration %d: cost %.6g, max scaled step %.3g, damping %g", it, outcome.cost, outcome.max_step,
                     outcome.damping)
            self.callback(it, opts.max_iterations, f"iteration {it}: cost {outcome.cost:.6g}")
            if outcome.keep_system:  # the step is negligible: keep this linearisation and factor
                final = (system, factor)
            if outcome.done:
                break
        self.callback(opts.max_iterations, opts.max_iterations, "adjusted" if outcome.converged else "not converged")
        return self._finish(values, active, outcome.converged, final, iterations)

    def _cover(self, active: list[np.ndarray]) -> None:
        """In place: every group added since (regularisation) gets all its rows active."""
        active += [np.ones(g.n_rows, bool) for g in self.groups[len(active):]]

    def _iterate(self, values, active: list[np.ndarray]) -> tuple[_Outcome, System, Factor]:
        """One Gauss-Newton iteration from ``values``: the system, the step, its trial."""
        opts = self.options
        system, factor = self.factorize(values, active)
        self._cover(active)
        cost = system.cost
        step = factor.solve(-system.gradient)
        size = float(np.max(np.abs(step), initial=0.0))
        # dx^T N dx: the step's squared length in standard deviations of the unknowns
        predicted = float(step @ -system.gradient)
        # the chi^2 tolerance is in units of the variance factor when that is above 1 (blunders, sigmas too
        # small): a decrease that is negligible against sigma0^2 is negligible, however large sigma0 is
        rows = sum(int(np.count_nonzero(a)) for a in active)
        variance = max(1.0, cost / max(rows - self.layout.n, 1))
        if size < opts.step_tolerance or predicted < opts.chi2_tolerance * variance:  # converged: no trial needed
            return _Outcome(self.layout.add_step(values, step / system.scale), cost, size, done=True,
                            converged=True, keep_system=True), system, factor
        new_values = self.layout.add_step(values, step / system.scale)
        new_cost = self._cost(new_values, active)
        if cost < new_cost <= cost * (1 + FLOOR):
            # the Gauss-Newton step changes the cost only at the rounding level: a minimum
            return _Outcome(values, cost, size, done=True, converged=True, keep_system=True), system, factor
        lam = 0.0
        if opts.damping and new_cost > cost * (1 + 1e-12) + 1e-300:
            step, new_values, new_cost, lam = self._damped_step(values, system, cost, active)
        return self._judge(values, cost, step, new_values, new_cost, lam), system, factor

    def _damped_step(self, values, system: System, cost: float, active: list[np.ndarray]):
        """Levenberg-Marquardt: ``(N + lambda I)`` with lambda from 1e-4 up by tens until the step
        lowers the cost (or ``max_damping_steps`` are spent); (step, values, cost, lambda)."""
        lam = 1e-4
        eye = sp.eye(self.layout.n, format="csc")
        for _ in range(self.options.max_damping_steps):
            step = self.factorizer.factorize(system.normal + lam * eye).solve(-system.gradient)
            new_values = self.layout.add_step(values, step / system.scale)
            new_cost = self._cost(new_values, active)
            if new_cost <= cost:
                break
            lam *= 10.0
        return step, new_values, new_cost, lam

    def _judge(self, values, cost: float, step: np.ndarray, new_values, new_cost: float, lam: float) -> _Outcome:
        """Keep a trial step that does not raise the cost; stop at a negligible step or cost change."""
        opts = self.options
        size = float(np.max(np.abs(step), initial=0.0))
        if new_cost > cost * (1 + 1e-12):  # no step lowers the cost: a minimum to numerical precision
            converged = size < opts.step_tolerance or abs(cost - new_cost) <= 1e-9 * max(cost, 1e-300)
            return _Outcome(values, cost, size, lam, done=True, converged=converged)
        small = size < opts.step_tolerance or abs(cost - new_cost) <= opts.cost_tolerance * max(cost, 1e-300)
        return _Outcome(new_values, min(new_cost, cost), size, lam, done=small, converged=small)

    def _finish(self, values, active: list[np.ndarray], converged: bool, final, iterations) -> Solution:
        """The solution at ``values``: the kept system and factor with the final residuals, or a
        fresh factorisation there."""
        if final is not None:
            system, factor = final
            system.residuals = np.concatenate(
                [np.where(a, g.residuals(values), 0.0) for g, a in zip(self.groups, active)] or [np.zeros(0)]
            )
        else:
            system, factor = self.factorize(values, active)
        self._cover(active)
        self.parameters.set_values(values)
        return Solution(self.parameters, self.layout, list(self.groups), active, system, factor, iterations,
                        converged, list(self.regularisation))

    def _cost(self, values, active) -> float:
        """The cost at trial values; infinite where a model cannot be evaluated (the step is damped)."""
        total = 0.0
        for group, act in zip(self.groups, active):
            try:
                r = group.residuals(values)
            except AdjustmentError as exc:
                log.info("trial step rejected: %s", exc)
                return float("inf")
            total += float(np.sum(r[act] ** 2))
        return total if np.isfinite(total) else float("inf")
