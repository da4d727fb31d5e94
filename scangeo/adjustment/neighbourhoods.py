"""Strip neighbourhoods of a block's unknowns: the observations whose blunders the external
reliability evaluates for a strip.

A strip's unknowns are the columns its own observation groups (the GPS/IMU samples of its flight line
and its image measurements) touch: its flight line's spline knots, the corrections of its GPS/IMU
models, the ground points it measures. Two strips are neighbours when they share such a column that
is not **global**: a column that more than ``GLOBAL_STRIPS`` strips touch (a boresight, a block-wide
GPS/IMU model) links no two strips. The neighbourhood of strip ``s`` at radius ``r``
(:class:`~scangeo.lsq.probe_effects.Neighbourhood`): ``near``, the non-global columns of the strips at
most ``r`` steps away; the observations that touch them are evaluated for the strip's probe.
Strips of one window (a strip and the strips within ``core`` steps not yet served) share one
neighbourhood, and so one solve.
"""
from __future__ import annotations

from collections import deque

import numpy as np

from scangeo.lsq.probe_effects import Neighbourhood
from scangeo.lsq.solver import Solution

#: A column touched by the groups of more strips than this is global (links no two strips).
GLOBAL_STRIPS = 4
#: Default radius (strip steps around a window) of the rows evaluated for its strips' probes.
RADIUS = 2
#: Default half width (strip steps) of a window of strips that share one solve.
CORE = 2


def strip_columns(solution: Solution) -> dict[str, np.ndarray]:
    """Per strip, the columns its own observation groups touch: those with a ``strip`` attribute (its image
    measurements) and those of its flight line (a ``flight_line`` attribute without a strip: the GPS/IMU
    samples, shared by every strip on the flight line; a flight line whose strips measure nothing counts
    as a strip of its id)."""
    J = solution.system.jacobian
    on_line: dict[str, list[str]] = {}
    for g in solution.groups:
        sid, line = getattr(g, "strip", None), getattr(g, "flight_line", None)
        if sid is not None and line is not None and str(sid) not in on_line.setdefault(str(line), []):
            on_line[str(line)].append(str(sid))
    out: dict[str, list[np.ndarray]] = {}
    for g, sl in zip(solution.groups, solution.system.row_slices):
        sid, line = getattr(g, "strip", None), getattr(g, "flight_line", None)
        owners = [str(sid)] if sid is not None else on_line.get(str(line), [str(line)]) if line is not None else []
        if not owners:
            continue
        cols = np.unique(J[sl].indices)
        for owner in owners:
            out.setdefault(owner, []).append(cols)
    return {sid: np.unique(np.concatenate(parts)) for sid, parts in out.items()}


def _distances(adjacent: dict[str, set[str]], start: set[str], limit: int) -> dict[str, int]:
    """Strip steps from the nearest of ``start``, up to ``limit``."""
    dist = {s: 0 for s in start}
    queue = deque(start)
    while queue:
        a = queue.popleft()
        if dist[a] >= limit:
            continue
        for b in sorted(adjacent[a]):
            if b not in dist:
                dist[b] = dist[a] + 1
                queue.append(b)
    return dist


def strip_neighbourhoods(solution: Solution, radius: int = RADIUS, core: int = CORE) -> dict[str, Neighbourhood]:
    """Per strip, its :class:`Neighbourhood` (see the module docstring); strips of one window share
    the same object. A window whose neighbourhood holds every strip gets none (every row is
    evaluated)."""
    cols = strip_columns(solution)
    count = np.zeros(solution.layout.n, dtype=np.int64)
    for c in cols.values():
        count[c] += 1
    is_global = count > GLOBAL_STRIPS
    owners: dict[int, list[str]] = {}
    for sid, c in cols.items():
        for col in c[~is_global[c] & (count[c] > 1)]:
            owners.setdefault(int(col), []).append(sid)
    adjacent: dict[str, set[str]] = {sid: set() for sid in cols}
    for sids in owners.values():
        for a in sids:
            adjacent[a].update(b for b in sids if b != a)
    out: dict[str, Neighbourhood] = {}
    served: set[str] = set()
    for sid in cols:   # windows: a strip not yet served and the unserved strips within `core` steps
        if sid in served:
            continue
        window = {t for t in _distances(adjacent, {sid}, core) if t not in served}
        served |= window
        dist = _distances(adjacent, window, radius)
        if len(dist) == len(cols):
            continue
        near = np.unique(np.concatenate([cols[t] for t in dist]))
        hood = Neighbourhood(near[~is_global[near]])
        for t in window:
            out[t] = hood
    return out


__all__ = ["CORE", "GLOBAL_STRIPS", "RADIUS", "strip_columns", "strip_neighbourhoods"]
