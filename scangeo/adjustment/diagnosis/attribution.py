"""How sure the diagnosis is of which strip drifts: the runner-up attribution and its criterion difference.

A tie point's DTM misclosure sees the error functions of every strip that measured it, so a drift
in the overlap of two strips is explained by either, and the block's control and the other overlap
of each strip decide between them. When the cleaning has set aside some of that control, the two
explanations can come close. :func:`~.patterns.select_breaks` chooses the one with the least BIC;
every alternative is scored under the same serial correlation (:func:`~.patterns.alternatives`):

* **moved**: the problem strip's functions (its drift and breaks) given to a neighbour instead, the
  breaks placed where the neighbour sees the same ground or where a search over its lines puts them,
  whichever fits better, the problem strip held constant;
* **merged**: the functions of the strips on both sides of a strip given to it alone;
* **dropped**: the problem strip held constant (the others keep theirs; with one problem strip, no
  problem strip at all);
* **shared**: a neighbour gets breaks too (the drift split between the two strips); and without a
  problem strip, **breaks**: the best model with one, on each of the three strips that score best
  (:func:`no_problem_alternatives`).

The **runner-up** of a problem strip is its closest alternative attribution, the **criterion
difference** ``dBIC = BIC(alternative) - BIC(chosen)``: twice the log of the Bayes factor between the
two (BIC's approximation, equal prior odds). Whether it casts doubt depends on what is compared:

* a **competing** attribution (moved, merged, dropped: no more searched breaks than the chosen one)
  makes the attribution **ambiguous** when ``dBIC < AMBIGUOUS_BIC`` (10). Below 10 the chosen
  attribution is less than "very strong" evidence on Kass and Raftery's scale (a Bayes factor below
  e^5, about 150:1), and this BIC overstates its certainty: it treats the DTM's correlated height
  error as independent beyond the lag-1 correction, and the misclosures as exact functions of two
  strips' errors. Measured on full-length vienna2000 with 20 blunders (docs/adjustment.md,
  "Attribution"): right attributions' competing runner-ups lie far above 10.
* a **richer** alternative (shared, breaks: more strips with searched breaks) only when it beats the
  chosen model by more than the best-placed breaks beat "none" on drift-free blocks
  (``dBIC < RICHER_BIC = -ADOPT_BIC``): its criterion is the least over every placement of its extra
  breaks, optimistic by the change-point effect, so a richer model that wins by less is what noise gives.

**Adoption.** An alternative that beats the search's own model by more than its noise is a model the
search missed (its pair step is gated by the serial correlation of what the current model leaves, which
a missed drift inflates), and it replaces it (:func:`adopt`): by the BIC, ``dBIC < -ADOPT_BIC`` (30);
the search's last steps then go on from it and its attribution is checked again. ``ADOPT_BIC`` is
calibrated on drift-free blocks, where every such gain is the change-point effect's
(docs/adjustment.md, "Adoption"): the best-placed breaks beat "none" by at most 21.0 there (the ``small``
preset; once, seed 7, the search's own by 32.2, which the split model then dropped; on vienna2000 they
never did), and on the
thinned vienna2000 blocks where the search missed strip 02's drift it beat "none" by 36.5-80.3. A
competing attribution is adopted when the split model's criterion prefers it by more than
``AMBIGUOUS_BIC`` (:func:`preferred_by_split_model`): it has no more searched breaks, so no change-point
optimism, and the split model sees the DTM heights and the control that the pattern fit sees only
through SE's misclosures.

Every plausible attribution (an alternative that casts doubt) gets its breaks placed by the split
model as the chosen one's are (:func:`~.diagnose.place_breaks`), and the comparison builds its
variants beside the chosen one's (:mod:`scangeo.strategy.default_variants`): the evidence of the
cross-validation and the check points then decides (:mod:`scangeo.strategy.evidence`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from scangeo.adjustment.diagnosis.local_fit import MIN_REDUNDANCY, BlockIndex, CurrentFit, StripProbe
from scangeo.adjustment.diagnosis.patterns import (
    Alternative,
    Candidates,
    Fit,
    PatternData,
    SelectionOptions,
    evaluate,
    polish,
    refine,
    residual_correlation,
)
from scangeo.blas import one_thread

#: the criterion difference below which a competing attribution makes the chosen one ambiguous (module docstring)
AMBIGUOUS_BIC = 10.0
#: the BIC difference below ``-ADOPT_BIC`` by which an alternative replaces the search's model (:func:`adopt`):
#: calibrated on drift-free blocks (module docstring)
ADOPT_BIC = 30.0
#: the criterion difference below which a richer alternative casts doubt: it must beat the chosen model by
#: more than the best-placed breaks do on drift-free blocks (then it is adopted, unless a model of its shape
#: was adopted before)
RICHER_BIC = -ADOPT_BIC
#: the alternatives with no more searched breaks than the chosen attribution
COMPETING = ("moved", "merged", "dropped")


@dataclass
class Attribution:
    """One way to explain the drift: which strips carry breaks (and at which lines), and its criterion.

    ``kind``: ``moved`` (the problem strip's functions given to ``other``), ``merged`` (given to
    ``other`` with those of the strips on its other side), ``dropped`` (the strip held constant),
    ``shared`` (``other`` gets breaks too) or ``breaks`` (a problem strip where the diagnosis found none).
    ``breaks``: per strip of the attribution, its break lines (the BIC's; after
    :func:`place_breaks`, the split model's). ``delta_bic``: its BIC minus the chosen one's.
    """

    kind: str
    strip: str
    other: str | None
    breaks: dict[str, tuple[float, ...]]
    bic: float
    delta_bic: float
    placed: bool = False
    #: the split model's criterion difference (:func:`split_model_difference`; None: not computed)
    delta_split: float | None = None
    #: its pattern fit (what :func:`adopt` adopts; None: not kept)
    fit: Fit | None = field(default=None, repr=False, compare=False)

    @property
    def doubt(self) -> bool:
        """Whether it casts doubt on the chosen attribution: its BIC difference below its bar, or (a
        competing one) the split model's below :data:`AMBIGUOUS_BIC`."""
        if self.delta_bic < self.bar:
            return True
        return self.competing and self.delta_split is not None and self.delta_split < AMBIGUOUS_BIC

    @property
    def strips(self) -> tuple[str, ...]:
        return tuple(self.breaks)

    @property
    def competing(self) -> bool:
        """Whether it has no more searched breaks than the chosen attribution (module docstring)."""
        return self.kind in COMPETING

    @property
    def bar(self) -> float:
        """The criterion difference below which it casts doubt on the chosen attribution."""
        return AMBIGUOUS_BIC if self.competing else RICHER_BIC

    @property
    def label(self) -> str:
        """The attribution's strips joined by ``-`` (a suffix of its variants' names, e.g. ``S4-03``)."""
        return "-".join(self.breaks)

    def describe(self) -> str:
        lines = "; ".join(f"strip {s} breaks at {', '.join(f'{b:.0f}' for b in v) or 'none'}"
                          for s, v in self.breaks.items())
        what = {"moved": f"the drift on strip {self.other} instead of {self.strip}",
                "merged": f"the drift of strip {self.strip} and its neighbours' on strip {self.other} alone",
                "dropped": f"no drift on strip {self.strip}",
                "shared": f"the drift shared by strips {self.strip} and {self.other}",
                "breaks": f"a problem strip {self.strip}"}.get(self.kind, f"strip {self.strip}")
        split = f", split model {self.delta_split:+.1f}" if self.delta_split is not None else ""
        return f"{what} ({lines or 'no problem strip'}), BIC {self.delta_bic:+.1f}{split}"

    def as_dict(self) -> dict:
        return {"kind": self.kind, "strip": self.strip, "other": self.other,
                "breaks": {s: [round(b, 1) for b in v] for s, v in self.breaks.items()},
                "bic": round(self.bic, 3), "delta_bic": round(self.delta_bic, 3), "placed": self.placed,
                "delta_split": None if self.delta_split is None else round(self.delta_split, 3)}


@dataclass
class AttributionCheck:
    """The attribution of one problem strip (or of none) against its alternatives.

    ``strip``: the problem strip (None: the diagnosis found none). ``runner_up``: the closest competing
    alternative, ``richer``: the closest richer one (None: none). ``plausible``: every alternative that
    casts doubt (module docstring; :attr:`Attribution.doubt`). ``threshold``: the competing
    alternatives' bar.
    """

    strip: str | None
    runner_up: Attribution | None
    richer: Attribution | None = None
    plausible: list[Attribution] = field(default_factory=list)
    threshold: float = AMBIGUOUS_BIC
    #: every alternative, the closest first
    alternatives: list[Attribution] = field(default_factory=list)

    def update(self) -> None:
        """``plausible`` again from the alternatives' criteria (after :func:`split_model_difference`)."""
        self.plausible = [a for a in self.alternatives if a.doubt]

    @property
    def ambiguous(self) -> bool:
        return bool(self.plausible)

    def sentence(self) -> str:
        """One line for the summary: the runner-up, the difference and the verdict."""
        who = f"strip {self.strip}" if self.strip is not None else "no problem strip"
        parts = []
        if self.runner_up is not None:
            parts.append(f"runner-up {self.runner_up.describe()}")
        if self.richer is not None:
            parts.append(f"{'richer alternative' if parts else 'runner-up'} {self.richer.describe()}")
        if not parts:
            return (f"attribution of {who}: no alternative (no neighbour shares its tie points, or every "
                    f"alternative leaves a channel fewer than {MIN_REDUNDANCY} residual degrees of freedom)")
        verdict = (f"AMBIGUOUS (a competing attribution within {self.threshold:g}, by the BIC or the split model, "
                   f"or a richer model more than {-RICHER_BIC:g} better): variants are built for each" if self.ambiguous
                   else f"clear (competing attributions at least {self.threshold:g} worse, richer ones not "
                        f"{-RICHER_BIC:g} better)")
        return f"attribution of {who}: {'; '.join(parts)}: {verdict}"

    def as_dict(self) -> dict:
        return {"strip": self.strip, "ambiguous": self.ambiguous, "threshold": self.threshold,
                "richer_threshold": RICHER_BIC,
                "runner_up": None if self.runner_up is None else self.runner_up.as_dict(),
                "richer": None if self.richer is None else self.richer.as_dict(),
                "plausible": [a.as_dict() for a in self.plausible]}


def _check(strip: str | None, found: list[Attribution], threshold: float) -> AttributionCheck:
    # a model that saturates a channel is not scored (local_fit.saturated): no alternative
    found = sorted((a for a in found if math.isfinite(a.delta_bic)), key=lambda a: a.delta_bic)
    competing = [a for a in found if a.competing]
    richer = [a for a in found if not a.competing]
    check = AttributionCheck(strip, competing[0] if competing else None, richer[0] if richer else None, [],
                             threshold, found)
    check.update()
    return check


def _breaks_of(data: PatternData, fit: Fit, strips) -> dict[str, tuple[float, ...]]:
    return {data.strips[s]: tuple(round(float(b), 1) for b in fit.breaks[s]) for s in strips}


def _problem(fit: Fit) -> list[int]:
    return [s for s, b in enumerate(fit.breaks) if b]


@one_thread()  # the break selection's small designs (scangeo/blas.py)
def attribution_checks(data: PatternData, fit: Fit, options: SelectionOptions | None = None,
                       threshold: float = AMBIGUOUS_BIC) -> list[AttributionCheck]:
    """Per problem strip of ``fit`` (a strip with breaks), its runner-ups and the plausible alternatives;
    without one, the best model with a problem strip (module docstring)."""
    options = options or SelectionOptions()
    problems = _problem(fit)
    if not problems:
        return [_check(None, no_problem_alternatives(data, fit, options), threshold)]
    alts: list[Alternative] = fit.alternatives
    out = []
    for s in problems:
        mine = []
        for a in alts:
            if a.strip != s and s not in a.also:
                continue
            strips = sorted(set(_problem(a.fit)) | ({a.other} if a.kind != "dropped" else set()))
            mine.append(Attribution(a.kind, data.strips[s],
                                    None if a.kind == "dropped" else data.strips[a.other],
                                    _breaks_of(data, a.fit, strips), float(a.fit.bic), float(a.fit.bic - fit.bic),
                                    fit=a.fit))
        out.append(_check(data.strips[s], mine, threshold))
    return out


#: without a problem strip, the strips whose best model with breaks is scored in full (the best by the
#: local scores): more than one, since the best-scoring strip can be the neighbour of the drifting one
#: (vienna2000 with half the control and tie points, seeds 117 and 124: breaks on strip 03 beat "none"
#: by 38-53, and only 03's variants were built while strip 02 drifted)
NO_PROBLEM_STRIPS = 3


@one_thread()  # the break selection's small designs (scangeo/blas.py)
def no_problem_alternatives(data: PatternData, fit: Fit, options: SelectionOptions | None = None,
                            strips: int = NO_PROBLEM_STRIPS) -> list[Attribution]:
    """Per strip, the best model with breaks on it (one or two, on ``options.pair_candidates`` lines, then
    moved to their best lines) against ``fit`` (which has none), both under the serial correlation of what
    that model leaves; for the ``strips`` strips whose best local score is least, best first."""
    options = options or SelectionOptions()
    index = BlockIndex(data)
    current = CurrentFit(index, fit.breaks, options.degree, fit.constant)
    n_breaks = sum(len(b) for b in fit.breaks)
    per_strip: list[tuple[float, int, Candidates]] = []
    for s in range(len(data.strips)):
        candidates = Candidates(data, [list(b) for b in fit.breaks], None, options.degree)
        n = data.n_lines[s]
        gap = options.min_gap_fraction * n
        probe = StripProbe(current, s)
        grid = [float(b) for b in np.linspace(0, n - 1, max(options.pair_candidates, 2) + 2)[1:-1]
                if index.feasible(s, (), float(b), gap, options.min_rows)]
        trials = [[b] for b in grid] + [[a, b] for i, a in enumerate(grid) for b in grid[i + 1:]
                                        if index.feasible(s, (a,), b, gap, options.min_rows)]
        for trial in trials:
            r = probe.bic(trial, False, None, n_breaks + len(trial))
            candidates.add(None if r is None else r[0], set(fit.constant) - {s}, s, trial)
        if candidates.models:
            best = candidates.best()
            per_strip.append((candidates.score(best)[0], best, candidates))
    out = []
    for _, i, candidates in sorted(per_strip, key=lambda t: t[0])[:strips]:
        s = candidates.models[i][0]
        constant = candidates.models[i][3]
        breaks = refine(data, candidates.breaks(i), None, options, constant, index=index)
        plain = evaluate(data, breaks, None, options.degree, constant)
        rho = residual_correlation(data, plain) if options.serial_correlation else {}
        richer = evaluate(data, breaks, rho, options.degree, constant)
        mine = evaluate(data, fit.breaks, rho, options.degree, fit.constant)
        out.append(Attribution("breaks", data.strips[s], None, _breaks_of(data, richer, [s]), float(richer.bic),
                               float(richer.bic - mine.bic), fit=richer))
    return sorted(out, key=lambda a: a.delta_bic)


def adopt(data: PatternData, fit: Fit, checks: list[AttributionCheck], options: SelectionOptions | None = None,
          threshold: float = ADOPT_BIC) -> tuple[Fit, list[AttributionCheck], list[Attribution]]:
    """The search's model replaced by an alternative that beats it beyond the adoption threshold (module docstring).

    While an alternative of ``checks`` has a BIC more than ``threshold`` below the current model's, the one
    with the least is adopted: the search's last steps go on from it (:func:`~.patterns.polish`: its breaks
    moved to their best lines, its strips' functions moved to a neighbour where that fits better, under its
    own serial correlation) and its attributions are checked again. Returns the model, its checks and the
    alternatives adopted in turn (empty: the search's model stands), each with its BIC difference to the
    model it replaced. A model of a shape seen before (the same strips constant, as many breaks on each) is
    not adopted again; at most one adoption per strip.
    """
    options = options or SelectionOptions()
    adopted: list[Attribution] = []
    seen = {_signature(fit)}
    for _ in range(len(data.strips)):
        better = [a for c in checks for a in c.alternatives
                  if a.fit is not None and a.delta_bic < -threshold and _signature(a.fit) not in seen]
        if not better:
            break
        best = min(better, key=lambda a: a.delta_bic)
        assert best.fit is not None
        fit = polish(data, best.fit.breaks, best.fit.rho, options, best.fit.constant)
        seen |= {_signature(best.fit), _signature(fit)}
        checks = attribution_checks(data, fit, options, checks[0].threshold if checks else AMBIGUOUS_BIC)
        adopted.append(best)
    return fit, checks, adopted


def preferred_by_split_model(checks: list[AttributionCheck], threshold: float = AMBIGUOUS_BIC) -> Attribution | None:
    """The competing attribution the split model prefers to the chosen one by more than ``threshold``
    (``delta_split < -threshold``; the least), None when there is none (module docstring)."""
    better = [a for c in checks for a in c.alternatives
              if a.competing and a.fit is not None and a.delta_split is not None and a.delta_split < -threshold]
    return min(better, key=lambda a: a.delta_split or 0.0) if better else None


def _signature(fit: Fit) -> tuple:
    """The model's shape: which strips are constant, and how many breaks each strip has."""
    return tuple(fit.constant), tuple(len(b) for b in fit.breaks)


#: competing alternatives whose BIC difference exceeds this are not asked of the split model (far beyond doubt)
SPLIT_PREFILTER = 100.0


def split_model_difference(cost, chosen: dict[str, tuple[float, ...]], other: dict[str, tuple[float, ...]]
                           ) -> float | None:
    """The split model's criterion difference of another attribution against the chosen one.

    ``cost`` is :func:`~.refine.s_model_cost`'s function (``vTPv``, ``sigma0``, unknowns per attribution);
    both are adjusted at their BIC's lines, and ``C = vTPv / sigma0^2 + u ln n`` with the chosen model's
    ``sigma0`` and observation count ``n``: for attributions with as many unknowns (moved) the
    difference is the likelihood-ratio statistic ``-2 ln LR`` of the adjustment itself, on the DTM
    heights and control the pattern fit only sees through SE's misclosures. None when either adjustment
    fails.
    """
    v0, s0, u0 = cost(chosen)
    v1, _, u1 = cost(other)
    if not (math.isfinite(v0) and math.isfinite(v1) and s0 > 0):
        return None
    n = v0 / s0 ** 2 + u0
    return float((v1 - v0) / s0 ** 2 + (u1 - u0) * math.log(max(n, 2.0)))


__all__ = ["ADOPT_BIC", "AMBIGUOUS_BIC", "COMPETING", "RICHER_BIC", "SPLIT_PREFILTER", "Attribution",
           "AttributionCheck", "adopt", "attribution_checks", "no_problem_alternatives", "preferred_by_split_model",
           "split_model_difference"]
