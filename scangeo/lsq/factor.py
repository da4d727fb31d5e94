"""Sparse LDL^T / Cholesky factorisation of symmetric positive (semi)definite normal matrices.

Two backends, chosen by measurement (docs/performance.md, tests/benchmarks/solver.py):

- ``cholmod``: CHOLMOD's supernodal Cholesky with AMD ordering (scikit-sparse, optional dependency;
  the fastest by a factor 1.5-5 on our normal matrices);
- ``superlu``: scipy's SuperLU in symmetric mode (minimum-degree ordering on A^T + A, diagonal
  pivots only), which then computes ``A = L D L^T``. Always available; scipy's default (COLAMD,
  partial pivoting) is 10-100 times slower on these matrices and is not used.

Both give pivots per unknown (for detecting rank defects) and an explicit ``(perm, L, d)`` for
selected inversion.
"""
from __future__ import annotations

import logging
from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from scangeo.errors import AdjustmentError

log = logging.getLogger(__name__)

#: Diagonal shift used only to locate the zero pivots of an exactly singular (unit-diagonal) matrix.
_SHIFT = 1e-13

try:  # optional: CHOLMOD through scikit-sparse
    from sksparse.cholmod import CholmodNotPositiveDefiniteError
    from sksparse.cholmod import analyze as _cholmod_analyze
except ImportError:  # pragma: no cover - depends on the machine
    _cholmod_analyze = None


class NotPositiveDefinite(AdjustmentError):
    """The matrix is not positive definite.

    ``pivots`` are LDL^T pivots of every unknown (original numbering) from a factorisation that went
    through (without pivoting, or of a slightly shifted matrix): the small or negative ones name the
    unknowns to regularise.
    """

    def __init__(self, message: str, pivots: np.ndarray) -> None:
        super().__init__(message)
        self.pivots = pivots


@dataclass
class LDL:
    """``A[perm][:, perm] = (I + L) diag(d) (I + L)^T`` with ``L`` strictly lower triangular (CSC)."""

    perm: np.ndarray
    L: sp.csc_matrix
    d: np.ndarray


class Factor(ABC):
    """A factorisation of a symmetric matrix ``A`` (n x n)."""

    backend: str

    @abstractmethod
    def solve(self, b: np.ndarray) -> np.ndarray:
        """``A^-1 b``."""

    @abstractmethod
    def pivots(self) -> np.ndarray:
        """The LDL^T pivot of every unknown, in the original numbering (n,)."""

    @abstractmethod
    def ldl(self) -> LDL:
        """The explicit factor, for selected inversion."""


def available_backends() -> list[str]:
    """The backends usable on this machine, fastest first."""
    return (["cholmod"] if _cholmod_analyze is not None else []) + ["superlu"]


def _strict_lower(L: sp.spmatrix, unit: bool = False) -> sp.csc_matrix:
    """The entries below the diagonal of a lower triangular ``L`` (CSC), without the coordinate copies
    of ``sp.tril`` (the factor is the largest array of an adjustment). ``unit``: of ``L`` scaled to a
    unit diagonal (``L diag(L)^-1``), its explicit zeros dropped."""
    L = sp.csc_matrix(L)
    L.sort_indices()
    n = L.shape[1]
    column = np.repeat(np.arange(n, dtype=L.indices.dtype), np.diff(L.indptr))
    keep = L.indices > column
    if unit:
        keep &= L.data != 0
    column = column[keep]
    data = L.data[keep] / L.diagonal()[column] if unit else L.data[keep]
    indptr = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(np.bincount(column, minlength=n), out=indptr[1:])
    del column
    return sp.csc_matrix((data, L.indices[keep], indptr), shape=L.shape)


class CholmodFactor(Factor):
    backend = "cholmod"

    def __init__(self, factor) -> None:
        self._f = factor

    def solve(self, b):
        return self._f(b)

    def pivots(self):
        d = np.empty(self._f.D().size)
        d[self._f.P()] = self._f.D()
        return d

    def ldl(self):
        # From the supernodal L L^T as it is: L_D() converts (a copy of) the factor to a simplicial L D L^T
        # and peaked at five times the memory of the result (96 strips of block24: 0.8 GB more). The same
        # numbers: d = diag(L)^2, L / diag(L) by column, and the explicit zeros of the supernodes dropped
        # as the conversion drops them (bit-identical on block24).
        L = self._f.L()
        root = L.diagonal()
        strict = _strict_lower(L, unit=True)
        del L
        return LDL(np.asarray(self._f.P(), dtype=np.int64), strict, root * root)


class SuperLUFactor(Factor):
    backend = "superlu"

    def __init__(self, lu) -> None:
        self._lu = lu
        if not np.array_equal(lu.perm_r, lu.perm_c):
            raise AdjustmentError("SuperLU chose off-diagonal pivots on a symmetric matrix")
        self._q = lu.perm_c  # position of each original index

    def solve(self, b):
        return self._lu.solve(b)

    def pivots(self):
        return self._lu.U.diagonal()[self._q]

    def ldl(self):
        return LDL(np.argsort(self._q).astype(np.int64), _strict_lower(self._lu.L), self._lu.U.diagonal().copy())


def _embed(A: sp.csc_matrix, indptr: np.ndarray, indices: np.ndarray) -> sp.csc_matrix | None:
    """``A`` on the larger pattern ``(indptr, indices)`` (explicit zeros where ``A`` has no entry), or
    None when ``A`` has an entry outside it. Data snooping's removals only thin the normal matrix's
    pattern: the symbolic analysis (the ordering, a large part of a factorisation) is kept."""
    n = A.shape[1]
    if indptr.size != n + 1 or A.nnz > indices.size:
        return None
    old = np.repeat(np.arange(n, dtype=np.int64), np.diff(indptr)) * A.shape[0] + indices
    new = np.repeat(np.arange(n, dtype=np.int64), np.diff(A.indptr)) * A.shape[0] + A.indices
    at = np.searchsorted(old, new)
    if np.any(at >= old.size) or not np.array_equal(old[np.minimum(at, old.size - 1)], new):
        return None
    data = np.zeros(indices.size)
    data[at] = A.data
    return sp.csc_matrix((data, indices.copy(), indptr.copy()), shape=A.shape)


class Factorizer:
    """Factorises a sequence of matrices of one sparsity pattern, reusing the symbolic analysis."""

    def __init__(self, backend: str = "auto") -> None:
        if backend == "auto":
            backend = available_backends()[0]
        if backend not in ("cholmod", "superlu"):
            raise AdjustmentError(f"unknown solver backend {backend!r} (expected auto, cholmod or superlu)")
        if backend not in available_backends():
            raise AdjustmentError("solver backend 'cholmod' needs scikit-sparse, which is not installed")
        self.backend = backend
        self._symbolic = None
        self._pattern: tuple[np.ndarray, np.ndarray] | None = None

    def factorize(self, A: sp.spmatrix) -> Factor:
        """Factorise the symmetric matrix ``A`` (both triangles stored).

        Raises :class:`NotPositiveDefinite` when a pivot is not positive and the backend stops there.
        """
        A = sp.csc_matrix(A)
        A.sort_indices()
        if self.backend == "cholmod":
            return self._cholmod(A)
        return self._superlu(A)

    def _cholmod(self, A: sp.csc_matrix) -> Factor:
        same = (self._pattern is not None and self._pattern[0].shape == A.indptr.shape
                and np.array_equal(self._pattern[0], A.indptr) and np.array_equal(self._pattern[1], A.indices))
        if not same and self._pattern is not None:
            embedded = _embed(A, *self._pattern)   # rows removed: a pattern inside the analysed one
            if embedded is not None:
                A, same = embedded, True
        if not same:
            self._symbolic = _cholmod_analyze(A, mode="supernodal", ordering_method="amd")
            self._pattern = (A.indptr.copy(), A.indices.copy())
        try:
            assert self._symbolic is not None
            return CholmodFactor(self._symbolic.cholesky(A))
        except CholmodNotPositiveDefiniteError:
            pass
        # LDL^T without pivoting goes through indefinite matrices and shows every bad pivot
        simplicial = _cholmod_analyze(A, mode="simplicial", ordering_method="amd")
        try:
            pivots = CholmodFactor(simplicial.cholesky(A)).pivots()
        except CholmodNotPositiveDefiniteError:  # an exactly zero pivot: look at a shifted matrix
            pivots = CholmodFactor(simplicial.cholesky(A, beta=_SHIFT)).pivots()
        raise NotPositiveDefinite("normal matrix not positive definite", pivots)

    def _superlu(self, A: sp.csc_matrix) -> Factor:
        try:
            lu = spla.splu(A, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                           options=dict(SymmetricMode=True))
        except RuntimeError as exc:  # "Factor is exactly singular": look at a shifted matrix
            shifted = spla.splu(A + _SHIFT * sp.eye(A.shape[0], format="csc"), permc_spec="MMD_AT_PLUS_A",
                                diag_pivot_thresh=0.0, options=dict(SymmetricMode=True))
            raise NotPositiveDefinite(f"normal matrix singular ({exc})", SuperLUFactor(shifted).pivots()) from None
        if not np.array_equal(lu.perm_r, lu.perm_c):
            # a zero pivot on the diagonal (e.g. an unknown whose last observation data snooping removed):
            # SuperLU pivots off the diagonal; report the pivots of a shifted matrix so the solver regularises
            shifted = spla.splu(A + _SHIFT * sp.eye(A.shape[0], format="csc"), permc_spec="MMD_AT_PLUS_A",
                                diag_pivot_thresh=0.0, options=dict(SymmetricMode=True))
            raise NotPositiveDefinite("normal matrix singular (SuperLU pivoted off the diagonal)",
                                      SuperLUFactor(shifted).pivots())
        return SuperLUFactor(lu)
