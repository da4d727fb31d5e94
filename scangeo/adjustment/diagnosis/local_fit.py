"""The criterion of many models that differ from one model in one strip's functions, without refitting the block.

The break selection (:mod:`scangeo.adjustment.diagnosis.patterns`) compares thousands of models, and
each differs from the current one in a single strip ``s``: a break added or moved, or its constant
function made linear. Refitting the whole block for each, as :func:`~.patterns.evaluate` does, costs
a dense least-squares solve over every strip's functions, so the selection grew with about the cube
of the block. A tie row couples only the strips that see its point, so the change is local.

Per channel, with ``A`` the current design (all strips' columns), take the triangle ``R`` of its QR
factorisation ``A = Q R`` once (Householder; ``Q = A R^-1`` is formed only on the rows a probe
needs). Removing strip ``s``'s columns ``S`` leaves the others ``O``; the part of ``range(A)`` they
lose is spanned by ``Q V``, ``V`` an orthonormal basis of ``R^-T E_S`` (orthogonal to every column of
``R`` in ``O``). So the residual without strip ``s`` and its square sum are

    r_O = r + Q V V^T Q^T y,        RSS_O = RSS + |V^T Q^T y|^2,

and the projection on ``range(A_O)`` is ``Q (I - V V^T) Q^T``. A candidate's columns ``Z`` for strip
``s`` (non-zero only in the rows ``R`` that see strip ``s``) bring

    RSS = RSS_O - g^T H^-1 g,   g = Z_R^T r_O,R,   H = Z_R^T Z_R - |U_R^T Z_R|^2,   U_R = (Q (I - V V^T))_R,

and the rank grows by the columns of ``Z``. So a candidate costs the rows of its strip, and the
block's size enters once per current model (one QR factorisation per channel).

Everything is computed from the QR factors, never from the normal equations ``A^T A``: their
rounding alone perturbs ``(A^T A)^-1`` by ``eps cond(A)^2`` of itself, and a nearly unobservable
common shift of the strips makes ``cond(A)`` about 1e4 on the test block, where a criterion from
the normal equations differs between BLAS kernels by 1e-5. Householder's ``R`` is exact for a
change of ``A`` of ``eps``, which moves these projections by about ``eps cond(A)``; the fit itself
comes from the corrected semi-normal equations, as accurate for ``cond(A) < eps^-1/2``, which
:data:`CONDITION` ensures. The result is :func:`~.patterns.evaluate`'s to
about 1e-9 of the criterion on the test blocks, on every kernel, when both the current design and
``H`` are well conditioned. Where they are not, the rank that ``numpy.linalg.lstsq`` would find is in
doubt, and :meth:`StripProbe.bic` returns None: the caller fits that model with
:func:`~.patterns.evaluate`. The callers also refit the best candidates exactly before choosing
(:data:`MARGIN`), so the choices are :func:`~.patterns.evaluate`'s.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.sparse as sp

#: the callers refit exactly every candidate whose approximate criterion is within this of the least
MARGIN = 1e-3
#: the least ratio of the smallest to the largest singular value of the current design ``A`` for the
#: update to be trusted (the rank not in doubt: far from the 1e-9 under which ``lstsq`` drops a column)
CONDITION = 1e-6
#: the least ratio of the smallest eigenvalue of ``H`` to its columns' largest square sum for a
#: candidate's columns to count in the rank without refitting it
TRUST = 1e-9


def strip_nodes(n_lines: int, breaks) -> np.ndarray:
    """A strip's nodes: its first line, its breaks in order, its last line."""
    return np.concatenate([[0.0], np.sort(np.asarray(breaks, float)), [float(n_lines - 1)]])


class BlockIndex:
    """Which terms and rows belong to which strip and channel (built once per selection)."""

    def __init__(self, data) -> None:
        self.data = data
        order = np.argsort(data.term_strip, kind="stable")
        bounds = np.searchsorted(data.term_strip[order], np.arange(len(data.strips) + 1))
        #: per strip, its terms' indices
        self.terms = [order[bounds[s]:bounds[s + 1]] for s in range(len(data.strips))]
        #: per strip, its terms' lines (for the least rows between breaks)
        self.lines = [data.term_line[t] for t in self.terms]
        #: per channel, its rows; and every row's position among its channel's rows
        self.rows = [np.flatnonzero(data.channel == c) for c in range(len(data.channels))]
        self.position = np.zeros(data.n, int)
        for rows in self.rows:
            self.position[rows] = np.arange(rows.size)

    def feasible(self, s: int, breaks, line: float, min_gap: float, min_rows: int) -> bool:
        """Whether a break at ``line`` keeps the least gap and the least terms between breaks."""
        nd = strip_nodes(self.data.n_lines[s], tuple(breaks) + (line,))
        if np.min(np.diff(nd)) < min_gap:
            return False
        return bool(np.all(np.histogram(self.lines[s], bins=nd)[0] >= min_rows))

    def strip_terms(self, s: int, breaks, degree: int, constant: bool, with_constant: bool = True
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
        """Strip ``s``'s entries of the design (row, column within the strip, value) and its column count.

        The columns span what :func:`~.patterns.design`'s do, in another basis: first the constant
        function of every component, then the hat functions of the nodes but the first (the hats sum to
        one), then degree 2's bubbles. ``with_constant=False`` leaves the constants out.
        """
        data, sel = self.data, self.terms[s]
        nk = len(data.components)
        row, comp, w = data.term_row[sel], data.term_component[sel], data.term_weight[sel]
        rows, cols, vals = ([row], [comp], [w]) if with_constant else ([], [], [])
        first = nk if with_constant else 0
        if constant:
            return row, comp, w, nk
        nd = strip_nodes(data.n_lines[s], breaks)
        line = np.clip(data.term_line[sel], nd[0], nd[-1])
        seg = np.clip(np.searchsorted(nd, line, side="right") - 1, 0, nd.size - 2)
        frac = (line - nd[seg]) / (nd[seg + 1] - nd[seg])
        base = first + comp * (nd.size - 1) - 1  # node j >= 1 of component k
        low = seg > 0
        rows += [row[low], row]
        cols += [(base + seg)[low], base + seg + 1]
        vals += [(w * (1.0 - frac))[low], w * frac]
        ncol = first + nk * (nd.size - 1)
        if degree >= 2:
            rows.append(row)
            cols.append(ncol + comp * (nd.size - 1) + seg)
            vals.append(w * 4.0 * frac * (1.0 - frac))
            ncol += nk * (nd.size - 1)
        return np.concatenate(rows), np.concatenate(cols), np.concatenate(vals), ncol


@dataclass
class _Channel:
    """The current model's fit of one channel."""

    A: sp.csr_matrix  # rows of the channel, used columns
    R: np.ndarray  # A = Q R
    Rinv: np.ndarray  # R^-1
    c: np.ndarray  # Q^T y (= R x)
    r: np.ndarray  # the residual y - A x
    rss: float  # r^T r
    n_used: int
    owner: np.ndarray  # strip of every used column
    constant: np.ndarray  # whether a used column is a strip's constant function
    good: bool  # A well conditioned


class CurrentFit:
    """The current model (``breaks``, ``constant``) fitted channel by channel, for :class:`StripProbe`."""

    def __init__(self, index: BlockIndex, breaks, degree: int, constant) -> None:
        data = index.data
        self.index, self.degree = index, degree
        self.breaks = [tuple(float(v) for v in b) for b in breaks]
        self.constant = frozenset(constant)
        rows, cols, vals, owner, const = [], [], [], [], []
        offset = 0
        for s in range(len(data.strips)):
            r, col_s, v, n = index.strip_terms(s, self.breaks[s], degree, s in self.constant)
            rows.append(r)
            cols.append(col_s + offset)
            vals.append(v)
            owner.append(np.full(n, s))
            const.append(np.arange(n) < len(data.components))
            offset += n
        row, col, val = np.concatenate(rows), np.concatenate(cols), np.concatenate(vals)
        owners, consts = np.concatenate(owner), np.concatenate(const)
        self.channels: list[_Channel | None] = []
        for c, crow in enumerate(index.rows):
            if crow.size == 0:
                self.channels.append(None)
                continue
            keep = data.channel[row] == c
            A = sp.csc_matrix((val[keep], (index.position[row[keep]], col[keep])), shape=(crow.size, offset))
            A.sum_duplicates()
            A.eliminate_zeros()
            used = np.flatnonzero(np.diff(A.indptr) > 0)
            y = data.value[crow]
            A = A[:, used].tocsr()
            R, Rinv, x = np.zeros((0, 0)), np.zeros((0, 0)), np.zeros(used.size)
            good = 0 < used.size <= crow.size
            if good:
                R = scipy.linalg.qr(A.toarray(), mode="r", check_finite=False)[0][: used.size]
                sv = np.linalg.svd(R, compute_uv=False)
                good = bool(sv[-1] > CONDITION * sv[0])
            r = y.copy()
            if good:
                Rinv = scipy.linalg.solve_triangular(R, np.eye(used.size), check_finite=False)
                # corrected semi-normal equations: one step of refinement makes them as accurate as
                # solving with Q for cond(A) < eps^-1/2, which CONDITION ensures
                for _ in range(2):
                    x += Rinv @ (Rinv.T @ (A.T @ r))
                    r = y - A @ x
            self.channels.append(_Channel(A, R, Rinv, R @ x if good else np.zeros(0), r, float(r @ r), used.size,
                                          owners[used], consts[used], good))

    def bic(self, rho: dict[str, float] | None, n_breaks: int) -> float | None:
        """The current model's BIC as :func:`~.patterns.evaluate` computes it; None when a channel's
        design is not well conditioned (its rank in doubt)."""
        if any(ch is not None and not ch.good for ch in self.channels):
            return None
        parts = [(0.0, 0) if ch is None else (ch.rss, ch.n_used) for ch in self.channels]
        return _criterion(self.index, parts, rho, n_breaks)[0]


#: the least residual degrees of freedom a model with breaks must leave in every channel: below it the
#: channel's variance estimate ``RSS / n`` collapses (at none left the breaks fit the rows exactly, RSS
#: about 1e-25, and the deviance ``n log(RSS / n)`` runs to minus hundreds per row), and the criterion would
#: buy any break that saturates a channel (the 2-strip test block of 200 lines, 11 tie points: breaks on
#: both strips "beat" none by 1461). Such a model is not scored (its criterion is infinite).
MIN_REDUNDANCY = 5


def saturated(n: int, rank: int, n_breaks: int) -> bool:
    """Whether a model with ``n_breaks`` breaks leaves a channel of ``n`` rows and ``rank`` unknowns fewer than
    :data:`MIN_REDUNDANCY` residual degrees of freedom (a model without breaks, the reference, is always scored)."""
    return n_breaks > 0 and n - rank < MIN_REDUNDANCY


def _criterion(index: BlockIndex, parts, rho: dict[str, float] | None, n_breaks: int) -> tuple[float, float]:
    """(BIC, deviance) from every channel's residual sum of squares and rank (:func:`~.patterns.evaluate`);
    infinite for a model that saturates a channel (:func:`saturated`)."""
    data = index.data
    deviance, k, n_total = 0.0, 0, 0.0
    for c, name in enumerate(data.channels):
        n = index.rows[c].size
        if n == 0:
            continue
        rss, rank = parts[c]
        if saturated(n, rank, n_breaks):
            return math.inf, -math.inf
        p = rho.get(name, 0.0) if rho is not None else 0.0
        neff = n * (1.0 - p) / (1.0 + p)
        deviance += neff * np.log(max(rss, 1e-300) / n)
        k += rank
        n_total += neff
    k += n_breaks
    return deviance + k * np.log(max(n_total, 2.0)), deviance


@dataclass
class _Local:
    """What a candidate of strip ``s`` needs of one channel: the rows ``R`` that see the strip, the
    orthonormal basis of the other columns' span on them (``U_R``, module docstring), the residual
    without the strip's non-constant functions on them (``r_R``) and its square sum over the channel
    (``rss``); ``rank``: the columns left."""

    R: np.ndarray
    U_R: np.ndarray
    r_R: np.ndarray
    rss: float
    rank: int


class StripProbe:
    """Models that differ from a :class:`CurrentFit` in strip ``s`` only (module docstring)."""

    def __init__(self, fit: CurrentFit, s: int) -> None:
        self.fit, self.s = fit, s
        data = fit.index.data
        terms = fit.index.terms[s]
        #: per channel: None (no rows), (RSS, rank) (the strip not seen in it) or the local parts
        self.parts: list[_Local | tuple[float, int] | None] = []
        #: False when a channel's current design is not well conditioned (every candidate refitted)
        self.trusted = all(ch is None or ch.good for ch in fit.channels)
        for c, ch in enumerate(fit.channels):
            if ch is None or not ch.good:
                self.parts.append(None)
                continue
            mine = data.channel[data.term_row[terms]] == c
            R = np.unique(fit.index.position[data.term_row[terms[mine]]])
            S = np.flatnonzero((ch.owner == s) & ~ch.constant)  # the constants stay
            if R.size == 0:
                # the strip is not seen in this channel: no candidate changes it
                self.parts.append((ch.rss, ch.n_used))
                continue
            # V: the part of range(R) that strip s's columns S add to the others' (orthogonal to R[:, O])
            V = np.linalg.qr(ch.Rinv[S].T)[0]  # an orthonormal basis of R^-T E_S
            cV = V.T @ ch.c
            Q_R = np.asarray(ch.A[R] @ ch.Rinv)  # the rows R of Q = A R^-1
            QV_R = Q_R @ V
            self.parts.append(_Local(R, Q_R - QV_R @ V.T, ch.r[R] + QV_R @ cV, ch.rss + float(cV @ cV),
                                     ch.n_used - S.size))

    def rss_rank(self, breaks_s, constant_s: bool) -> list[tuple[float, int]] | None:
        """Per channel, the residual sum of squares and rank with strip ``s`` given these functions;
        None when the update is not to be trusted (module docstring)."""
        if not self.trusted:
            return None
        index = self.fit.index
        data = index.data
        if constant_s:
            row, col, val, ncol = np.zeros(0, int), np.zeros(0, int), np.zeros(0), 0
        else:
            row, col, val, ncol = index.strip_terms(self.s, breaks_s, self.fit.degree, False, with_constant=False)
        chan = data.channel[row]
        out: list[tuple[float, int]] = []
        for c, part in enumerate(self.parts):
            if part is None:
                out.append((0.0, 0))
                continue
            if isinstance(part, tuple):
                out.append(part)
                continue
            keep = chan == c
            local = np.searchsorted(part.R, index.position[row[keep]])
            Z = np.zeros((part.R.size, ncol))
            np.add.at(Z, (local, col[keep]), val[keep])
            Z = Z[:, np.any(Z != 0.0, axis=0)]
            if Z.shape[1] == 0:
                out.append((part.rss, part.rank))
                continue
            UZ = part.U_R.T @ Z
            ZZ = Z.T @ Z
            H = ZZ - UZ.T @ UZ
            if np.linalg.eigvalsh(H)[0] <= TRUST * float(np.max(np.diag(ZZ))):
                return None
            g = Z.T @ part.r_R
            z = np.linalg.solve(H, g)
            # RSS_O - 2 g^T z + z^T H z: the criterion's quadratic at the z found, so a slightly wrong z
            # errs in second order (RSS_O - g^T H^-1 g at the exact one)
            rss = part.rss - 2.0 * (g @ z) + z @ H @ z
            out.append((float(rss), part.rank + Z.shape[1]))
        return out

    def bic(self, breaks_s, constant_s: bool, rho: dict[str, float] | None, n_breaks: int
            ) -> tuple[float, float] | None:
        """(BIC, deviance) of the model with strip ``s`` given these functions, as
        :func:`~.patterns.evaluate` computes them; ``n_breaks``: the model's breaks over all strips."""
        parts = self.rss_rank(breaks_s, constant_s)
        if parts is None:
            return None
        return _criterion(self.fit.index, parts, rho, n_breaks)


__all__ = ["CONDITION", "MARGIN", "TRUST", "BlockIndex", "CurrentFit", "StripProbe", "strip_nodes"]
