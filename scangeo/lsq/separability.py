"""Separability of a blunder: can the adjustment say which measurement holds it?

Data snooping removes the observation unit with the largest ``|w|``. That is only an honest answer
when no other measurement could explain the same misclosure. Before a unit is removed, two things are
checked with the current normal matrix (``N^-1`` applied by solves, no inverse):

1. **redundancy after the removal**: with ``U = N^-1 A^T`` for the unit's scaled rows ``A`` and
   ``S = I - A U`` (the unit's redundancy matrix), the redundancy number of another row ``k``
   becomes ``r'_k = r_k - b_k S^-1 b_k^T``, ``b_k = j_k U``. ``S`` singular (the removal leaves an
   unknown undetermined: a tie point seen in two strips losing a ray) or a row whose ``r'_k`` drops
   below ``MIN_SEPARABLE_REDUNDANCY`` (the partner ray of a single-ray control point, the pixel
   rows of a two-ray tie point with a DTM height) means the remaining measurements can no longer be
   checked: removing this unit rather than that one is a guess;
2. **correlation of the w-tests**: ``rho_ik = -b_k[i] / sqrt(r_i r_k)``; above ``MAX_CORRELATION``
   the two tests cannot be told apart (their w are nearly equal in size).

Either makes the blunder *not separable*: data snooping then removes every measurement of the point
(image measurements in all strips, control coordinates, DTM height) and reports "blunder in one of
its measurements, not separable" instead of blaming one of them.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from scangeo.lsq.observations import ObservationGroup
from scangeo.lsq.statistics import MIN_REDUNDANCY

#: |correlation| of two w-tests above which they are not separable.
MAX_CORRELATION = 0.9
#: A row whose redundancy number drops below this when a unit is removed is left unchecked.
MIN_SEPARABLE_REDUNDANCY = 0.01
#: ``S`` with an eigenvalue below this: the removal leaves an unknown undetermined.
MIN_EIGENVALUE = 1e-8
NOTE = "blunder in one of its measurements, not separable"


@dataclass(frozen=True)
class Verdict:
    """Whether the unit's blunder is separable; if not, the rows of its whole point and why."""

    separable: bool
    rows: np.ndarray            # global rows to remove
    partners: tuple[str, ...]   # "group id component" of the rows it cannot be told apart from
    reason: str = ""


def _label(groups: Sequence[ObservationGroup], slices: Sequence[slice], row: int) -> str:
    for g, sl in zip(groups, slices):
        if sl.start <= row < sl.stop:
            return f"{g.name} {g.ids[row - sl.start]} {g.components[row - sl.start]}"
    return str(row)


def scaled_jacobian(solution) -> sp.csr_matrix:
    """The whitened Jacobian with scaled columns ``J D^-1`` of a solution (rejected rows zero)."""
    s = solution.system
    J = (s.jacobian @ sp.diags(1.0 / s.scale)).tocsr()
    J.eliminate_zeros()
    return J


def _ids_as_str(group: ObservationGroup) -> np.ndarray:
    """``group.ids`` as strings, converted once per ids array (kept on the group beside the array it
    was made from: data snooping asks for every candidate of every round, 154,000 conversions of 77
    groups' ids on the montafon block's comparison, 20 CPU s)."""
    cached = getattr(group, "_ids_str", None)
    if cached is None or cached[0] is not group.ids:
        cached = (group.ids, group.ids.astype(str))
        group._ids_str = cached  # type: ignore[attr-defined]
    return cached[1]


def point_rows(groups: Sequence[ObservationGroup], slices: Sequence[slice], active: np.ndarray,
               point: str) -> np.ndarray:
    """Global active rows of every snooped observation group that belong to ``point``."""
    out = [sl.start + np.flatnonzero((_ids_as_str(g) == point) & active[sl])
           for g, sl in zip(groups, slices) if g.kind == "observation" and g.snooped]
    return np.concatenate(out) if out else np.zeros(0, dtype=np.int64)


def examine(unit_rows: np.ndarray, point: str, Js: sp.csr_matrix, leverage: np.ndarray, active: np.ndarray,
            tested: np.ndarray, apply_inverse: Callable[[np.ndarray], np.ndarray],
            groups: Sequence[ObservationGroup], slices: Sequence[slice]) -> Verdict:
    """Is a blunder in the unit (global ``unit_rows`` of ``point``) separable from the other rows?

    Parameters
    ----------
    Js : (m, n) the whitened Jacobian with scaled columns (``J D^-1``) of every row.
    leverage : (m,) ``h = j N^-1 j^T`` of the current adjustment (NaN where not known).
    active, tested : (m,) rows in the adjustment, rows data snooping tests.
    apply_inverse : ``b -> N^-1 b`` for the current scaled normal matrix (n x k right-hand sides).
    """
    A = Js[unit_rows]
    U = np.asarray(apply_inverse(A.T.toarray())).reshape(Js.shape[1], unit_rows.size)
    AU = A @ U
    S = np.eye(unit_rows.size) - 0.5 * (AU + AU.T)
    others = active & tested & np.isfinite(leverage) & (1.0 - np.nan_to_num(leverage, nan=1.0) >= MIN_REDUNDANCY)
    others[unit_rows] = False
    idx = np.flatnonzero(others)
    B = np.asarray(Js[idx] @ U)
    r_k = 1.0 - leverage[idx]
    r_u = np.clip(1.0 - leverage[unit_rows], MIN_REDUNDANCY, None)
    rho = np.abs(B) / np.sqrt(np.outer(r_k, r_u))
    correlated = idx[rho.max(axis=1, initial=0.0) > MAX_CORRELATION]
    own = point_rows(groups, slices, active, point)
    partners: np.ndarray
    if float(np.linalg.eigvalsh(S)[0]) < MIN_EIGENVALUE:
        partners = np.union1d(np.setdiff1d(own, unit_rows), correlated)
        reason = "removing it leaves an unknown undetermined"
    else:
        r_new = r_k - np.einsum("ij,ij->i", B @ np.linalg.inv(S), B)
        lost = idx[(r_new < MIN_SEPARABLE_REDUNDANCY) & (r_k >= MIN_SEPARABLE_REDUNDANCY)]
        partners = np.union1d(lost, correlated)
        reason = ("removing it leaves another measurement with redundancy 0" if lost.size
                  else f"its w-test correlates with another one above {MAX_CORRELATION}")
    if partners.size == 0:
        return Verdict(True, unit_rows, ())
    labels = tuple(_label(groups, slices, int(k)) for k in partners[:8])
    return Verdict(False, np.union1d(own, unit_rows), labels, reason)




def examine_unit(solution, statistics, update, group_index: int, unit: int) -> Verdict:
    """:func:`examine` for observation unit ``unit`` of group ``group_index`` of an adjustment in the
    state data snooping sees: the full ``solution`` and its ``statistics``, or with ``update`` (a
    :class:`~scangeo.lsq.removal.RemovalUpdate`) the removals since."""
    groups, slices = solution.groups, solution.system.row_slices
    group = groups[group_index]
    sel = group.row_unit == unit
    unit_rows = slices[group_index].start + np.flatnonzero(sel)
    tested = np.concatenate([np.full(g.n_rows, g.kind == "observation" and g.snooped) for g in groups])
    if update is None:
        Js, leverage = scaled_jacobian(solution), statistics.leverages
        active, apply_inverse = np.concatenate(solution.active), solution.factor.solve
    else:
        Js, leverage = update.scaled_jacobian, update.leverages()
        active, apply_inverse = np.concatenate(update.active), update.apply_inverse
    return examine(unit_rows, str(group.ids[sel][0]), Js, leverage, active, tested, apply_inverse, groups, slices)


__all__ = ["MAX_CORRELATION", "MIN_SEPARABLE_REDUNDANCY", "NOTE", "Verdict", "examine", "examine_unit", "point_rows"]
