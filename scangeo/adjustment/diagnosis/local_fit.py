"""The criterion of many models that differ from one model in one strip's functions, without refitting the block.

The break selection (:mod:`scangeo.adjustment.diagnosis.patterns`) compares thousands of models, and
each differs from the current one in a single strip ``s``: a break added or moved, or its constant
function made linear. Refitting the whole block for each, as :func:`~.patterns.evaluate` does, costs
a dense least-squares solve over every strip's functions, so the selection grew with about the cube
of the block. A tie row couples only the strips that see its point, so the change is local:

Per channel, with ``A`` the current design (all strips' columns) and ``N = A^T A`` nonsingular, take
``P = N^-1`` once. Removing strip ``s``'s columns ``S`` leaves the others ``O`` with (block inverse)

    (N_OO)^-1 = P_OO - P_OS P_SS^-1 P_SO,   x_O = x_O - P_OS P_SS^-1 x_S,   RSS_O = RSS + x_S^T P_SS^-1 x_S,

and a candidate's columns ``Z`` for strip ``s`` (non-zero only in the rows ``R`` that see strip ``s``)
bring

    RSS = RSS_O - g^T H^-1 g,   g = Z_R^T r_O,R,   H = Z_R^T Z_R - F^T (N_OO)^-1_CC F,   F = A_RC^T Z_R,

where ``C`` are the other strips' columns in the rows ``R`` (the neighbours') and ``r_O`` the residual
without strip ``s``; the rank grows by the columns of ``Z``. So a candidate costs the rows of its
strip, and the block's size enters once per current model (one inverse of ``N`` per channel).

The result is the same criterion as :func:`~.patterns.evaluate`'s to rounding (about 1e-9 of it on
the test blocks), when both the current design and ``H`` are well conditioned. Where they are not,
the rank that ``numpy.linalg.lstsq`` would find is in doubt, and :meth:`StripProbe.bic` returns None:
the caller fits that model with :func:`~.patterns.evaluate`. The callers also refit the best
candidates exactly before choosing (:data:`MARGIN`), so the choices are :func:`~.patterns.evaluate`'s.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

#: the callers refit exactly every candidate whose approximate criterion is within this of the least
MARGIN = 1e-3
#: the least ratio of the smallest to the largest eigenvalue of ``N`` for the update to be trusted
#: (the rank not in doubt: a singular value ratio above 1e-6, far from ``lstsq``'s 1e-9)
CONDITION = 1e-12
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
    P: np.ndarray  # (A^T A)^-1
    x: np.ndarray
    rss: float
    owner: np.ndarray  # strip of every used column
    constant: np.ndarray  # whether a used column is a strip's constant function
    good: bool  # N well conditioned


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
            A = A[:, used].tocsr()
            N = (A.T @ A).toarray()
            y = data.value[crow]
            good = used.size > 0
            P = np.zeros((used.size, used.size))
            x = np.zeros(used.size)
            if good:
                ev = np.linalg.eigvalsh(N)
                good = bool(ev[0] > CONDITION * ev[-1])
            if good:
                P = np.linalg.inv(N)
                P = 0.5 * (P + P.T)
                x = P @ (A.T @ y)
            r = y - A @ x
            self.channels.append(_Channel(A, P, x, float(r @ r), owners[used], consts[used], good))


    def bic(self, rho: dict[str, float] | None, n_breaks: int) -> float | None:
        """The current model's BIC as :func:`~.patterns.evaluate` computes it; None when a channel's
        design is not well conditioned (its rank in doubt)."""
        if any(ch is not None and not ch.good for ch in self.channels):
            return None
        parts = [(0.0, 0) if ch is None else (ch.rss, ch.x.size) for ch in self.channels]
        return _criterion(self.index, parts, rho, n_breaks)[0]


def _criterion(index: BlockIndex, parts, rho: dict[str, float] | None, n_breaks: int) -> tuple[float, float]:
    """(BIC, deviance) from every channel's residual sum of squares and rank (:func:`~.patterns.evaluate`)."""
    data = index.data
    deviance, k, n_total = 0.0, 0, 0.0
    for c, name in enumerate(data.channels):
        n = index.rows[c].size
        if n == 0:
            continue
        rss, rank = parts[c]
        p = rho.get(name, 0.0) if rho is not None else 0.0
        neff = n * (1.0 - p) / (1.0 + p)
        deviance += neff * np.log(max(rss, 1e-300) / n)
        k += rank
        n_total += neff
    k += n_breaks
    return deviance + k * np.log(max(n_total, 2.0)), deviance


@dataclass
class _Local:
    """What a candidate of strip ``s`` needs of one channel: the rows ``R`` that see the strip, the other
    strips' columns ``C`` in them (``A_RC``), ``(N_OO)^-1`` on them (``G``), the residual without the
    strip's non-constant functions (on ``R``; its square sum ``rss``), and ``B = A_O (N_OO)^-1_:C``'s
    products (``a = B^T r_O``, ``BB = B^T B``, its rows ``R``); ``rank``: the columns left."""

    R: np.ndarray
    A_RC: np.ndarray
    G: np.ndarray
    r_R: np.ndarray
    rss: float
    a: np.ndarray
    BB: np.ndarray
    B_R: np.ndarray
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
                self.parts.append((ch.rss, ch.x.size))
                continue
            others = np.flatnonzero((ch.owner != s) | ch.constant)
            A_O = ch.A[:, others]
            C = np.searchsorted(others, np.setdiff1d(np.unique(ch.A[R].indices), S))
            P_OS = ch.P[np.ix_(others, S)]
            Pss = np.linalg.inv(ch.P[np.ix_(S, S)]) if S.size else np.zeros((0, 0))
            x_O = ch.x[others] - P_OS @ (Pss @ ch.x[S])
            K = ch.P[np.ix_(others, others[C])] - P_OS @ Pss @ P_OS[C].T  # (N_OO)^-1 [:, C]
            y = data.value[fit.index.rows[c]]
            r_O = y - A_O @ x_O
            B = np.asarray(A_O @ K)
            A_RC = A_O[R][:, C].toarray()
            self.parts.append(_Local(R, A_RC, K[C], r_O[R], float(r_O @ r_O), B.T @ r_O, B.T @ B, B[R],
                                     others.size))

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
            F = part.A_RC.T @ Z
            ZZ = Z.T @ Z
            H = ZZ - F.T @ part.G @ F
            if np.linalg.eigvalsh(H)[0] <= TRUST * float(np.max(np.diag(ZZ))):
                return None
            z = np.linalg.solve(H, Z.T @ part.r_R)
            u = F @ z
            w = Z @ z
            # the residual sum of squares of the coefficients found, from the residual vector
            # r_O + B u - Z z over all the channel's rows (a slightly wrong solution errs in second order)
            rss = part.rss + 2.0 * (part.a @ u - part.r_R @ w) + u @ part.BB @ u - 2.0 * (part.B_R @ u) @ w + w @ w
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
