"""Breaks in a strip's GPS/IMU error: C0 piecewise-linear functions along each strip, breaks chosen by BIC.

The diagnosis (:mod:`scangeo.adjustment.diagnosis.diagnose`) turns an SE adjustment into observations of
unknown error functions of the strips: every observation row is a weighted sum of the values of
one or more strip functions at image lines,

    y_r = sum_j  w_rj  f_{s_j, k_j}(l_rj) + e_r,        e_r ~ N(0, sigma_c^2) for the row's channel c,

where ``f_{s,k}`` is component ``k`` (e.g. across-track or vertical position error) of strip ``s``,
continuous and linear between the strip's breaks (C0, kinks allowed: the split models of the
adjustment). A misclosure of a tie point seen in two strips involves both strips' functions, so a
strip is blamed only when that explains the data with fewer parameters than blaming its neighbours.

Model selection (:func:`select_breaks`): every strip starts with no break (one line per component:
what SE with a rigid rotation can absorb); breaks are inserted greedily, each time the one (over all
strips and candidate lines) that lowers the Bayesian information criterion most (when no single one
does, the best pair of breaks on one strip, on a coarser grid: an excursion that rises and falls back
is fitted no better by one kink than by none),

    BIC = sum_c n_c log(RSS_c / n_c) + k log(n),        k = rank of the design + number of breaks,

with each channel's variance estimated (profile likelihood), until no insertion lowers it; after
every insertion each break is moved to its best line with the others fixed. The residual variance
of a channel is corrected for serial correlation along the strip (the DTM's error is correlated
over hundreds of metres): ``n_c`` in the likelihood term becomes the effective number
``n_c (1 - rho) / (1 + rho)`` with ``rho`` the lag-1 autocorrelation of the residuals along the
lines, which keeps correlated noise from buying breaks. The 95 % interval of a break is the
range of lines over which the criterion's likelihood term rises by at most 3.84 (chi^2, 1 degree of
freedom) with the other breaks fixed (a profile likelihood interval).
"""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial

import numpy as np

from scangeo.adjustment.diagnosis.local_fit import MARGIN, BlockIndex, CurrentFit, StripProbe, saturated, strip_nodes
from scangeo.blas import one_thread

#: chi^2 quantile (1 degree of freedom, 95 %) for the profile-likelihood interval of a break.
CHI2_95 = 3.841


@dataclass
class PatternData:
    """Observation rows of the strip functions (see the module docstring).

    ``value``, ``channel`` per row; the terms ``term_row``, ``term_strip``, ``term_component``,
    ``term_line``, ``term_weight`` say which function values (strip, component, line) enter which row
    with which weight. ``n_lines`` per strip: the line axis ``0 .. n_lines - 1`` of its functions.
    ``order`` (per row, optional): a position used to order rows for the serial correlation (default
    the line of the row's first term).
    """

    value: np.ndarray
    channel: np.ndarray
    term_row: np.ndarray
    term_strip: np.ndarray
    term_component: np.ndarray
    term_line: np.ndarray
    term_weight: np.ndarray
    strips: tuple[str, ...]
    n_lines: tuple[int, ...]
    channels: tuple[str, ...]
    components: tuple[str, ...]
    order: np.ndarray | None = None

    @property
    def n(self) -> int:
        return int(self.value.size)

    def first_term(self) -> tuple[np.ndarray, np.ndarray]:
        """(strip, line) of every row's first term."""
        rows, first = np.unique(self.term_row, return_index=True)
        strip = np.full(self.n, -1)
        line = np.zeros(self.n)
        strip[rows], line[rows] = self.term_strip[first], self.term_line[first]
        return strip, line


@dataclass
class Fit:
    """A fitted set of breaks: the criterion and what it is made of."""

    breaks: tuple[tuple[float, ...], ...]
    bic: float
    deviance: float
    k: int
    rss: dict[str, float]
    n_eff: dict[str, float]
    rho: dict[str, float] = field(default_factory=dict)
    constant: tuple[int, ...] = ()
    coefficients: np.ndarray = field(repr=False, default_factory=lambda: np.zeros(0))
    residuals: np.ndarray = field(repr=False, default_factory=lambda: np.zeros(0))
    #: the other attributions of its problem strips (:func:`alternatives`), when :func:`select_breaks` made it
    alternatives: list[Alternative] = field(repr=False, default_factory=list)


@dataclass
class BreakEstimate:
    """A break of a strip: its line and 95 % interval; ``method`` says what placed it (``bic_line``: the
    BIC's line when the S model moved it, :mod:`scangeo.adjustment.diagnosis.refine`, which also tests it:
    ``f_statistic``, ``p_value``)."""

    strip: str
    line: float
    low: float
    high: float
    bic_line: float | None = None
    method: str = "BIC"
    #: the split model's test of the break (:func:`scangeo.adjustment.diagnosis.refine.break_tests`):
    #: F statistic of the parameters it adds, and its p-value
    f_statistic: float | None = None
    p_value: float | None = None

    @property
    def half_width(self) -> float:
        return 0.5 * (self.high - self.low)


def design(data: PatternData, breaks, degree: int = 1, constant=()) -> tuple[np.ndarray, list[tuple[int, int, int]]]:
    """The design matrix for ``breaks`` (per strip) and (strip, component, node) per column.

    Columns are the values of each strip function at its nodes (the strip's ends and breaks); a
    function value between two nodes is their linear interpolation (C0 hat functions). Degree 2 adds
    per segment a quadratic bubble ``4 u (1 - u)`` (u from 0 to 1 over the segment; node -1 - segment),
    which vanishes at the nodes and so keeps the function continuous. A strip in ``constant`` has one
    column per component (a constant function; node 0).
    """
    nk = len(data.components)
    names: list[tuple[int, int, int]] = []
    offset = np.zeros(len(data.strips), int)
    nodes = []
    for s, (n, b) in enumerate(zip(data.n_lines, breaks)):
        nd = strip_nodes(n, b)
        nodes.append(nd)
        offset[s] = len(names)
        if s in constant:
            names += [(s, k, 0) for k in range(nk)]
            continue
        names += [(s, k, j) for k in range(nk) for j in range(nd.size)]
        if degree >= 2:
            names += [(s, k, -1 - j) for k in range(nk) for j in range(nd.size - 1)]
    A = np.zeros((data.n, len(names)))
    for s, nd in enumerate(nodes):
        sel = np.flatnonzero(data.term_strip == s)
        if sel.size == 0:
            continue
        if s in constant:
            np.add.at(A, (data.term_row[sel], offset[s] + data.term_component[sel]), data.term_weight[sel])
            continue
        line = np.clip(data.term_line[sel], nd[0], nd[-1])
        seg = np.clip(np.searchsorted(nd, line, side="right") - 1, 0, nd.size - 2)
        frac = (line - nd[seg]) / (nd[seg + 1] - nd[seg])
        base = offset[s] + data.term_component[sel] * nd.size
        w = data.term_weight[sel]
        np.add.at(A, (data.term_row[sel], base + seg), w * (1.0 - frac))
        np.add.at(A, (data.term_row[sel], base + seg + 1), w * frac)
        if degree >= 2:
            bubble = offset[s] + nk * nd.size + data.term_component[sel] * (nd.size - 1) + seg
            np.add.at(A, (data.term_row[sel], bubble), w * 4.0 * frac * (1.0 - frac))
    return A, names


def _serial_rho(resid: np.ndarray, strip: np.ndarray, line: np.ndarray) -> float:
    """Lag-1 autocorrelation of residuals ordered by line within each strip (clipped to [0, 0.9])."""
    num = den = 0.0
    for s in np.unique(strip):
        r = resid[strip == s][np.argsort(line[strip == s])]
        if r.size > 2:
            r = r - r.mean()
            num += float(np.sum(r[1:] * r[:-1]))
            den += float(np.sum(r * r))
    return float(np.clip(num / den, 0.0, 0.9)) if den > 0 else 0.0


@one_thread()  # designs of a few thousand rows x ~100 columns (scangeo/blas.py)
def evaluate(data: PatternData, breaks, rho: dict[str, float] | None = None, degree: int = 1,
             constant=()) -> Fit:
    """Least-squares fit of the strip functions for ``breaks`` (``constant``: strips held constant), with its BIC
    (infinite for a model with breaks that saturates a channel: :func:`~.local_fit.saturated`)."""
    A, _ = design(data, breaks, degree, constant)
    coef = np.zeros(A.shape[1])
    resid = data.value.copy()
    deviance, k, rss, neff = 0.0, 0, {}, {}
    nb = sum(len(b) for b in breaks)
    saturating = False
    for c, name in enumerate(data.channels):
        rows = data.channel == c
        if not rows.any():
            continue
        Ac = A[rows]
        used = np.flatnonzero(np.any(Ac != 0.0, axis=0))
        x, _, rank, _ = np.linalg.lstsq(Ac[:, used], data.value[rows], rcond=1e-9)
        coef[used] += x
        r = data.value[rows] - Ac[:, used] @ x
        resid[rows] = r
        n = int(rows.sum())
        rss[name] = float(r @ r)
        saturating |= saturated(n, int(rank), nb)
        p = rho.get(name, 0.0) if rho is not None else 0.0
        neff[name] = n * (1.0 - p) / (1.0 + p)
        deviance += neff[name] * np.log(max(rss[name], 1e-300) / n)
        k += int(rank)
    k += nb
    n_total = sum(neff.values())
    bic = math.inf if saturating else deviance + k * np.log(max(n_total, 2.0))
    return Fit(tuple(tuple(float(v) for v in b) for b in breaks), bic,
               deviance, k, rss, neff, dict(rho or {}), tuple(sorted(constant)), coef, resid)


def residual_correlation(data: PatternData, fit: Fit) -> dict[str, float]:
    """Lag-1 serial correlation of each channel's residuals along the lines."""
    strip, line = data.first_term()
    if data.order is not None:
        line = data.order
    out = {}
    for c, name in enumerate(data.channels):
        rows = data.channel == c
        if rows.any():
            out[name] = _serial_rho(fit.residuals[rows], strip[rows], line[rows])
    return out


@dataclass(frozen=True)
class SelectionOptions:
    """Options of :func:`select_breaks`.

    candidates : candidate lines per strip for a new break (evenly spaced).
    min_gap_fraction : least distance between breaks and from the strip's ends, as a fraction of its lines.
    min_rows : least number of terms of the strip between two breaks.
    max_breaks : most breaks per strip.
    serial_correlation : correct the likelihood for serial correlation of the residuals.
    degree : 1 (piecewise linear) or 2 (piecewise quadratic, C0) between breaks.
    pair_candidates : candidate lines per strip for two breaks added at once, when no single step
        lowers the criterion (an excursion that rises and falls back is not fitted better by one
        kink than by none); 0: no such step.
    pair_strips : the strips searched for such a pair: the ones not held constant and this many more,
        those whose best single step came closest to paying (a pair's drift shows in its single steps
        too; searching every strip of a large block costs what the local update saves).
    """

    candidates: int = 120
    min_gap_fraction: float = 0.06
    min_rows: int = 6
    max_breaks: int = 4
    serial_correlation: bool = True
    degree: int = 1
    pair_candidates: int = 30
    pair_strips: int = 3


def _with(breaks, s: int, strip_breaks) -> list[list[float]]:
    trial = [list(x) for x in breaks]
    trial[s] = sorted(float(v) for v in strip_breaks)
    return trial


def _refit_bic(data: PatternData, breaks, rho, degree: int, constant) -> float:
    return evaluate(data, breaks, rho, degree, constant).bic


class Candidates:
    """Models scored by :mod:`~.local_fit` (None: not trusted), refitted with :func:`evaluate` where the
    scores are too close to tell (:data:`~.local_fit.MARGIN`). A model is ``base`` with strip ``s``'s
    breaks replaced, or whole ``breaks``."""

    def __init__(self, data: PatternData, base, rho, degree: int) -> None:
        self.data, self.base, self.rho, self.degree = data, base, rho, degree
        self.models: list[tuple[int, list[float], list[list[float]] | None, set[int]]] = []
        self.approx: list[float | None] = []
        self.fits: dict[int, Fit] = {}

    def add(self, approx: float | None, constant, s: int = -1, strip=(), breaks=None) -> None:
        self.models.append((s, sorted(float(v) for v in strip), breaks, set(constant)))
        self.approx.append(approx)

    def breaks(self, i: int) -> list[list[float]]:
        s, strip, breaks, _ = self.models[i]
        return [list(x) for x in breaks] if breaks is not None else _with(self.base, s, strip)

    def fit(self, i: int) -> Fit:
        if i not in self.fits:
            self.fits[i] = evaluate(self.data, self.breaks(i), self.rho, self.degree, self.models[i][3])
        return self.fits[i]

    def refit_bic(self, i: int) -> float:
        return self.fit(i).bic

    def score(self, i: int) -> tuple[float, bool]:
        """Candidate ``i``'s criterion and whether it is :func:`evaluate`'s."""
        return (self.fits[i].bic, True) if i in self.fits else (float(self.approx[i]), False)  # type: ignore[arg-type]

    def best(self, by_rank: bool = False) -> int:
        """The candidate with the least criterion (then the least rank, ``by_rank``) as refitting every one
        would find it, the first of equals: the untrusted ones are refitted, then those within the margin
        of the least value, unless a single one is that close."""
        for i, a in enumerate(self.approx):
            if a is None:
                self.fit(i)
        values = [self.score(i)[0] for i in range(len(self.approx))]
        least = min(values)
        near = [i for i, v in enumerate(values) if v <= least + MARGIN]
        if len(near) == 1:
            return near[0]
        if by_rank:
            return min(near, key=lambda i: (self.fit(i).bic, self.fit(i).k))
        return min(near, key=self.refit_bic)


def _below(a: tuple[float, bool], refit_a: Callable[[], float], b: tuple[float, bool], refit_b: Callable[[], float],
           slack: float = 0.0) -> bool:
    """Whether criterion ``a`` < ``b`` + ``slack`` (each with whether it is :func:`evaluate`'s), refitting
    both when the approximations are too close to tell."""
    if abs(a[0] - b[0] - slack) <= MARGIN and not (a[1] and b[1]):
        return refit_a() < refit_b() + slack
    return a[0] < b[0] + slack


def _best_position(data, breaks, s, j, lines, rho, options, constant=(), index: BlockIndex | None = None
                   ) -> list[float]:
    """Strip ``s``'s breaks with break ``j`` on the best of ``lines`` (the first of equals)."""
    index = index or BlockIndex(data)
    probe = StripProbe(CurrentFit(index, breaks, options.degree, constant), s)
    n_breaks = sum(len(b) for b in breaks)
    candidates = Candidates(data, breaks, rho, options.degree)
    for b in lines:
        strip = list(breaks[s])
        strip[j] = float(b)
        strip.sort()
        r = probe.bic(strip, False, rho, n_breaks)
        candidates.add(None if r is None else r[0], constant, s, strip)
    return candidates.models[candidates.best()][1]


def _richer(data: PatternData, fit: CurrentFit, options: SelectionOptions) -> Candidates:
    """Every model one step richer than the current one (``fit``): a constant strip made linear, or a break
    added to a non-constant strip, scored against it."""
    index, breaks, constant = fit.index, [list(b) for b in fit.breaks], set(fit.constant)
    n_breaks = sum(len(b) for b in breaks)
    candidates = Candidates(data, breaks, None, options.degree)
    for s in range(len(data.strips)):
        if s in constant:
            r = StripProbe(fit, s).bic((), False, None, n_breaks)
            candidates.add(None if r is None else r[0], constant - {s}, s, [])
            continue
        n = data.n_lines[s]
        if len(breaks[s]) >= options.max_breaks:
            continue
        gap = options.min_gap_fraction * n
        probe = None
        for b in np.linspace(0, n - 1, options.candidates + 2)[1:-1]:
            if index.feasible(s, tuple(breaks[s]), float(b), gap, options.min_rows):
                probe = probe or StripProbe(fit, s)
                trial = sorted(breaks[s] + [float(b)])
                r = probe.bic(trial, False, None, n_breaks + 1)
                candidates.add(None if r is None else r[0], constant, s, trial)
    return candidates


def _pair_strips(richer: Candidates, constant, options: SelectionOptions) -> set[int]:
    """The strips :func:`_richer_by_two` searches (``SelectionOptions.pair_strips``), from the single steps."""
    best: dict[int, float] = {}
    for i, (s, _, _, _) in enumerate(richer.models):
        value = richer.score(i)[0] if richer.approx[i] is not None or i in richer.fits else -math.inf
        best[s] = min(best.get(s, math.inf), value)
    closest = sorted(best, key=best.__getitem__)[:options.pair_strips]
    return set(closest) | {s for s in range(len(richer.base)) if s not in constant}


def _richer_by_two(data: PatternData, fit: CurrentFit, options: SelectionOptions, rho,
                   strips: set[int] | None = None) -> Candidates:
    """Every model with two breaks more on one strip than the current one (a constant strip made linear
    too), on a grid of ``options.pair_candidates`` lines per strip, scored with the serial correlation
    ``rho`` against it. Where the current model's design is well conditioned, a pair the local update
    does not trust is left out, not refitted: its columns are nearly dependent on the others' (two
    breaks around a few rows), no credible pair of kinks, and refitting the hundreds of them would cost
    what the local update saves. Where the current design is not (the strips' common constants are not
    all determined), every pair is refitted, as every single step is. ``strips``: those searched (all)."""
    index, breaks, constant = fit.index, [list(b) for b in fit.breaks], set(fit.constant)
    n_breaks = sum(len(b) for b in breaks)
    candidates = Candidates(data, breaks, rho, options.degree)
    if options.pair_candidates < 2:
        return candidates
    for s in range(len(data.strips)):
        if strips is not None and s not in strips:
            continue
        n = data.n_lines[s]
        if len(breaks[s]) + 2 > options.max_breaks:
            continue
        gap = options.min_gap_fraction * n
        grid = [float(b) for b in np.linspace(0, n - 1, options.pair_candidates + 2)[1:-1]
                if index.feasible(s, tuple(breaks[s]), float(b), gap, options.min_rows)]
        probe = None
        for i, a in enumerate(grid):
            for b in grid[i + 1:]:
                if not index.feasible(s, tuple(breaks[s]) + (a,), b, gap, options.min_rows):
                    continue
                probe = probe or StripProbe(fit, s)
                trial = sorted(breaks[s] + [a, b])
                r = probe.bic(trial, False, rho, n_breaks + 2)
                if r is not None or not probe.trusted:
                    candidates.add(None if r is None else r[0], constant - {s}, s, trial)
    return candidates


def _poorer(data: PatternData, index: BlockIndex, breaks, constant: set[int], rho, options: SelectionOptions
            ) -> Candidates:
    """Every model one step poorer than the current: a linear strip made constant, or a break removed (and
    the others moved to their best lines)."""
    fit = CurrentFit(index, breaks, options.degree, constant)
    n_breaks = sum(len(b) for b in breaks)
    candidates = Candidates(data, breaks, rho, options.degree)
    for s in range(len(data.strips)):
        if s in constant:
            continue
        if not breaks[s]:
            r = StripProbe(fit, s).bic((), True, rho, n_breaks)
            candidates.add(None if r is None else r[0], constant | {s}, s, [])
        for j in range(len(breaks[s])):
            trial = [list(x) for x in breaks]
            del trial[s][j]
            trial = refine(data, trial, rho, options, constant, index=index)
            candidates.add(CurrentFit(index, trial, options.degree, constant).bic(rho, n_breaks - 1), constant,
                           breaks=trial)
    return candidates


def neighbours(data: PatternData, s: int) -> list[int]:
    """The strips that share observation rows with strip ``s`` (tie points in common)."""
    rows = np.unique(data.term_row[data.term_strip == s])
    others = np.unique(data.term_strip[np.isin(data.term_row, rows)])
    return [int(t) for t in others if t != s]


def line_map(data: PatternData, s: int, t: int) -> tuple[float, float] | None:
    """``(a, b)`` with ``line_t = a + b line_s`` where strips ``s`` and ``t`` see the same ground (least
    squares over their common rows; ``b`` is about -1 for a strip flown the other way); None with fewer
    than three common rows."""
    line_s: dict[int, float] = {}
    line_t: dict[int, float] = {}
    for r, st, line in zip(data.term_row, data.term_strip, data.term_line):
        if st == s:
            line_s.setdefault(int(r), float(line))
        elif st == t:
            line_t.setdefault(int(r), float(line))
    common = sorted(set(line_s) & set(line_t))
    if len(common) < 3:
        return None
    x = np.array([line_s[r] for r in common])
    y = np.array([line_t[r] for r in common])
    (a, b), *_ = np.linalg.lstsq(np.column_stack([np.ones_like(x), x]), y, rcond=None)
    return float(a), float(b)


#: sweeps of :func:`refine` for an alternative's carried or searched breaks (they start within a grid step)
SWEEPS_ALT = 2


@dataclass
class Alternative:
    """Another attribution of a problem strip's functions: ``moved`` to strip ``other`` (``strip`` made
    constant), ``shared`` with it (both strips split), ``merged``: ``other`` lies between ``strip``
    and further strips that are not constant (``also``), and its functions alone replace theirs (a
    drift of a middle strip shows in both its overlaps, and functions on both its neighbours can mimic
    it). The breaks are
    carried to the lines where ``other`` sees the same ground and moved to its best lines. Or ``dropped``:
    ``strip`` held constant, nothing in its place (``other`` is ``strip``). ``fit`` under the serial
    correlation given."""

    kind: str
    strip: int
    other: int
    fit: Fit
    also: tuple[int, ...] = ()


def _carried(data: PatternData, breaks, constant, s: int, t: int, keep: bool, rho, options: SelectionOptions,
             index: BlockIndex, also=()) -> tuple[list[list[float]], set[int]] | None:
    """Strip ``s``'s breaks carried to strip ``t`` (``keep``: ``s`` keeps its own; ``also``: further strips
    made constant), at ``t``'s best lines: those where ``t`` sees the ground ``s`` broke at, or (one or
    two breaks) the best of a coarse search over ``t``'s lines, whichever fits better, then refined
    (:data:`SWEEPS_ALT` sweeps of :func:`refine`)."""
    m = line_map(data, s, t)
    if m is None:
        return None
    n = data.n_lines[t]
    gap = options.min_gap_fraction * n
    own = [float(b) for b in breaks[t]]
    lines = list(own)
    for x in sorted(m[0] + m[1] * b for b in breaks[s]):
        line = float(np.clip(x, gap, n - 1 - gap))
        if len(lines) < options.max_breaks and index.feasible(t, tuple(lines), line, gap, options.min_rows):
            lines.append(line)
    trial = [list(x) for x in breaks]
    const = set(constant) - {t}
    for u in ((s,) if not keep else ()) + tuple(also):
        trial[u] = []
        const.add(u)
    starts = [sorted(lines)]
    k = len(breaks[s])
    if 1 <= k <= 2 and len(own) + k <= options.max_breaks:
        trial[t] = own
        base = CurrentFit(index, trial, options.degree, const - {t} if own else const | {t})
        probe = StripProbe(base, t)
        # a coarse grid (half the pair search's lines), the refinement below does the rest
        steps = max(options.pair_candidates // 2, 2) * (2 if k == 1 else 1)
        grid = [float(b) for b in np.linspace(0, n - 1, steps + 2)[1:-1]
                if index.feasible(t, tuple(own), float(b), gap, options.min_rows)]
        sets = [[a] for a in grid] if k == 1 else [[a, b] for i, a in enumerate(grid) for b in grid[i + 1:]
                                                    if index.feasible(t, tuple(own) + (a,), b, gap, options.min_rows)]
        n_breaks = sum(len(b) for u, b in enumerate(trial) if u != t) + len(own) + k
        scored = [(r[0], x) for x in sets if (r := probe.bic(sorted(own + x), False, rho, n_breaks)) is not None]
        if scored:
            starts.append(sorted(own + min(scored)[1]))
    best = None
    for start in starts:
        trial[t] = start
        value = evaluate(data, trial, rho, options.degree, const).bic
        if best is None or value < best[0]:
            best = (value, [list(x) for x in trial])
    assert best is not None
    return refine(data, best[1], rho, options, const, sweeps=SWEEPS_ALT, index=index), const


@one_thread()  # designs of a few thousand rows x ~100 columns (scangeo/blas.py)
def alternatives(data: PatternData, fit: Fit, options: SelectionOptions | None = None,
                 index: BlockIndex | None = None, kinds=("moved", "shared", "merged", "dropped")
                 ) -> list[Alternative]:
    """Every problem strip's functions moved to, or shared with, each neighbour, and the functions of two or
    more problem strips merged into a strip between them (the :class:`Alternative` kinds; a neighbour
    that is not constant keeps its own breaks and gets the carried ones), fitted under ``fit``'s serial
    correlation (``fit.rho``)."""
    options = options or SelectionOptions()
    index = index or BlockIndex(data)
    rho = fit.rho or None
    out = []
    for s in range(len(data.strips)):
        if s in fit.constant or not fit.breaks[s]:
            continue
        if "dropped" in kinds:
            kept = [list(b) for b in fit.breaks]
            kept[s] = []
            out.append(Alternative("dropped", s, s, evaluate(data, kept, rho, options.degree, set(fit.constant) | {s})))
        for t in neighbours(data, s):
            flanks = [u for u in neighbours(data, t) if u != s and u not in fit.constant]
            for kind in kinds:
                if kind == "dropped" or kind == "merged" and not flanks:
                    continue
                also = flanks if kind == "merged" else ()
                trial = _carried(data, fit.breaks, fit.constant, s, t, kind == "shared", rho, options, index, also)
                if trial is not None:
                    out.append(Alternative(kind, s, t, evaluate(data, trial[0], rho, options.degree, trial[1]),
                                           tuple(also)))
    return out


def _better_alternative(data: PatternData, fit: Fit, options: SelectionOptions, index: BlockIndex,
                        kinds=("moved", "merged")) -> tuple[Fit | None, list[Alternative]]:
    """The alternative (:func:`alternatives`) with a lower criterion than ``fit``'s, the lowest (None if none),
    and all of them."""
    alts = alternatives(data, fit, options, index, kinds)
    found = [a.fit for a in alts if a.fit.bic < fit.bic - 1e-6]
    return (min(found, key=lambda f: f.bic) if found else None), alts


@one_thread()  # designs of a few thousand rows x ~100 columns (scangeo/blas.py)
def select_breaks(data: PatternData, options: SelectionOptions = SelectionOptions()) -> Fit:
    """Greedy model growth by BIC, then pruning under serial correlation (module docstring).

    The candidate models are scored by :mod:`~.local_fit` (each differs from the current model in one
    strip); where two are too close to tell they are refitted with :func:`evaluate`, so the choices are
    those of refitting every candidate."""
    ns = len(data.strips)
    degree = options.degree
    index = BlockIndex(data)
    breaks: list[list[float]] = [[] for _ in range(ns)]
    constant = set(range(ns))
    while True:
        fit = CurrentFit(index, breaks, degree, constant)
        value = fit.bic(None, sum(len(b) for b in breaks))
        now = (value, False) if value is not None else (_refit_bic(data, breaks, None, degree, constant), True)
        step = None
        richer = _richer(data, fit, options)
        if richer.models:
            i = richer.best()
            if _below(richer.score(i), partial(richer.refit_bic, i), now,
                      partial(_refit_bic, data, breaks, None, degree, constant)):
                step = richer.breaks(i), richer.models[i][3]
        if step is None and options.pair_candidates >= 2:
            # no single step pays: the best two breaks at once on one strip, which must pay under the serial
            # correlation of what the current model leaves (the richer one's own would let correlated noise
            # buy a pair, and then single breaks after it)
            pairs = _richer_by_two(data, fit, options, None, _pair_strips(richer, constant, options))
            if pairs.models:
                i = pairs.best()
                rho_now = residual_correlation(data, evaluate(data, breaks, None, degree, constant)) \
                    if options.serial_correlation else {}
                richer_fit = evaluate(data, pairs.breaks(i), rho_now, degree, pairs.models[i][3])
                if richer_fit.bic < evaluate(data, breaks, rho_now, degree, constant).bic:
                    step = pairs.breaks(i), pairs.models[i][3]
        if step is None and len(constant) < ns:
            # nor a pair: a problem strip's functions moved to a neighbour, or two merged into the strip between
            # them, where greed put them on the wrong one of strips that see the same tie points
            better, _ = _better_alternative(data, evaluate(data, breaks, None, degree, constant), options, index,
                                            ("moved", "merged"))
            if better is not None:
                step = [list(b) for b in better.breaks], set(better.constant)
        if step is None:
            break
        breaks, constant = step
        breaks = refine(data, breaks, None, options, constant, index=index)
    current = evaluate(data, breaks, None, degree, constant)
    if len(constant) == ns:
        return current
    # the serial correlation of what the richest model leaves is the noise's: prune what it does not pay for
    # (and what it adds nothing to: a function another strip's can take over does not raise the rank)
    rho = residual_correlation(data, current) if options.serial_correlation else {}
    current = evaluate(data, breaks, rho, degree, constant)
    while len(constant) < ns:
        poorer = _poorer(data, index, breaks, constant, rho, options)
        i = poorer.best(by_rank=True)
        # keep the current model when the poorer one's criterion exceeds it by more than 1e-6
        if _below((current.bic, True), partial(float, current.bic), poorer.score(i), partial(poorer.refit_bic, i),
                  -1e-6):
            break
        current = poorer.fit(i)
        breaks = [list(x) for x in current.breaks]
        constant = set(current.constant)
    return polish(data, breaks, rho, options, constant, index)


def polish(data: PatternData, breaks, rho: dict[str, float], options: SelectionOptions, constant=(),
           index: BlockIndex | None = None) -> Fit:
    """The last steps of :func:`select_breaks` from a model (``breaks``, ``constant``) under the serial
    correlation ``rho``: its breaks moved to their best lines, then no problem strip better moved to a
    neighbour (or two merged; a richer model, shared, is the growth's and the pruning's to decide, not
    this polish's); the fit with its :func:`alternatives`."""
    index = index or BlockIndex(data)
    breaks = refine(data, breaks, rho, options, constant, index=index)
    current = evaluate(data, breaks, rho, options.degree, constant)
    alts: list[Alternative] = []
    for _ in range(len(data.strips)):
        better, alts = _better_alternative(data, current, options, index, ("moved", "merged"))
        if better is None:
            break
        current, alts = better, []
    current.alternatives = alts + alternatives(data, current, options, index, ("shared", "dropped"))
    return current


def refine(data: PatternData, breaks, rho, options: SelectionOptions, constant=(), sweeps: int = 3,
           index: BlockIndex | None = None) -> list[list[float]]:
    """Move every break to its best line (others fixed), a few sweeps: within two candidate spacings of
    where it is, on a grid of 1/600 of the strip."""
    index = index or BlockIndex(data)
    breaks = [list(b) for b in breaks]
    for _ in range(sweeps):
        moved = False
        for s in range(len(breaks)):
            n = data.n_lines[s]
            for j in range(len(breaks[s])):
                lines = _window(data, breaks[s], j, n, options)
                reach = 2.0 * n / (options.candidates + 1)
                lines = lines[np.abs(lines - breaks[s][j]) <= reach]
                if lines.size == 0:
                    continue
                new = _best_position(data, breaks, s, j, lines, rho, options, constant, index)
                if new != breaks[s]:
                    moved = True
                breaks[s] = list(new)
        if not moved:
            break
    return breaks


def _window(data, strip_breaks, j, n, options, step_fraction=1.0 / 600) -> np.ndarray:
    """Candidate lines for break j between its neighbours (respecting the least gap)."""
    gap = options.min_gap_fraction * n
    lo = (strip_breaks[j - 1] if j > 0 else 0.0) + gap
    hi = (strip_breaks[j + 1] if j + 1 < len(strip_breaks) else n - 1.0) - gap
    if hi < lo:
        return np.zeros(0)
    return np.arange(lo, hi + 1e-9, max(step_fraction * n, 1.0))


@one_thread()  # designs of a few thousand rows x ~100 columns (scangeo/blas.py)
def break_intervals(data: PatternData, fit: Fit, options: SelectionOptions = SelectionOptions()
                    ) -> list[BreakEstimate]:
    """95 % profile-likelihood interval of every break of ``fit`` (the others fixed).

    The profile is scored by :class:`~.local_fit.StripProbe`; the lines near its least value and near
    the interval's ends (within :data:`~.local_fit.MARGIN`) are refitted with :func:`evaluate`, so the
    interval is the one refitting every line gives."""
    rho = fit.rho
    index = BlockIndex(data)
    current = CurrentFit(index, fit.breaks, options.degree, fit.constant)
    n_breaks = sum(len(b) for b in fit.breaks)
    out = []
    for s, strip_breaks in enumerate(fit.breaks):
        n = data.n_lines[s]
        probe = StripProbe(current, s) if strip_breaks else None
        for j, b in enumerate(strip_breaks):
            lines = np.union1d(_window(data, list(strip_breaks), j, n, options, 1.0 / 1000), [b])
            if lines.size == 0:
                out.append(BreakEstimate(data.strips[s], b, b, b))
                continue
            trials = []
            for line in lines:
                strip = list(strip_breaks)
                strip[j] = float(line)
                trials.append(sorted(strip))
            approx = [probe.bic(t, False, rho, n_breaks) if probe is not None else None for t in trials]
            dev = np.array([np.inf if a is None else a[1] for a in approx])
            exact = np.zeros(dev.size, bool)
            # refitted: the untrusted lines; then, when a line is too close to the interval's end to tell,
            # the least value and the lines that close to the end
            for sel in (~np.isfinite(dev), "least", "edge"):
                if isinstance(sel, str):
                    if not np.any(np.abs(dev - dev.min() - CHI2_95) <= MARGIN):
                        break
                    low = dev.min() + (CHI2_95 if sel == "edge" else 0.0)
                    sel = np.abs(dev - low) <= MARGIN
                for i in np.flatnonzero(sel & ~exact):
                    dev[i] = evaluate(data, _with(fit.breaks, s, trials[i]), rho, options.degree,
                                      fit.constant).deviance
                    exact[i] = True
            i0 = int(np.argmin(dev))
            ok = dev - dev.min() <= CHI2_95
            lo = hi = i0
            while lo > 0 and ok[lo - 1]:
                lo -= 1
            while hi < lines.size - 1 and ok[hi + 1]:
                hi += 1
            out.append(BreakEstimate(data.strips[s], float(b), float(min(lines[lo], b)), float(max(lines[hi], b))))
    return out


__all__ = ["CHI2_95", "Alternative", "BreakEstimate", "Candidates", "Fit", "PatternData", "SelectionOptions",
           "alternatives", "break_intervals", "design", "evaluate", "line_map", "neighbours", "polish",
           "residual_correlation", "select_breaks"]
