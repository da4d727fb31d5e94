"""Solves with a sparse factor for a few right-hand sides of local support, and a few rows of the result.

For ``A[p][:, p] = (I + L) D (I + L)^T`` the solution of ``A x = b`` is

    y = (I + L)^-1 b[p],   z = D^-1 y,   x[p] = (I + L)^-T z.

When ``b`` is non-zero only on a few unknowns ``S`` (permuted numbering), ``y`` and ``z`` are non-zero
only on their ancestors in the elimination tree (``parent[j]`` is the first row of column ``j`` of
``L``): the forward solve visits those columns only (Gilbert and Peierls). When only the entries
``T`` of ``x`` are wanted, the backward solve needs ``x`` only on the ancestors of ``T`` (row ``j`` of
``(I + L)^T`` holds column ``j`` of ``L``, whose rows are ancestors of ``j``). Both are exact: the
same arithmetic as a full solve, restricted to the entries that reach the result.

With a fill-reducing ordering of a block of strips the ancestors of a strip's unknowns are the strip
and the separators above it: the work per right-hand side stays about that of one strip's columns of
``L`` as the block grows (docs/adjustment.md, Reliability), not ``nnz(L)`` as a full solve.
The compiled kernel releases the GIL, so threads run solves side by side.
"""
from __future__ import annotations

import numba
import numpy as np


def elimination_parents(Lp: np.ndarray, Li: np.ndarray) -> np.ndarray:
    """``parent[j]``: the first row below the diagonal of column ``j`` of the strictly lower ``L``
    (CSC, sorted rows), -1 for a root."""
    n = Lp.size - 1
    parent = np.full(n, -1, dtype=np.int64)
    has = np.diff(Lp) > 0
    parent[has] = Li[Lp[:-1][has]]
    return parent


@numba.njit(cache=True, nogil=True)
def _ancestors(parent, start, mark, stamp):  # pragma: no cover - compiled
    """Every ancestor of the nodes ``start`` (themselves included), ascending; ``mark[j] == stamp``
    marks the visited."""
    count = 0
    out = np.empty(parent.size, dtype=np.int64)
    for s in start:
        j = s
        while j >= 0 and mark[j] != stamp:
            mark[j] = stamp
            out[count] = j
            count += 1
            j = parent[j]
    return np.sort(out[:count])


@numba.njit(cache=True, nogil=True)
def _solve(Lp, Li, Lx, d, parent, support, B, targets):  # pragma: no cover - compiled
    n, m = d.size, B.shape[1]
    mark = np.zeros(n, dtype=np.int8)
    forward = _ancestors(parent, support, mark, 1)
    backward = _ancestors(parent, targets, mark, 2)
    nodes = np.unique(np.concatenate((forward, backward)))
    where = np.full(n, -1, dtype=np.int64)
    for a in range(nodes.size):
        where[nodes[a]] = a
    Y = np.zeros((nodes.size, m))
    for a in range(support.size):
        for c in range(m):
            Y[where[support[a]], c] += B[a, c]
    for j in forward:                                   # (I + L) y = b, ascending
        wj = where[j]
        for p in range(Lp[j], Lp[j + 1]):
            wi = where[Li[p]]
            lx = Lx[p]
            for c in range(m):
                Y[wi, c] -= lx * Y[wj, c]
        for c in range(m):
            Y[wj, c] /= d[j]
    for b in range(backward.size - 1, -1, -1):          # (I + L)^T x = z, descending
        wj = where[backward[b]]
        j = backward[b]
        for p in range(Lp[j], Lp[j + 1]):
            wi = where[Li[p]]
            lx = Lx[p]
            for c in range(m):
                Y[wj, c] -= lx * Y[wi, c]
    X = np.empty((targets.size, m))
    for a in range(targets.size):
        for c in range(m):
            X[a, c] = Y[where[targets[a]], c]
    return X


class PartialSolver:
    """``A^-1 B`` at a few rows, for ``B`` with a few non-zero rows, from ``A``'s explicit factor.

    Parameters
    ----------
    Lp, Li, Lx : ``L`` strictly lower (CSC arrays, sorted rows) and ``d`` with
        ``A[perm][:, perm] = (I + L) diag(d) (I + L)^T``; ``pos[perm] = arange(n)`` (the position of
        each original index). The arrays are shared, not copied.
    """

    def __init__(self, Lp: np.ndarray, Li: np.ndarray, Lx: np.ndarray, d: np.ndarray, pos: np.ndarray) -> None:
        self._Lp = np.ascontiguousarray(Lp, dtype=np.int64)
        self._Li = np.ascontiguousarray(Li, dtype=np.int64)
        self._Lx = np.ascontiguousarray(Lx, dtype=float)
        self._d = np.ascontiguousarray(d, dtype=float)
        self._pos = np.ascontiguousarray(pos, dtype=np.int64)
        self._parent = elimination_parents(self._Lp, self._Li)
        self.n = self._d.size

    @classmethod
    def from_ldl(cls, perm: np.ndarray, L, d: np.ndarray) -> PartialSolver:
        """From ``A[perm][:, perm] = (I + L) diag(d) (I + L)^T`` (``L`` strictly lower, CSC, sorted)."""
        pos = np.empty(d.size, dtype=np.int64)
        pos[np.asarray(perm, dtype=np.int64)] = np.arange(d.size)
        return cls(L.indptr, L.indices, L.data, d, pos)

    def solve(self, rows: np.ndarray, B: np.ndarray, targets: np.ndarray) -> np.ndarray:
        """``(A^-1 b)[targets]`` for the ``m`` columns ``b`` of a matrix that is zero but on ``rows``,
        where it is ``B`` (``rows.size x m``); returns ``targets.size x m``. Original numbering;
        ``rows`` and ``targets`` without repeats."""
        B = np.asarray(B, dtype=float)
        B = np.ascontiguousarray(B[:, None] if B.ndim == 1 else B)
        if B.shape[0] != np.size(rows):
            raise ValueError(f"{B.shape[0]} rows of right-hand sides for {np.size(rows)} unknowns")
        if B.shape[0] == 0 or np.size(targets) == 0:   # nothing to solve (e.g. a probe of fixed unknowns)
            return np.zeros((np.size(targets), B.shape[1]))
        return _solve(self._Lp, self._Li, self._Lx, self._d, self._parent,
                      self._pos[np.asarray(rows, dtype=np.int64)], B,
                      self._pos[np.asarray(targets, dtype=np.int64)])


__all__ = ["PartialSolver", "elimination_parents"]
