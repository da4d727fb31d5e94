"""The adjustment as one call: solve, compute statistics, and snoop for blunders (Baarda).

Data snooping: after each solution, the observation unit holding the row with the largest ``|w|``
above the critical value (Baarda's w-test; 3.29 is alpha0 = 0.1 % two-sided) is removed from the
adjustment (all rows of the unit, e.g. line and pixel of one image measurement) and the adjustment
is solved again from the current values, until no w exceeds the critical value. Rows with a
redundancy number below ``MIN_REDUNDANCY`` are uncontrolled and never tested; pseudo-observations are
never tested, nor are groups that opt out (``snooped = False``: the GPS/IMU samples).

How the adjustment is solved again after a removal (``SnoopingOptions.method``):

- ``"update"`` (default): by a low-rank update of the last factorisation (``removal.py``): the new
  solution by Gauss-Newton steps with the updated inverse, the new redundancy numbers of the tested
  rows from the last selected inverse, no factorisation. When no w exceeds the critical value any
  more, the adjustment is solved and its statistics computed in full (factorisation, selected
  inversion) and tested again: the reported statistics are always those of a full solution, and a
  w that the full solution puts above the critical value is snooped as before. A removal that
  leaves an unknown undetermined (it needs regularisation) is solved in full at once.
- ``"linear"``: as ``"update"``, but the new solution after a removal is that of the current state's
  linear model (no linearisation: ``removal.py``, linear rounds); when no w exceeds the critical value
  any more, the nonlinear model's solution (the chord iteration through every removal since) is
  tested again, then the full solution as above. For nearly linear problems with many rounds (the
  laser's strip adjustment: planes and small corrections), where the linearisations were most of the
  time.
- ``"resolve"``: a full solution and selected inversion after every removal (the reference).
"""
from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from scangeo.errors import AdjustmentError
from scangeo.lsq.keys import PointKey
from scangeo.lsq.observations import ObservationGroup
from scangeo.lsq.parameters import Parameters
from scangeo.lsq.removal import RemovalUpdate
from scangeo.lsq.rounds import CANDIDATES, independent_units
from scangeo.lsq.separability import NOTE, examine_unit, point_rows, scaled_jacobian
from scangeo.lsq.solver import Solution, Solver, SolverOptions
from scangeo.lsq.statistics import Statistics
from scangeo.progress import ProgressCallback, no_progress, scaled

log = logging.getLogger(__name__)


#: How the adjustment is solved again after a removal (module docstring).
METHODS = ("update", "linear", "resolve")


@dataclass(frozen=True)
class SnoopingOptions:
    """Data snooping: ``critical_value`` of |w|, at most ``max_rejections`` units, ``per_round`` per
    re-solution (1 is Baarda's strategy; more is faster on large blocks with many blunders: the
    worst units of distinct points are removed together)."""

    enabled: bool = True
    critical_value: float = 3.29
    max_rejections: int = 1000
    per_round: int = 1
    #: with ``per_round`` > 1: only units whose w-tests and those of the units ranked above them cannot
    #: influence each other go in one round (``rounds.py``); False: the ``per_round`` worst of distinct points
    independent: bool = False
    method: str = "update"
    #: with ``method = "update"``: at most this many rows removed between full solutions (the update keeps
    #: a column per row for the tested rows only, not for every unknown: 96 strips of block24 remove about 80)
    max_update_rows: int = 256
    #: a blunder that cannot be told apart from another measurement's (``separability.py``) removes
    #: its whole point with a note instead of blaming one measurement
    separability: bool = True

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise AdjustmentError(f"snooping method must be one of {', '.join(map(repr, METHODS))}, "
                                  f"not {self.method!r}")


@dataclass(frozen=True)
class Rejection:
    """One observation unit removed by data snooping."""

    group: str
    id: str
    components: tuple[str, ...]
    w: float
    round: int
    #: False: a non-separable blunder, every measurement of the point removed (``note`` says why)
    separable: bool = True
    note: str = ""


@dataclass
class Adjustment:
    """Result of :func:`adjust`."""

    solution: Solution
    statistics: Statistics
    rejections: list[Rejection] = field(default_factory=list)
    snooping_rounds: int = 0
    #: full solutions (factorisation and selected inversion), the first included
    full_solutions: int = 1
    #: sigma0 of the first full solution, with every observation (before data snooping removed any): the
    #: same as an adjustment without snooping gives, without a second adjustment
    sigma0_first: float = float("nan")

    @property
    def parameters(self) -> Parameters:
        return self.solution.parameters


def _worst_units(groups: Sequence[ObservationGroup], active: list[np.ndarray], w_tests: list[np.ndarray],
                 crit: float, count: int) -> list[tuple[int, int, float]]:
    """Up to ``count`` (group index, unit, |w|) with the largest |w| above ``crit``, best first."""
    found: list[tuple[float, int, int]] = []
    for gi, (group, act, w) in enumerate(zip(groups, active, w_tests)):
        if group.kind != "observation" or not group.snooped:
            continue
        aw = np.where(act & np.isfinite(w), np.abs(w), 0.0)
        if not aw.size or aw.max() <= crit:
            continue
        units = group.row_unit
        best = np.zeros(units.max() + 1)
        np.maximum.at(best, units, aw)
        for u in np.argsort(best)[::-1][:count]:
            if best[u] > crit:
                found.append((float(best[u]), gi, int(u)))
    found.sort(reverse=True)
    out: list[tuple[int, int, float]] = []
    points: set[str] = set()
    for w_max, gi, u in found:  # one unit per point and round: a point's other rays share its blunder's smear
        pid = str(groups[gi].ids[groups[gi].row_unit == u][0])
        if pid not in points:
            points.add(pid)
            out.append((gi, u, w_max))
        if len(out) == count:
            break
    return out


def _independent_units(solution: Solution, stats: Statistics, update: RemovalUpdate | None,
                       active: list[np.ndarray], w_tests: list[np.ndarray], crit: float,
                       count: int) -> list[tuple[int, int, float]]:
    """Up to ``count`` units above ``crit`` that can go in one round (``rounds.independent_units``)."""
    candidates = _worst_units(solution.groups, active, w_tests, crit, CANDIDATES)
    if len(candidates) < 2:
        return candidates
    groups, slices = solution.groups, solution.system.row_slices
    act = np.concatenate(active)
    if update is None:
        Js, leverage, correction = scaled_jacobian(solution), stats.leverages, None
    else:
        Js, leverage, correction = update.scaled_jacobian, update.leverages(), update.coupling_correction
    w = np.concatenate(w_tests)
    tested = _tested_rows(solution) & act & np.isfinite(w)

    def rows_of(point: str) -> np.ndarray:
        return point_rows(groups, slices, tested, point)

    return independent_units(candidates, groups, slices, rows_of, Js, w, leverage,
                             stats.inverse.partial_solver(), correction, count)


def _tested_rows(solution: Solution) -> np.ndarray:
    """Mask of the stacked rows that data snooping tests."""
    return np.concatenate([np.full(g.n_rows, g.kind == "observation" and g.snooped) for g in solution.groups])


def adjust(parameters: Parameters, groups: Sequence[ObservationGroup],
           solver_options: SolverOptions = SolverOptions(),  # noqa: B008 (frozen options)
           snooping: SnoopingOptions = SnoopingOptions(),
           callback: ProgressCallback = no_progress, point_key: PointKey | None = None) -> Adjustment:
    """Adjust ``parameters`` to ``groups``; with data snooping unless disabled.

    Never raises on a rank defect: undetermined unknowns are regularised and listed in
    ``solution.regularisation``. ``point_key`` maps an observation id to the key of its point
    (``Ground`` of the line-scanner block): a point whose measurements data snooping removed as a
    non-separable blunder and that is regularised then says so.
    """
    solver = Solver(parameters, groups, solver_options, scaled(callback, 0.0, 0.7))
    solution = solver.solve()
    stats = Statistics(solution)
    sigma0_first = float(stats.sigma0)
    full = 1
    update: RemovalUpdate | None = None    # removals since the last full solution, by low-rank update
    rejections: list[Rejection] = []
    rounds = 0
    while snooping.enabled:
        active = solution.active if update is None else update.active
        worst = []
        if len(rejections) < snooping.max_rejections:
            w_tests = stats.w_tests() if update is None else update.w_tests()
            count = min(snooping.per_round, snooping.max_rejections - len(rejections))
            if snooping.independent and count > 1:
                worst = _independent_units(solution, stats, update, active, w_tests, snooping.critical_value, count)
            else:
                worst = _worst_units(solution.groups, active, w_tests, snooping.critical_value, count)
        if not worst:
            if update is None or update.removed.size == 0:
                break
            if not update.polished and update.polish():
                continue  # the w-tests again, at the nonlinear model's solution
            # no w above the critical value with the updated statistics: confirm with a full solution
            solver.parameters.set_values(update.values)
            active = update.active
            del solution, stats, update  # the last factor, selected inverse and update go before the next
            solution, update = solver.solve(active), None
            stats = Statistics(solution)
            full += 1
            continue
        rounds += 1
        row_parts: list[np.ndarray] = []
        for gi, unit, w in worst:
            group = solution.groups[gi]
            sel = group.row_unit == unit
            comps = tuple(str(c) for c in group.components[sel])
            verdict = examine_unit(solution, stats, update, gi, unit) if snooping.separability else None
            if verdict is None or verdict.separable:
                row_parts.append(solution.system.row_slices[gi].start + np.flatnonzero(sel))
                rejections.append(Rejection(group.name, str(group.ids[sel][0]), comps, w, rounds))
            else:  # the whole point: which of its measurements holds the blunder cannot be told
                row_parts.append(verdict.rows)
                note = f"{NOTE}: {verdict.reason} ({'; '.join(verdict.partners)})"
                rejections.append(Rejection(group.name, str(group.ids[sel][0]), comps, w, rounds, False, note))
            log.info("data snooping round %d: rejected %s %s (|w| = %.2f)", rounds, group.name, group.ids[sel][0], w)
        rows = np.concatenate(row_parts)
        callback(
            0.7 + 0.3 * min(len(rejections) / max(snooping.max_rejections, 1), 1.0),
            1.0,
            f"data snooping: {len(rejections)} rejected",
        )
        if snooping.method in ("update", "linear"):
            if update is None:
                update = RemovalUpdate(solver, solution, stats.leverages, _tested_rows(solution))
            if update.remove(rows, snooping.max_update_rows, linear=snooping.method == "linear"):
                continue
            solver.parameters.set_values(update.values)  # refactorise from the latest values
            active, update = update.active, None
        else:
            active = [a.copy() for a in solution.active]
            for a, sl in zip(active, solution.system.row_slices):
                inside = rows[(rows >= sl.start) & (rows < sl.stop)]
                a[inside - sl.start] = False
        del solution, stats  # the last factor and selected inverse go before the next factorisation
        solution = solver.solve(active)
        stats = Statistics(solution)
        full += 1
    callback(1.0, 1.0, "adjustment done")
    # say why their points are regularised
    hidden = {point_key(r.id) for r in rejections if not r.separable} if point_key is not None else set()
    solution.regularisation = [replace(n, reason=f"every measurement of the point removed ({NOTE})")
                               if n.key in hidden else n
                               for n in solution.regularisation]
    return Adjustment(solution, stats, rejections, rounds, full, sigma0_first)
