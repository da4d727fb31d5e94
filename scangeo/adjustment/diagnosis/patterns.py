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
strips and candidate lines) that lowers the Bayesian information criterion most,

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

from dataclasses import dataclass, field

import numpy as np

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


def _nodes(n_lines: int, breaks) -> np.ndarray:
    return np.concatenate([[0.0], np.sort(np.asarray(breaks, float)), [float(n_lines - 1)]])


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
        nd = _nodes(n, b)
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


def evaluate(data: PatternData, breaks, rho: dict[str, float] | None = None, degree: int = 1,
             constant=()) -> Fit:
    """Least-squares fit of the strip functions for ``breaks`` (``constant``: strips held constant), with its BIC."""
    A, _ = design(data, breaks, degree, constant)
    coef = np.zeros(A.shape[1])
    resid = data.value.copy()
    deviance, k, rss, neff = 0.0, 0, {}, {}
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
        p = rho.get(name, 0.0) if rho is not None else 0.0
        neff[name] = n * (1.0 - p) / (1.0 + p)
        deviance += neff[name] * np.log(max(rss[name], 1e-300) / n)
        k += int(rank)
    nb = sum(len(b) for b in breaks)
    k += nb
    n_total = sum(neff.values())
    return Fit(tuple(tuple(float(v) for v in b) for b in breaks), deviance + k * np.log(max(n_total, 2.0)),
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


def _feasible(data: PatternData, s: int, breaks: tuple[float, ...], line: float, min_gap: float,
              min_rows: int) -> bool:
    nd = _nodes(data.n_lines[s], tuple(breaks) + (line,))
    if np.min(np.diff(nd)) < min_gap:
        return False
    sel = data.term_strip == s
    counts = np.histogram(data.term_line[sel], bins=nd)[0]
    return bool(np.all(counts >= min_rows))


@dataclass(frozen=True)
class SelectionOptions:
    """Options of :func:`select_breaks`.

    candidates : candidate lines per strip for a new break (evenly spaced).
    min_gap_fraction : least distance between breaks and from the strip's ends, as a fraction of its lines.
    min_rows : least number of terms of the strip between two breaks.
    max_breaks : most breaks per strip.
    serial_correlation : correct the likelihood for serial correlation of the residuals.
    degree : 1 (piecewise linear) or 2 (piecewise quadratic, C0) between breaks.
    """

    candidates: int = 120
    min_gap_fraction: float = 0.06
    min_rows: int = 6
    max_breaks: int = 4
    serial_correlation: bool = True
    degree: int = 1


def _best_position(data, breaks, s, j, lines, rho, options, constant=()):
    best = None
    for b in lines:
        trial = [list(x) for x in breaks]
        trial[s][j] = float(b)
        trial[s].sort()
        f = evaluate(data, trial, rho, options.degree, constant)
        if best is None or f.bic < best.bic:
            best = f
    return best


def _moves(data: PatternData, breaks, constant: set[int], options: SelectionOptions):
    """Every model one step richer: a constant strip made linear, or a break added to a non-constant strip."""
    for s in range(len(data.strips)):
        if s in constant:
            yield [list(x) for x in breaks], constant - {s}
            continue
        n = data.n_lines[s]
        if len(breaks[s]) >= options.max_breaks:
            continue
        gap = options.min_gap_fraction * n
        for b in np.linspace(0, n - 1, options.candidates + 2)[1:-1]:
            if _feasible(data, s, tuple(breaks[s]), float(b), gap, options.min_rows):
                trial = [list(x) for x in breaks]
                trial[s] = sorted(trial[s] + [float(b)])
                yield trial, constant


def select_breaks(data: PatternData, options: SelectionOptions = SelectionOptions()) -> Fit:
    """Greedy model growth by BIC, then pruning under serial correlation (module docstring)."""
    ns = len(data.strips)
    breaks: list[list[float]] = [[] for _ in range(ns)]
    constant = set(range(ns))
    current = evaluate(data, breaks, None, options.degree, constant)
    while True:
        best = None
        for trial, const in _moves(data, breaks, constant, options):
            f = evaluate(data, trial, None, options.degree, const)
            if best is None or f.bic < best[0].bic:
                best = (f, const)
        if best is None or best[0].bic >= current.bic:
            break
        constant = set(best[1])
        breaks = refine(data, [list(x) for x in best[0].breaks], None, options, constant)
        current = evaluate(data, breaks, None, options.degree, constant)
    if len(constant) == ns:
        return current
    # the serial correlation of what the richest model leaves is the noise's: prune what it does not pay for
    # (and what it adds nothing to: a function another strip's can take over does not raise the rank)
    rho = residual_correlation(data, current) if options.serial_correlation else {}
    current = evaluate(data, breaks, rho, options.degree, constant)
    while len(constant) < ns:
        trials = []
        for s in range(ns):
            if s in constant:
                continue
            if not breaks[s]:
                trials.append(evaluate(data, breaks, rho, options.degree, constant | {s}))
            for j in range(len(breaks[s])):
                trial = [list(x) for x in breaks]
                del trial[s][j]
                trials.append(evaluate(data, refine(data, trial, rho, options, constant), rho, options.degree,
                                       constant))
        pruned = min(trials, key=lambda f: (f.bic, f.k))
        if pruned.bic > current.bic + 1e-6:
            break
        breaks = [list(x) for x in pruned.breaks]
        constant = set(pruned.constant)
        current = pruned
    # the breaks' best lines under the final weights of the channels
    breaks = refine(data, breaks, rho, options, constant)
    return evaluate(data, breaks, rho, options.degree, constant)


def refine(data: PatternData, breaks, rho, options: SelectionOptions, constant=(), sweeps: int = 3
           ) -> list[list[float]]:
    """Move every break to its best line (others fixed), a few sweeps: within two candidate spacings of
    where it is, on a grid of 1/600 of the strip."""
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
                f = _best_position(data, breaks, s, j, lines, rho, options, constant)
                new = sorted(f.breaks[s])
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


def break_intervals(data: PatternData, fit: Fit, options: SelectionOptions = SelectionOptions()
                    ) -> list[BreakEstimate]:
    """95 % profile-likelihood interval of every break of ``fit`` (the others fixed)."""
    rho = fit.rho
    out = []
    for s, strip_breaks in enumerate(fit.breaks):
        n = data.n_lines[s]
        for j, b in enumerate(strip_breaks):
            lines = np.union1d(_window(data, list(strip_breaks), j, n, options, 1.0 / 1000), [b])
            profile = []
            for line in lines:
                trial = [list(x) for x in fit.breaks]
                trial[s][j] = float(line)
                profile.append(evaluate(data, trial, rho, options.degree, fit.constant).deviance)
            dev = np.asarray(profile)
            if dev.size == 0:
                out.append(BreakEstimate(data.strips[s], b, b, b))
                continue
            i0 = int(np.argmin(dev))
            ok = dev - dev.min() <= CHI2_95
            lo = hi = i0
            while lo > 0 and ok[lo - 1]:
                lo -= 1
            while hi < lines.size - 1 and ok[hi + 1]:
                hi += 1
            out.append(BreakEstimate(data.strips[s], float(b), float(min(lines[lo], b)), float(max(lines[hi], b))))
    return out


__all__ = ["CHI2_95", "BreakEstimate", "Fit", "PatternData", "SelectionOptions", "break_intervals", "design",
           "evaluate", "residual_correlation", "select_breaks"]
