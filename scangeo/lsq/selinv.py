"""Selected inversion: the entries of ``A^-1`` on the pattern of the factor (Takahashi recursion).

For ``A[p][:, p] = (I + L) D (I + L)^T`` the inverse ``Z`` of the permuted matrix satisfies, column
by column from the last one,

    Z[i, j] = - sum_{k > j, L[k, j] != 0} L[k, j] Z[i, k]        (i > j, L[i, j] != 0)
    Z[j, j] = 1 / d[j] - sum_{k > j, L[k, j] != 0} L[k, j] Z[k, j]

and needs only entries of ``Z`` inside the pattern of ``L`` (the rows of a column of ``L`` form a
clique of the filled graph). Every entry of ``A^-1`` on the pattern of ``A`` is therefore available:
the variances and covariances of unknowns that share an observation, and the redundancy numbers.
Cost: about that of the numeric factorisation; memory: one more array like ``L``. Never a dense inverse.
"""
from __future__ import annotations

import numba
import numpy as np

from scangeo.lsq.factor import LDL
from scangeo.lsq.partial_solve import PartialSolver


@numba.njit(cache=True)
def _takahashi(n, Lp, Li, Lx, d, Zx, Zd):  # pragma: no cover - compiled
    s = np.zeros(n)
    for j in range(n - 1, -1, -1):
        a0, a1 = Lp[j], Lp[j + 1]
        m = a1 - a0
        for a in range(m):
            s[a] = 0.0
        for b in range(m):
            k = Li[a0 + b]
            lb = Lx[a0 + b]
            s[b] += lb * Zd[k]
            # walk column k of L (rows > k) in step with rows[b+1:] of column j
            p = Lp[k]
            pend = Lp[k + 1]
            for a in range(b + 1, m):
                i = Li[a0 + a]
                while p < pend and Li[p] < i:
                    p += 1
                z = Zx[p]  # Z[i, k], i > k: in column k (clique property guarantees Li[p] == i)
                s[a] += lb * z
                s[b] += Lx[a0 + a] * z
        diag = 1.0 / d[j]
        for a in range(m):
            Zx[a0 + a] = -s[a]
            diag -= Lx[a0 + a] * (-s[a])
        Zd[j] = diag


@numba.njit(cache=True)
def _lookup(Lp, Li, Zx, Zd, i, k):  # pragma: no cover - compiled
    if i == k:
        return Zd[i]
    if i < k:
        i, k = k, i
    lo, hi = Lp[k], Lp[k + 1]
    while lo < hi:
        mid = (lo + hi) // 2
        if Li[mid] < i:
            lo = mid + 1
        else:
            hi = mid
    if lo < Lp[k + 1] and Li[lo] == i:
        return Zx[lo]
    return np.nan


@numba.njit(cache=True)
def _quadratic_forms(Lp, Li, Zx, Zd, pos, Jp, Jj, Jx, out):  # pragma: no cover - compiled
    # out[r] = J[r, :] Z J[r, :]^T for each row r of the CSR matrix J (columns in original numbering)
    for r in range(Jp.size - 1):
        acc = 0.0
        for a in range(Jp[r], Jp[r + 1]):
            ca = pos[Jj[a]]
            acc += Jx[a] * Jx[a] * Zd[ca]
            for b in range(a + 1, Jp[r + 1]):
                acc += 2.0 * Jx[a] * Jx[b] * _lookup(Lp, Li, Zx, Zd, ca, pos[Jj[b]])
        out[r] = acc


@numba.njit(cache=True)
def _entries(Lp, Li, Zx, Zd, pos, rows, cols, out):  # pragma: no cover - compiled
    for e in range(rows.size):
        out[e] = _lookup(Lp, Li, Zx, Zd, pos[rows[e]], pos[cols[e]])


class SparseInverse:
    """Entries of ``A^-1`` on the pattern of a factor, looked up in the original numbering.

    Entries outside the pattern are returned as NaN (they are not computed).
    """

    def __init__(self, ldl: LDL) -> None:
        L = ldl.L
        n = L.shape[0]
        self._Lp = L.indptr.astype(np.int64)
        self._Li = L.indices.astype(np.int64)
        self._Lx = np.ascontiguousarray(L.data, dtype=float)
        self._d = np.ascontiguousarray(ldl.d, dtype=float)
        self._Zx = np.empty(L.nnz)
        self._Zd = np.empty(n)
        _takahashi(n, self._Lp, self._Li, self._Lx, self._d, self._Zx, self._Zd)
        self._pos = np.empty(n, dtype=np.int64)
        self._pos[ldl.perm] = np.arange(n)

    def partial_solver(self) -> PartialSolver:
        """Solves with the same factor restricted to the entries that reach the result (the arrays
        are shared): :class:`~scangeo.lsq.partial_solve.PartialSolver`."""
        return PartialSolver(self._Lp, self._Li, self._Lx, self._d, self._pos)

    def diagonal(self) -> np.ndarray:
        """``diag(A^-1)`` in the original numbering."""
        return self._Zd[self._pos]

    def entries(self, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """``A^-1[rows[e], cols[e]]`` for each e (NaN outside the pattern)."""
        rows = np.ascontiguousarray(rows, dtype=np.int64)
        cols = np.ascontiguousarray(cols, dtype=np.int64)
        out = np.empty(rows.size)
        _entries(self._Lp, self._Li, self._Zx, self._Zd, self._pos, rows.ravel(), cols.ravel(), out)
        return out.reshape(rows.shape)

    def block(self, columns: np.ndarray) -> np.ndarray:
        """The square block ``A^-1[columns][:, columns]`` (NaN where outside the pattern)."""
        c = np.asarray(columns, dtype=np.int64)
        rr, cc = np.meshgrid(c, c, indexing="ij")
        return self.entries(rr, cc)

    def quadratic_forms(self, J) -> np.ndarray:
        """``diag(J A^-1 J^T)`` for a CSR matrix ``J`` whose rows couple only unknowns that share
        observations (so every needed entry is on the pattern)."""
        J = J.tocsr()
        out = np.empty(J.shape[0])
        _quadratic_forms(self._Lp, self._Li, self._Zx, self._Zd, self._pos,
                         J.indptr.astype(np.int64), J.indices.astype(np.int64), J.data.astype(float), out)
        return out
