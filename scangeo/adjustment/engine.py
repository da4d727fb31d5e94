"""The adjustment as one call: solve, compute statistics, and snoop for blunders (Baarda).

Data snooping: after each solution, the observation unit holding the row with the largest ``|w|``
above the critical value (Baarda's w-test; 3.29 is alpha0 = 0.1 % two-sided) is removed from the
adjustment (all rows of the unit, e.g. line and pixel of one image measurement) and the adjustment
is solved again from the current values, until no w exceeds the critical value. Rows with a
redundancy number below ``MIN_REDUNDANCY`` are uncontrolled and never tested; pseudo-observations are
never tested, nor are groups that opt out (``snooped = False``: the GPS/IMU samples).
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from scangeo.adjustment.observations import ObservationGroup
from scangeo.adjustment.parameters import Parameters
from scangeo.adjustment.solver import Solution, Solver, SolverOptions
from scangeo.adjustment.statistics import Statistics
from scangeo.progress import ProgressCallback, no_progress, scaled

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class SnoopingOptions:
    """Data snooping: ``critical_value`` of |w|, at most ``max_rejections`` units, ``per_round`` per
    re-solution (1 is Baarda's strategy; more is faster on large blocks with many blunders: the
    worst units of distinct points are removed together)."""

    enabled: bool = True
    critical_value: float = 3.29
    max_rejections: int = 1000
    per_round: int = 1


@dataclass(frozen=True)
class Rejection:
    """One observation unit removed by data snooping."""

    group: str
    id: str
    components: tuple[str, ...]
    w: float
    round: int


@dataclass
class Adjustment:
    """Result of :func:`adjust`."""

    solution: Solution
    statistics: Statistics
    rejections: list[Rejection] = field(default_factory=list)
    snooping_rounds: int = 0

    @property
    def parameters(self) -> Parameters:
        return self.solution.parameters


def _worst_units(stats: Statistics, crit: float, count: int) -> list[tuple[int, int, float]]:
    """Up to ``count`` (group index, unit, |w|) with the largest |w| above ``crit``, best first."""
    sol = stats.solution
    found: list[tuple[float, int, int]] = []
    for gi, (group, act, w) in enumerate(zip(sol.groups, sol.active, stats.w_tests())):
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
    out, points = [], set()
    for w, gi, u in found:  # one unit per point and round: a point's other rays share its blunder's smear
        pid = str(sol.groups[gi].ids[sol.groups[gi].row_unit == u][0])
        if pid not in points:
            points.add(pid)
            out.append((gi, u, w))
        if len(out) == count:
            break
    return out


def adjust(parameters: Parameters, groups: Sequence[ObservationGroup],
           solver_options: SolverOptions = SolverOptions(), snooping: SnoopingOptions = SnoopingOptions(),
           callback: ProgressCallback = no_progress) -> Adjustment:
    """Adjust ``parameters`` to ``groups``; with data snooping unless disabled.

    Never raises on a rank defect: undetermined unknowns are regularised and listed in
    ``solution.regularisation``.
    """
    solver = Solver(parameters, groups, solver_options, scaled(callback, 0.0, 0.7))
    solution = solver.solve()
    stats = Statistics(solution)
    rejections: list[Rejection] = []
    rounds = 0
    while snooping.enabled and len(rejections) < snooping.max_rejections:
        worst = _worst_units(stats, snooping.critical_value,
                             min(snooping.per_round, snooping.max_rejections - len(rejections)))
        if not worst:
            break
        rounds += 1
        active = [a.copy() for a in solution.active]
        for gi, unit, w in worst:
            group = solution.groups[gi]
            rows = group.row_unit == unit
            active[gi][rows] = False
            rejections.append(Rejection(group.name, str(group.ids[rows][0]),
                                        tuple(str(c) for c in group.components[rows]), w, rounds))
            log.info("data snooping round %d: rejected %s %s (|w| = %.2f)", rounds, group.name,
                     group.ids[rows][0], w)
        callback(0.7 + 0.3 * min(len(rejections) / max(snooping.max_rejections, 1), 1.0), 1.0,
                 f"data snooping: {len(rejections)} rejected")
        solution = solver.solve(active)
        stats = Statistics(solution)
    callback(1.0, 1.0, "adjustment done")
    return Adjustment(solution, stats, rejections, rounds)
