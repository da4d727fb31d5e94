"""Observations removed from a solved adjustment without refactorising: a low-rank (Woodbury) update.

Data snooping removes one observation unit (a few rows) at a time and needs the new solution and the
new redundancy numbers of every tested row. Refactorising and re-inverting the normal matrix for
every removal is what made large blocks slow. With the scaled normal matrix ``N`` of the last full
solution, its factor and its selected inverse, removing the scaled Jacobian rows ``A`` (k x n) gives

    N' = N - A^T A,   N'^-1 = N^-1 + U S^-1 U^T,   U = N^-1 A^T,   S = I - A U

(Sherman-Morrison-Woodbury; ``S`` is the redundancy matrix of the removed rows, singular exactly when
the removal leaves some unknown undetermined). Every removal since the last full solution is kept in
``A``: one solve with the existing factor per removed row, no factorisation.

- The new solution: Gauss-Newton steps ``dx = -N'^-1 g`` with the gradient ``g`` of the current
  linearisation (removed rows left out) and ``N'^-1`` as above, until the step promises a cost
  decrease below the solver's ``chi2_tolerance``, the solver's own convergence test. The normal
  matrix stays that of the last factorisation (a chord iteration: linearly convergent, one or two
  steps after a removal).
- The new leverages of the tested rows: ``h'_i = h_i + (j_i U) S^-1 (j_i U)^T`` from those of the
  last full solution (same linearisation), so the redundancy numbers ``1 - h'_i`` and the w-tests
  are those of the reduced adjustment.

Memory: ``U`` (unknowns x removed rows, dense) is never kept. What the tests and steps need of it
is kept instead: ``V U`` (k x k, for ``S``) and ``B = J_t U`` (tested rows x k, for the leverages),
formed as each removal's columns of ``U`` are solved, a few columns at a time; ``N'^-1 b`` is
``y + N^-1 V^T S^-1 V y`` with ``y = N^-1 b`` (``U^T b = V N^-1 b``: ``N`` is symmetric), one more solve
with the existing factor. On 96 strips of block24 ``U`` held 876,489 unknowns x about 80 rows
(560 MB, and twice that while it grew); the tested rows are about 30,000.

An unknown that no active row observes any more (a point whose every measurement was removed as a
non-separable blunder) gets, in the update, the pseudo-observation the solver's next full solution
will give it (``x = current value`` with the block's regularisation sigma): rows ``R`` added with
``N' = N - A^T A + R^T R``, i.e. ``V = [A; R]`` with signs ``C = diag(-1, +1)``,
``N'^-1 = N^-1 + U S^-1 U^T``, ``U = N^-1 V^T``, ``S = -C - V U``. So such a removal needs no
factorisation either (before, each was a full solution: the number of those grew with the block).

The update declines (the caller then refactorises) when ``S`` is nearly singular (the removal leaves
an unknown undetermined otherwise, which needs the solver's regularisation by pivots), when a step
does not lower the cost, or when the chord iteration has not converged in a few steps.

**Linear rounds** (``remove(..., linear=True)``; ``snooping_method = "linear"``). The chord iteration
linearises the whole block at every step: two or three linearisations per removal, 60 % of the laser
comparison's CPU on a montafon block (1,139 linearisations of 76 strips' anchors, 0.41 s each, for 480
removals). A linear round instead takes the chord steps on the linear model of the last state,
residuals ``r + J dx`` and gradient ``J^T r`` with the same ``J`` (a sparse product and two solves with
the existing factor per step, no linearisation): on the last full solution's linearisation this is
exact in one step (``N'`` is then that model's normal matrix). The w-tests of the next round read
those residuals. When no w exceeds the critical value any more, :meth:`RemovalUpdate.polish` runs the
chord iteration of the nonlinear model, from the last nonlinear state through every removal since
(the very steps a removal of the default mode takes), and the w-tests are read again there: a round
whose removals leave no w above the critical value ends exactly as in the default mode, to the bit.
Only the choice of later rounds' units rests on the linear model, whose residuals differ from the
nonlinear ones by the second-order terms of the steps.
"""
from __future__ import annotations

import logging

import numpy as np
import scipy.sparse as sp

from scangeo.blas import one_thread
from scangeo.errors import AdjustmentError
from scangeo.lsq.solver import Solution, Solver
from scangeo.lsq.statistics import MIN_REDUNDANCY

log = logging.getLogger(__name__)

#: ``S`` with an eigenvalue below this: the removal leaves an unknown (nearly) undetermined.
MIN_EIGENVALUE = 1e-8
#: At most this many chord steps per removal.
MAX_STEPS = 6
#: Columns of ``U`` solved at once (each is a dense vector over all unknowns).
COLUMNS = 8


class RemovalUpdate:
    """The adjustment of ``solution`` with rows removed since, kept up to date without refactorising.

    Parameters
    ----------
    solver : the solver that produced ``solution`` (its groups, layout and options).
    solution : the last full solution: factor, linearisation, values, active rows.
    leverage : (m,) ``h_i = j_i N^-1 j_i^T`` of every row of ``solution``'s system (its statistics).
    tested : (m,) rows whose w-tests are wanted (their leverages are updated).
    """

    def __init__(self, solver: Solver, solution: Solution, leverage: np.ndarray, tested: np.ndarray) -> None:
        self.solver = solver
        self.solution = solution
        system = solution.system
        self.scale = system.scale
        self._Js = (system.jacobian @ sp.diags(1.0 / system.scale)).tocsr()
        self._tested = np.flatnonzero(tested)
        self._J_tested = self._Js[self._tested]
        self._h0 = leverage[self._tested]
        self.active = [a.copy() for a in solution.active]
        self.values = solution.parameters.values()
        self.removed = np.zeros(0, dtype=np.int64)
        self._V = sp.csr_matrix((0, solver.layout.n))      # removed rows and added regularisation rows
        self._sign = np.zeros(0)                             # -1 removed, +1 added
        self._VU: np.ndarray = np.zeros((0, 0))             # V N^-1 V^T
        self._B: np.ndarray = np.zeros((self._tested.size, 0))  # J_tested N^-1 V^T
        self._S_inv: np.ndarray = np.zeros((0, 0))
        self._h: np.ndarray | None = None                   # the leverages of this state (leverages())
        # for the leverages, kept from one state to the next: M = B S^-1 and e = diag(B S^-1 B^T) of the
        # first ``M.shape[1]`` columns, with that state's S^-1
        self._M: np.ndarray = np.zeros((self._tested.size, 0))
        self._e: np.ndarray = np.zeros(self._tested.size)
        self._M_S_inv: np.ndarray = np.zeros((0, 0))
        # per column, the active rows that observe it (an orphaned unknown gets a pseudo-observation)
        nonzero = self._Js.data != 0
        self._observers = np.bincount(self._Js.indices[nonzero], minlength=solver.layout.n)
        self._residuals = system.residuals
        self._jacobian = system.jacobian
        self.cost = system.cost
        # the last state of the nonlinear model (values, residuals, Jacobian): where the chord iteration
        # starts; the current state above runs ahead of it by linear rounds
        self._nonlinear = (self.values, self._residuals, self._jacobian)
        #: True while the current state is the nonlinear model's (no linear round since the last chord iteration)
        self.polished = True
        self.steps = 0
        self.linear_steps = 0

    # -- removal --------------------------------------------------------------------------------
    def _deactivate(self, rows: np.ndarray) -> None:
        rows = np.unique(rows)
        was = np.concatenate(self.active)[rows]
        for act, sl in zip(self.active, self.solution.system.row_slices):
            inside = rows[(rows >= sl.start) & (rows < sl.stop)]
            act[inside - sl.start] = False
        gone = self._Js[rows[was]]
        np.subtract.at(self._observers, gone.indices[gone.data != 0], 1)

    def remove(self, rows: np.ndarray, max_rows: int | None = None, linear: bool = False) -> bool:
        """Remove the (global) rows from ``active`` and update the solution; False when that needs a
        full solution instead (also when more than ``max_rows`` rows would be removed in all).
        ``linear``: the new solution of the current state's linear model (module docstring; :meth:`polish`
        takes it to the nonlinear model's)."""
        rows = np.asarray(rows, dtype=np.int64)
        self._deactivate(rows)
        if max_rows is not None and self.removed.size + rows.size > max_rows:
            return False
        A = self._Js[rows]
        R = self._regularisation(A)
        V_new = sp.vstack([A, R], format="csr")
        V = sp.vstack([self._V, V_new], format="csr")
        k_old, k = self._V.shape[0], V.shape[0]
        VU = np.zeros((k, k))
        VU[:k_old, :k_old] = self._VU
        B = np.zeros((self._tested.size, k))
        B[:, :k_old] = self._B
        for a in range(0, V_new.shape[0], COLUMNS):  # U's new columns, a few at a time, never kept
            b = min(a + COLUMNS, V_new.shape[0])
            rhs = V_new[a:b].T.toarray()
            U = np.asarray(self.solution.factor.solve(rhs)).reshape(rhs.shape)
            VU[:, k_old + a:k_old + b] = V @ U
            B[:, k_old + a:k_old + b] = self._J_tested @ U
            del rhs, U
        VU[k_old:, :k_old] = VU[:k_old, k_old:].T
        self._h = None
        self.removed = np.concatenate([self.removed, rows])
        self._V, self._VU, self._B = V, VU, B
        self._sign = np.concatenate([self._sign, -np.ones(rows.size), np.ones(R.shape[0])])
        S = self._S_full()
        with one_thread():  # k x k, k up to a few hundred: OpenBLAS's threads only cost (scangeo/blas.py)
            smallest = float(np.min(np.abs(np.linalg.eigvalsh(S))))
            if smallest < MIN_EIGENVALUE:
                log.info("removal leaves unknowns undetermined (redundancy eigenvalue %.3g): refactorising", smallest)
                return False
            self._S_inv = np.linalg.inv(S)
        if linear:
            self.polished = False
            return self._linear_solve()
        return self._solve()

    def polish(self) -> bool:
        """The nonlinear model's solution after the linear rounds since the last one: the chord iteration
        from the last nonlinear state with every removal since; False when that needs a full solution."""
        self.polished = True
        return self._solve()

    def _regularisation(self, A: sp.csr_matrix) -> sp.csr_matrix:
        """Scaled rows of the pseudo-observations ``x = current value`` (the block's regularisation
        sigma, as the solver adds them) of the columns of ``A`` that no active row observes any more
        (a point whose every measurement was removed): with them the update stays regular, as the
        next full solution regularises those unknowns."""
        orphans = [int(c) for c in np.unique(A.indices) if self._observers[c] <= 0]
        values = []
        for c in orphans:
            values.append(1.0 / (self.solver.regularisation_sigma(c)[2] * self.scale[c]))
        k = len(orphans)
        return sp.csr_matrix((np.array(values), (np.arange(k), np.array(orphans, dtype=np.int64))),
                             shape=(k, self._Js.shape[1]))

    @property
    def scaled_jacobian(self) -> sp.csr_matrix:
        """``J D^-1`` of the last full solution's linearisation (removed rows included)."""
        return self._Js

    def apply_inverse(self, b: np.ndarray) -> np.ndarray:
        """``N'^-1 b`` for one or several (n x k) right-hand sides: ``y + N^-1 V^T S^-1 V y`` with
        ``y = N^-1 b`` (the scaled normal matrix with the removed rows left out)."""
        b = np.asarray(b, dtype=float)
        factor = self.solution.factor
        y = np.asarray(factor.solve(b)).reshape(b.shape)
        if self._V.shape[0] == 0:
            return y
        c = self._S_inv @ (self._V @ y)
        return y + np.asarray(factor.solve(np.asarray(self._V.T @ c))).reshape(b.shape)

    def _linear_solve(self) -> bool:
        """Chord steps on the current state's linear model (residuals ``r + J dx``, the same ``J``) until the
        step promises a cost decrease below the solver's ``chi2_tolerance``; no linearisation."""
        opts, layout = self.solver.options, self.solver.layout
        act = np.concatenate(self.active)
        r = self._residuals * act
        values, J = self.values, self._jacobian
        for _ in range(MAX_STEPS):
            gradient = (J.T @ r) / self.scale
            step = self.apply_inverse(-gradient)
            self.linear_steps += 1
            if float(step @ -gradient) < opts.chi2_tolerance:
                self.values, self._residuals, self.cost = values, r, float(r @ r)
                return True
            dx = step / self.scale
            values = layout.add_step(values, dx)
            r = (r + J @ dx) * act
        log.info("linear chord steps did not converge in %d steps: refactorising", MAX_STEPS)
        self.values, self._residuals, self.cost = values, r, float(r @ r)
        return False

    def _solve(self) -> bool:
        solver, opts = self.solver, self.solver.options
        values, residuals, J = self._nonlinear
        r = residuals * np.concatenate(self.active)
        cost = float(r @ r)
        for _ in range(MAX_STEPS):
            gradient = (J.T @ r) / self.scale
            step = self.apply_inverse(-gradient)
            self.steps += 1
            if float(step @ -gradient) < opts.chi2_tolerance:  # converged (the solver's test)
                self.values, self._residuals, self._jacobian, self.cost = values, r, J, cost
                self._nonlinear = (values, r, J)
                return True
            trial = solver.layout.add_step(values, step / self.scale)
            try:
                r_new, J_new, _ = solver.linearisation(trial, self.active)
            except AdjustmentError as exc:  # a model that cannot be evaluated there: let the solver damp
                log.info("chord step failed (%s): refactorising", exc)
                return False
            cost_new = float(r_new @ r_new)
            log.debug("chord step: cost %.6g -> %.6g, predicted decrease %.3g", cost, cost_new, float(step @ -gradient))
            if not cost_new <= cost * (1 + 1e-12):
                log.info("chord step raised the cost (%.6g -> %.6g): refactorising", cost, cost_new)
                return False
            values, r, J, cost = trial, r_new, J_new, cost_new
        log.info("chord iteration did not converge in %d steps: refactorising", MAX_STEPS)
        return False

    # -- tests ----------------------------------------------------------------------------------
    def leverages(self) -> np.ndarray:
        """``h'_i = j_i N'^-1 j_i^T`` of every tested row of the stack (NaN for the others); computed
        once per state (the w-tests and each unit's separability test of a round read the same), read-only.

        ``diag(B S^-1 B^T)`` is carried from the last state on by the bordered inverse of ``S``: with the
        columns ``o`` known (``M = B_o S_oo^-1``) and ``n`` new, ``C = S_on``, ``G = S_oo^-1 C``, the
        Schur complement ``Z = S_nn - C^T G`` and ``Y = B_n - M C``, the diagonal grows by
        ``diag(Y Z^-1 Y^T)`` and ``M`` becomes ``[M - Y Z^-1 G^T, Y Z^-1]``: tested rows x old x new
        columns per state instead of tested rows x all columns squared (the montafon block's mission
        variant: 12 new of up to 256 columns a round). The first state after a full solution is the
        direct product, as before."""
        if self._h is None:
            B, k_old = self._B, self._M.shape[1]
            if k_old == 0:
                M = B @ self._S_inv
                e = np.einsum("ik,ik->i", M, B)
            else:
                S = self._S_full()
                C = S[:k_old, k_old:]
                B_new = B[:, k_old:]
                with one_thread():
                    G = self._M_S_inv @ C
                    Z = S[k_old:, k_old:] - C.T @ G
                    Z_inv = np.linalg.inv(0.5 * (Z + Z.T))
                Y = B_new - self._M @ C
                YZ = Y @ Z_inv
                e = self._e + np.einsum("ik,ik->i", YZ, Y)
                M = np.hstack([self._M - YZ @ G.T, YZ])
            self._M, self._e, self._M_S_inv = M, e, self._S_inv
            h = np.full(self._residuals.size, np.nan)
            h[self._tested] = self._h0 + e
            h.setflags(write=False)
            self._h = h
        return self._h

    def _S_full(self) -> np.ndarray:
        """``S = -C - V U`` of every removal since the last full solution (symmetrised, as inverted)."""
        VU = self._VU
        return -np.diag(self._sign) - 0.5 * (VU + VU.T)

    def coupling_correction(self, rows_a: np.ndarray, rows_b: np.ndarray) -> np.ndarray:
        """``j_b (N'^-1 - N^-1) j_a^T = B_b S^-1 B_a^T`` for tested (global) rows: what the removals since
        the last full solution add to the couplings of two sets of rows."""
        ia, ib = np.searchsorted(self._tested, rows_a), np.searchsorted(self._tested, rows_b)
        if not (np.array_equal(self._tested[np.minimum(ia, self._tested.size - 1)], rows_a)
                and np.array_equal(self._tested[np.minimum(ib, self._tested.size - 1)], rows_b)):
            raise ValueError("couplings of rows that are not tested")
        return self._B[ib] @ self._S_inv @ self._B[ia].T

    def w_tests(self) -> list[np.ndarray]:
        """Per group, Baarda's w of every active tested row (NaN elsewhere), as ``Statistics.w_tests``."""
        h = self.leverages()
        out = []
        for act, sl in zip(self.active, self.solution.system.row_slices):
            red = 1.0 - h[sl]
            w = self._residuals[sl] / np.sqrt(np.maximum(red, MIN_REDUNDANCY))
            out.append(np.where(act & (red >= MIN_REDUNDANCY), w, np.nan))
        return out
