"""Break lines placed by adjusting the split model at candidate lines: the adjustment's own profile likelihood.

The BIC search (:mod:`scangeo.adjustment.diagnosis.patterns`) decides how many breaks a strip has and
where they roughly lie, with straight lines between them. An error that bends before its kink (the
simulated excursion rises with a concave bulge) pulls a straight line's corner away from the kink: at
half the vienna2000 length the first break came 190-410 lines early. The split model the variants use
(S: the problem strips split at their breaks, position degree 2 per part, C0 at the breaks) models
such a bend, so :func:`refine_breaks` asks it where the break is: for each break in turn, the others
fixed, the S model is adjusted with the break at lines around the BIC's (control in its bands, the tie
points with DTM heights, no automatic rejection: the S2 variant) and the line with the smallest
weighted sum of squared residuals ``vTPv`` wins (the maximum-likelihood line: keeping the BIC's line
whenever it lies inside the 95 % level was measured and keeps the BIC's early bias, e.g. full-length
vienna2000 seed 4: 2310 / 4713 instead of 2415 / 4818 for 2400 / 4900). Every candidate has the same
observations and unknowns (the same redundancy), so differences of ``vTPv`` are likelihood-ratio
statistics: the 95 % interval is the range of lines with ``vTPv - min <= 3.84 sigma0^2`` (chi^2, 1 degree of freedom;
``sigma0`` of the best candidate scales a wrong a-priori weight). The DTM's error is correlated along
a strip, so the interval is a lower bound of the uncertainty.

The search: a coarse grid of ``coarse_steps`` steps of ``coarse_fraction`` of the strip's lines to
each side of the BIC's line (kept between the neighbouring breaks and the strip's ends by the least
gap), then half and quarter steps on both sides of the coarse minimum. Check points are not used.

Then every break is **tested** in the split model (:func:`break_tests`): the S model is adjusted
without it, and the rise of ``vTPv`` is the F test of the parameters the break adds (the test of
additional parameters of adjustment theory),

    F = (vTPv_without - vTPv_with) / (k * sigma0^2),   k = unknowns the break adds + 1 (its line),

against F(k, r) with ``r`` the redundancy. While a strip has more than one break, the one with the
largest p-value above ``test_level`` (5 %) is dropped and the strip's other breaks are placed again
(the BIC's piecewise-linear functions buy a spurious break for a bulge that the split model's
quadratic parts follow, and the spurious break pulls the others away: full-length vienna2000 seed 2).
A strip's last break is not dropped: that the strip needs more than SE is the BIC's verdict against
degree 0, and whether a polynomial does as well as a split is what ``compare`` (P against S) shows.
Every break keeps its ``f_statistic`` and ``p_value``.
"""
from __future__ import annotations

import logging
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace

from scipy import stats

from scangeo.adjustment.block import adjust_variant
from scangeo.adjustment.diagnosis.patterns import CHI2_95, BreakEstimate
from scangeo.adjustment.results import read_measurements
from scangeo.adjustment.variants import StripModels, Variant
from scangeo.errors import ScangeoError
from scangeo.io.project import Project

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class RefineOptions:
    """Options of :func:`refine_breaks`.

    coarse_fraction : the coarse grid's step, as a fraction of the strip's lines.
    coarse_steps : coarse steps to each side of the BIC's line.
    min_gap_fraction : least distance between breaks and from the strip's ends (fraction of its lines).
    position_degree : the split model's position degree per part (the S variants': 2).
    test_level : significance level of the F test that drops a strip's spurious breaks (None: no test).
    """

    coarse_fraction: float = 0.06
    coarse_steps: int = 3
    min_gap_fraction: float = 0.06
    position_degree: int = 2
    test_level: float | None = 0.05


DEFAULT_REFINE = RefineOptions()

#: ``cost(breaks per problem strip) -> (vTPv, sigma0, unknowns)``; ``(inf, nan, 0)`` when the adjustment fails.
CostFunction = Callable[[dict[str, tuple[float, ...]]], tuple[float, float, int]]


def s_model_cost(project_root, dtm_height_points: Sequence[str] = ("*",), position_degree: int = 2) -> CostFunction:
    """The cost function of the S model (the S2 variant's set-up) on the project.

    The project's files are read once; every probe starts its unknowns where the previous probe left
    them (the same answer in fewer iterations: the candidates differ by one break line).
    """
    project = Project.from_user_input(project_root)
    points, ground = read_measurements(project)
    start: dict = {}

    def cost(breaks: dict[str, tuple[float, ...]]) -> tuple[float, float, int]:
        strips = tuple(StripModels(s, position_degree=position_degree, breaks_lines=tuple(sorted(b)))
                       for s, b in breaks.items())
        v = Variant("diagnosis-S", "S", "split model probing a break line", strips=strips, dtm_heights=True,
                    dtm_height_points=tuple(dtm_height_points), snooping=False)
        try:
            _, adj = adjust_variant(project, v, points, ground, snooping=False, start=start)
        except ScangeoError as exc:  # a candidate the adjustment cannot solve is not a candidate
            log.info("break probe %s failed: %s", breaks, exc)
            return math.inf, math.nan, 0
        if not adj.solution.converged:
            return math.inf, math.nan, 0
        start.clear()
        start.update({b.key: b.values.copy() for b in adj.parameters})
        log.debug("break probe %s: %d iterations", breaks, len(adj.solution.iterations))
        st = adj.statistics
        return st.sigma0 ** 2 * st.redundancy, st.sigma0, sum(int(b.values.size) for b in adj.parameters)

    return cost


@dataclass
class Profile:
    """The evaluated lines of one break and their ``vTPv``."""

    lines: list[float]
    cost: list[float]
    sigma0: float

    def best(self) -> float:
        return self.lines[min(range(len(self.cost)), key=self.cost.__getitem__)]

    def interval(self) -> tuple[float, float]:
        """The lines with ``vTPv - min <= 3.84 sigma0^2``, interpolated between evaluated lines."""
        order = sorted(range(len(self.lines)), key=self.lines.__getitem__)
        x = [self.lines[i] for i in order]
        y = [self.cost[i] for i in order]
        i0 = min(range(len(y)), key=y.__getitem__)
        limit = y[i0] + CHI2_95 * (self.sigma0 ** 2 if math.isfinite(self.sigma0) else 1.0)
        ends = []
        for step in (-1, 1):
            i = i0
            while 0 <= i + step < len(x) and y[i + step] <= limit:
                i += step
            j = i + step
            if 0 <= j < len(x) and math.isfinite(y[j]) and y[j] > y[i]:
                ends.append(x[i] + (x[j] - x[i]) * (limit - y[i]) / (y[j] - y[i]))
            else:
                ends.append(x[i])
        return min(ends), max(ends)


def _probe_break(current: dict[str, list[float]], strip: str, j: int, bounds: tuple[float, float], step: float,
                 steps: int, cost: CostFunction) -> dict[float, tuple[float, float, int]]:
    """(vTPv, sigma0, unknowns) of break ``j`` of ``strip`` at the coarse lines and around the coarse minimum."""
    seen: dict[float, tuple[float, float, int]] = {}
    others = current[strip]

    def probe(line: float) -> None:
        line = float(round(min(max(line, bounds[0]), bounds[1])))
        if line not in seen:
            trial = {s: tuple(v) for s, v in current.items()}
            trial[strip] = tuple(sorted(others[:j] + [line] + others[j + 1:]))
            seen[line] = cost(trial)

    for i in range(-steps, steps + 1):
        probe(others[j] + i * step)
    best = min(seen, key=lambda x: seen[x][0])
    for f in (-0.5, -0.25, 0.25, 0.5):
        probe(best + f * step)
    return seen


def _place(b: BreakEstimate, current: dict[str, list[float]], n_lines: dict[str, int], cost: CostFunction,
           options: RefineOptions) -> tuple[BreakEstimate, Profile]:
    """Break ``b`` moved to its best line with the strip's other breaks (``current``) fixed; ``current`` updated."""
    strip = current[b.strip]
    j = strip.index(b.line) if b.line in strip else min(range(len(strip)), key=lambda i: abs(strip[i] - b.line))
    n = n_lines[b.strip]
    gap = options.min_gap_fraction * n
    lo = (max(x for x in strip if x < strip[j]) if any(x < strip[j] for x in strip) else 0.0) + gap
    hi = (min(x for x in strip if x > strip[j]) if any(x > strip[j] for x in strip) else n - 1.0) - gap
    if hi < lo:
        return b, Profile([b.line], [math.nan], math.nan)
    seen = _probe_break(current, b.strip, j, (lo, hi), options.coarse_fraction * n, options.coarse_steps, cost)
    lines = sorted(seen)
    finite = [x for x in lines if math.isfinite(seen[x][0])]
    if not finite:
        return b, Profile(lines, [seen[x][0] for x in lines], math.nan)
    best = min(finite, key=lambda x: seen[x][0])
    profile = Profile(finite, [seen[x][0] for x in finite], seen[best][1])
    low, high = profile.interval()
    strip[j] = best
    bic = b.bic_line if b.bic_line is not None else b.line
    return replace(b, line=best, low=min(low, best), high=max(high, best), bic_line=bic, method="S model"), profile


@dataclass(frozen=True)
class BreakTest:
    """The F test of one break in the split model (module docstring)."""

    strip: str
    line: float
    delta_vtpv: float
    added: int
    f_statistic: float
    p_value: float


def break_tests(current: Mapping[str, Sequence[float]], cost: CostFunction,
                strips: set[str] | None = None) -> list[BreakTest]:
    """Every break of ``current`` (of ``strips`` only, when given) tested against the split model without it
    (module docstring)."""
    v_full, sigma0, k_full = cost({s: tuple(v) for s, v in current.items()})
    if not (math.isfinite(v_full) and sigma0 > 0):
        return []
    redundancy = max(v_full / sigma0 ** 2, 1.0)
    out = []
    for s, lines in current.items():
        if strips is not None and s not in strips:
            continue
        for j, line in enumerate(lines):
            trial = {t: tuple(v) for t, v in current.items()}
            trial[s] = tuple(lines[:j]) + tuple(lines[j + 1:])
            v, _, k = cost(trial)
            if not math.isfinite(v):  # the model without the break cannot be adjusted: the break is needed
                out.append(BreakTest(s, float(line), math.inf, 1, math.inf, 0.0))
                continue
            added = max(k_full - k, 0) + 1
            f = max(v - v_full, 0.0) / (added * sigma0 ** 2)
            out.append(BreakTest(s, float(line), v - v_full, added, f, float(stats.f.sf(f, added, redundancy))))
    return out


def refine_breaks(breaks: Sequence[BreakEstimate], n_lines: dict[str, int], cost: CostFunction,
                  options: RefineOptions = RefineOptions(),
                  progress: Callable[[int, int], None] | None = None,
                  fixed: Mapping[str, Sequence[float]] | None = None) -> tuple[list[BreakEstimate], list[Profile]]:
    """Every break moved to the line where the S model fits best, with its profile interval, then tested
    (module docstring).

    ``breaks`` are the BIC's; the result keeps their order, with ``line``, ``low``, ``high`` from the
    profile, ``bic_line`` the BIC's line, ``method`` "S model", ``f_statistic`` and ``p_value`` from the
    test; breaks the test drops are left out. A break whose probes all fail keeps the BIC's estimate.
    ``fixed``: other strips' breaks, split in every probe but neither moved nor tested.
    """
    current: dict[str, list[float]] = {s: list(v) for s, v in (fixed or {}).items()}
    moving = {b.strip for b in breaks}
    if moving & set(current):
        raise ValueError(f"strips {sorted(moving & set(current))} are both fixed and refined")
    for b in breaks:
        current.setdefault(b.strip, []).append(b.line)
    out = list(breaks)
    profiles = []
    for k, b in enumerate(breaks):
        out[k], profile = _place(b, current, n_lines, cost, options)
        profiles.append(profile)
        if progress is not None:
            progress(k + 1, len(breaks))
    if options.test_level is None:
        return out, profiles
    while True:
        tests = break_tests(current, cost, moving)
        weak = [t for t in tests if len(current[t.strip]) > 1 and t.p_value > options.test_level]
        if not weak:
            break
        drop = max(weak, key=lambda t: t.p_value)
        log.info("break %s@%.0f dropped: F = %.2f, p = %.3f (the split model without it fits as well)",
                 drop.strip, drop.line, drop.f_statistic, drop.p_value)
        i = next(i for i, b in enumerate(out) if b.strip == drop.strip and b.line == drop.line)
        del out[i], profiles[i]
        current[drop.strip].remove(drop.line)
        for i, b in enumerate(out):  # the strip's other breaks placed again without the dropped one
            if b.strip == drop.strip:
                out[i], profiles[i] = _place(b, current, n_lines, cost, options)
    by_line = {(t.strip, t.line): t for t in tests}
    for i, b in enumerate(out):
        t = by_line.get((b.strip, b.line))
        if t is not None:
            out[i] = replace(b, f_statistic=t.f_statistic, p_value=t.p_value)
    return out, profiles


__all__ = ["DEFAULT_REFINE", "BreakTest", "CostFunction", "Profile", "RefineOptions", "refine_breaks", "s_model_cost",
           "break_tests"]
