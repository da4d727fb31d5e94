"""Several blunders per round of data snooping, when their w-tests cannot influence each other.

Baarda's data snooping removes one observation unit per round, the one with the largest ``|w|``,
because removing a blunder changes the residuals of every observation correlated with it: a unit
whose ``|w|`` is only the smear of a larger blunder nearby falls below the critical value once that
one is gone. The number of rounds therefore grows with the number of blunders, i.e. with the block,
and every round costs work over the whole block.

Removing unit ``j`` (rows ``R``) changes the whitened residuals of the others by
``dv = Q_vR Q_RR^-1 v_R`` (``Q = I - J N^-1 J^T``, the cofactor matrix of the residuals); for one row
``b`` the w-test of row ``a`` moves by ``rho_ab w_b`` with ``rho_ab = Q_ab / sqrt(Q_aa Q_bb)``, the
correlation of the two w-tests, and its redundancy number by ``rho_ab^2 r_a``. So a unit whose rows
are uncorrelated with those of every unit ranked above it keeps its w-test, to first order, whatever
is removed before it: Baarda's sequence would still reject it, and it can go in the same round.

The rule (:func:`independent_units`): the candidates are the units above the critical value, one per
point, best first. The first is taken. A further one is taken when, for every candidate ranked above
it (taken or not) and every pair of rows ``a`` of its point and ``b`` of the other's (all tested rows
of both points: a blunder that is not separable removes the whole point),
``sum_b |rho_ab| |w_b| <= MAX_INFLUENCE`` and ``sum_a |rho_ab| |w_a| <= MAX_INFLUENCE``: neither removal
moves a w-test of the other point by more than ``MAX_INFLUENCE``, to first order. Far apart (no
shared unknowns, strips with no overlap between them) the correlations are of order 1e-4 and below;
in the same or neighbouring strips a large blunder influences its neighbours and waits for the next
round.

``Q_ab = -j_a N^-1 j_b^T`` comes from the factor of the last full solution by a solve restricted to
the entries needed (:class:`~scangeo.lsq.partial_solve.PartialSolver`: the ancestors of the rows'
unknowns in the elimination tree), with the low-rank correction of the removals since
(``B_a S^-1 B_b^T``, :class:`~scangeo.lsq.removal.RemovalUpdate`): no solve over the whole block.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
import scipy.sparse as sp

from scangeo.lsq.observations import ObservationGroup
from scangeo.lsq.partial_solve import PartialSolver

#: Largest first-order change of a w-test that two units removed in the same round may cause each other.
MAX_INFLUENCE = 0.1
#: At most this many candidates are examined per round.
CANDIDATES = 64


def couplings(Js: sp.csr_matrix, solver: PartialSolver, rows_a: np.ndarray, rows_b: np.ndarray) -> np.ndarray:
    """``j_b N^-1 j_a^T`` (``rows_b.size x rows_a.size``) for rows of the scaled Jacobian ``Js``, by a
    solve restricted to the entries that reach it."""
    A, B = Js[rows_a], Js[rows_b]
    cols_a, cols_b = np.unique(A.indices), np.unique(B.indices)
    if cols_a.size == 0 or cols_b.size == 0:
        return np.zeros((rows_b.size, rows_a.size))
    X = solver.solve(cols_a, A[:, cols_a].T.toarray(), cols_b)
    return np.asarray(B[:, cols_b] @ X)


def independent_units(candidates: Sequence[tuple[int, int, float]], groups: Sequence[ObservationGroup],
                      slices: Sequence[slice], point_rows: Callable[[str], np.ndarray], Js: sp.csr_matrix,
                      w: np.ndarray, leverage: np.ndarray, solver: PartialSolver,
                      correction: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None,
                      count: int | None = None) -> list[tuple[int, int, float]]:
    """The candidates (group index, unit, |w|; best first, distinct points) that go in one round.

    Parameters
    ----------
    point_rows : the global rows a point's removal may take (its active tested rows).
    Js : (m, n) the scaled Jacobian ``J D^-1`` of the last full solution (every row).
    w, leverage : (m,) the current w-tests and leverages ``h = j N'^-1 j^T`` (NaN: not tested).
    solver : restricted solves with the last full solution's factor (``N^-1``).
    correction : ``(rows_a, rows_b) -> j_b (N'^-1 - N^-1) j_a^T`` of the removals since, or None.
    count : at most this many units (None: no limit).
    """
    taken: list[tuple[int, int, float]] = []
    ranked: list[np.ndarray] = []    # the rows of every candidate examined so far, taken or not
    for gi, unit, w_max in candidates:
        if count is not None and len(taken) == count:
            break
        group = groups[gi]
        own = slices[gi].start + np.flatnonzero(group.row_unit == unit)
        rows = np.union1d(point_rows(str(group.ids[group.row_unit == unit][0])), own)
        rows = rows[np.isfinite(w[rows])]
        if ranked and rows.size:
            above = np.concatenate(ranked)
            q = couplings(Js, solver, rows, above)
            if correction is not None:
                q = q + correction(rows, above)
            r_a, r_b = 1.0 - leverage[rows], 1.0 - leverage[above]
            rho = np.abs(q) / np.sqrt(np.outer(r_b, r_a))
            owner = np.repeat(np.arange(len(ranked)), [x.size for x in ranked])
            # per point ranked above: its influence on each of our rows, and ours on each of its rows
            influence_on_ours = np.zeros((len(ranked), rows.size))
            np.add.at(influence_on_ours, owner, rho * np.abs(w[above])[:, None])
            influence_on_theirs = rho @ np.abs(w[rows])
            independent = max(influence_on_ours.max(initial=0.0), influence_on_theirs.max(initial=0.0)) <= MAX_INFLUENCE
        else:
            independent = True
        ranked.append(rows)
        if independent:
            taken.append((gi, unit, w_max))
    return taken


__all__ = ["CANDIDATES", "MAX_INFLUENCE", "couplings", "independent_units"]
