"""Reliability of an adjusted variant: per observation, per point and per strip and kind of point.

:func:`variant_reliability` computes the figures of :mod:`scangeo.lsq.reliability` for a
:class:`~scangeo.adjustment.results.VariantResult`, with the strips' ground positions probed on a
grid of image positions (:func:`strip_probes`), and gives every observation row a **status**:

- ``verified``: tested by data snooping and passed, redundancy number at least ``MIN_REDUNDANCY``;
- ``uncontrolled``: redundancy number below ``MIN_REDUNDANCY`` (r = 0): a blunder in it cannot be
  detected, whatever its size; never shown as verified;
- ``rejected``: removed by data snooping (the blunder was separable: this measurement holds it);
- ``not separable``: removed with every other measurement of its point, because the adjustment
  cannot tell which of them holds the blunder;
- ``failed``: left in the adjustment with ``|w|`` above the critical value (snooping disabled or at
  its limit);
- ``untested``: GPS/IMU samples (not snooped); ``pseudo``: pseudo-observations; ``check``: check
  point measurements (outside the adjustment; their MDB is that of their own test, ``delta0 sigma``).

Written to ``PROJECT/results/NAME/``: ``reliability.csv`` (one row per observation unit, with the
point's adjusted map position, for maps) and ``reliability.json`` (summary per strip and kind, the
non-separable points, the weakest strip positions). Formats in docs/formats.md.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from scangeo.adjustment.keys import Ground
from scangeo.adjustment.neighbourhoods import RADIUS, strip_neighbourhoods
from scangeo.adjustment.results import VariantResult
from scangeo.adjustment.sensitivity import ground_sensitivity, image_grid
from scangeo.atomic import write_csv, write_text
from scangeo.lsq.reliability import OrientationProbe, Reliability, compute_reliability, delta0
from scangeo.lsq.statistics import MIN_REDUNDANCY

#: Per strip, the probe grid of image positions: lines x pixels.
PROBE_GRID = (9, 5)
KINDS = ("control", "planimetric", "height", "tie", "check", "dtm", "gpsimu")


@dataclass
class VariantReliability:
    """The reliability of one variant, per row of its observation groups (as ``Reliability``) with a
    status and a kind per row."""

    result: VariantResult
    reliability: Reliability
    status: list[np.ndarray]
    kind: list[np.ndarray]
    probes: list[OrientationProbe]
    grid: tuple[int, int] = PROBE_GRID


def strip_probes(result: VariantResult, grid: tuple[int, int] = PROBE_GRID,
                 radius: int | None = RADIUS) -> list[OrientationProbe]:
    """Per strip, how the unknowns move its ground positions at a grid of image positions (adjusted
    geometry, on the DTM): ``dG_xy = -(dimage/dG_xy)^-1 dimage/dx`` (see ``OrientationProbe``;
    :func:`scangeo.adjustment.sensitivity.ground_sensitivity`).

    ``radius``: the probe's neighbourhood (strip steps, :mod:`scangeo.adjustment.neighbourhoods`): the
    observations evaluated for it, where it is smaller than the block; None: every observation.
    """
    sol = result.adjustment.solution
    hoods = strip_neighbourhoods(sol, radius) if radius is not None else {}
    values = sol.parameters.values()     # once: per strip only its probe points are added (linear)
    project = result.block.project
    out = []
    for sid in result.block.strips:
        g = ground_sensitivity(result, sid, *image_grid(result, sid, grid), values=values)
        if g is None:
            continue
        x, y, _ = project.map_frame.project_to_map(g.p_P)
        out.append(OrientationProbe(sid, g.matrix, np.column_stack([x, y]), hoods.get(sid)))
    return out


def _kinds(result: VariantResult, groups) -> list[np.ndarray]:
    out = []
    for g in groups:
        if g.kind != "observation":
            out.append(np.full(g.n_rows, "pseudo", dtype=object))
        elif g.name.startswith("gpsimu"):
            out.append(np.full(g.n_rows, "gpsimu", dtype=object))
        elif g.name == "dtm heights":
            out.append(np.full(g.n_rows, "dtm", dtype=object))
        else:
            out.append(np.array([result.block.role(str(p)) for p in g.ids], dtype=object))
    return out


def _statuses(result: VariantResult, rel: Reliability) -> list[np.ndarray]:
    adj = result.adjustment
    sol = adj.solution
    crit = result.variant.critical_value
    hidden = {r.id for r in adj.rejections if not r.separable}
    out = []
    for g, act, w, r in zip(sol.groups, sol.active, adj.statistics.w_tests(), rel.redundancy):
        st = np.full(g.n_rows, "verified", dtype=object)
        if g.kind != "observation":
            st[:] = "pseudo"
            out.append(st)
            continue
        if not g.snooped:
            st[:] = "untested"
        st[np.abs(np.nan_to_num(w)) > crit] = "failed"
        st[act & ~(r >= MIN_REDUNDANCY)] = "uncontrolled"
        gone = ~act
        st[gone] = "rejected"
        st[gone & np.isin(g.ids.astype(str), list(hidden))] = "not separable"
        out.append(st)
    return out


def variant_reliability(result: VariantResult, external: bool = True,
                        grid: tuple[int, int] = PROBE_GRID) -> VariantReliability:
    """The reliability of an adjusted variant (cached on ``result`` for the default arguments)."""
    cached = result.__dict__.get("_reliability")
    if cached is not None and external and grid == PROBE_GRID:
        return cached
    adj = result.adjustment
    probes = strip_probes(result, grid) if external else []
    rel = compute_reliability(adj.solution, adj.statistics, probes, external=external, point_key=Ground)
    out = VariantReliability(result, rel, _statuses(result, rel), _kinds(result, adj.solution.groups), probes, grid)
    if external and grid == PROBE_GRID:
        result.__dict__["_reliability"] = out
    return out


def _fmt(x: float, digits: str = ".4g") -> str:
    return "" if not math.isfinite(x) else format(x, digits)


def _fmt_inf(x: float) -> str:
    return "inf" if x == math.inf else _fmt(x)


def row_columns(vr: VariantReliability, group_index: int, row: int) -> list[str]:
    """The reliability columns of residuals.csv for one observation row:
    ``mdb, ext_point_m, ext_orientation_m, sqrt_lambda, status``."""
    rel = vr.reliability
    values = (rel.mdb, rel.ext_point_m, rel.ext_orientation_m, rel.sqrt_lambda)
    return [_fmt_inf(float(a[group_index][row])) for a in values] + [str(vr.status[group_index][row])]


#: residuals.csv columns added by the reliability.
COLUMNS = ["mdb", "ext_point_m", "ext_orientation_m", "sqrt_lambda", "status"]


def check_columns(sigma: float, ok: bool, failed: bool, alpha0: float, beta: float) -> list[str]:
    """The reliability columns of a check-point measurement (tested against its own sigma only)."""
    status = ("check failed" if failed else "check") if ok else "not projected"
    return [_fmt(delta0(alpha0, beta) * sigma), "", "", "", status]


def reliability_lines(vr: VariantReliability) -> list[str]:
    """A few lines for the console: uncontrolled measurements, non-separable points, per strip the
    largest shift of its ground positions by a single undetected blunder."""
    rel = vr.reliability
    unc = sorted({str(g.ids[i]) for g, st in zip(rel.groups, vr.status) if g.snooped
                  for i in np.flatnonzero(st == "uncontrolled")})
    out = [f"reliability: {len(unc)} points with measurements nothing checks (r = 0)"
           + (f": {', '.join(unc[:8])}{' ...' if len(unc) > 8 else ''}" if unc else "")]
    hidden = [r.id for r in vr.result.adjustment.rejections if not r.separable]
    if hidden:
        out.append(f"not separable (every measurement removed): {', '.join(hidden)}")
    for sid, (size, gi, i) in sorted(rel.ext_strip.items()):
        g = rel.groups[gi]
        if size > 0:
            out.append(f"strip {sid}: an undetected blunder shifts its ground positions by up to {size:.2f} m "
                       f"({g.name} {g.ids[i]} {g.components[i]})")
    return out


#: Unit status, worst first.
_ORDER = ("not separable", "rejected", "failed", "uncontrolled", "untested", "verified")
_CHECK = ("check", "check failed", "not projected")
UNIT_COLUMNS = ["group", "point", "strip", "kind", "x", "y", "H", "components", "unit", "redundancy", "mdb",
                "ext_point_m", "ext_orientation_m", "status"]


def unit_table(vr: VariantReliability) -> list[list]:
    """One row per observation unit of the image, control and DTM groups (``UNIT_COLUMNS``): the
    smallest redundancy number, the largest MDB and effects of its rows, the worst status, and the
    point's adjusted map position (x, y, H)."""
    result, rel = vr.result, vr.reliability
    sol = result.adjustment.solution
    mf = result.block.project.map_frame
    rows = []
    for gi, g in enumerate(sol.groups):
        if g.kind != "observation" or not g.snooped:
            continue
        strip = str(getattr(g, "strip", None) or getattr(g, "flight_line", ""))  # GPS/IMU: its flight line
        for u in np.unique(g.row_unit):
            sel = np.flatnonzero(g.row_unit == u)
            pid = str(g.ids[sel[0]])
            key = Ground(pid)
            xyz = (mf.project_to_map(sol.parameters[key].values[None, :]) if key in sol.parameters
                   else (np.array([np.nan]),) * 3)
            st = [str(x) for x in vr.status[gi][sel]]
            red = rel.redundancy[gi][sel]
            rows.append([g.name, pid, strip, str(vr.kind[gi][sel[0]]), *(float(c[0]) for c in xyz),
                         " ".join(str(c) for c in g.components[sel]),
                         "/".join(dict.fromkeys(str(x) for x in g.units[sel])),
                         float(np.nanmin(red)) if np.isfinite(red).any() else math.nan,
                         _max(rel.mdb[gi][sel]), _max(rel.ext_point_m[gi][sel]), _max(rel.ext_orientation_m[gi][sel]),
                         min(st, key=lambda x: _ORDER.index(x) if x in _ORDER else len(_ORDER))])
    return rows


def _max(a: np.ndarray) -> float:
    a = a[~np.isnan(a)]
    return float(a.max()) if a.size else math.nan


def summary(vr: VariantReliability) -> list[dict]:
    """Per strip (``-`` for block-wide groups), kind of point and unit: counts by status, median and
    largest MDB, largest effect on the own point and on the strips' ground positions. Check points
    are listed with the MDB of their own test (``delta0 sigma``) and no external reliability."""
    sol = vr.result.adjustment.solution
    rel = vr.reliability
    acc: dict[tuple[str, str, str], list] = {}
    for gi, g in enumerate(sol.groups):
        if g.kind != "observation":
            continue
        strip = str(getattr(g, "strip", None) or getattr(g, "flight_line", "")) or "-"  # GPS/IMU: its flight line
        for i in range(g.n_rows):
            k = (strip, str(vr.kind[gi][i]), str(g.units[i]))
            acc.setdefault(k, []).append((float(rel.mdb[gi][i]), float(rel.ext_point_m[gi][i]),
                                          float(rel.ext_orientation_m[gi][i]), str(vr.status[gi][i])))
    c = vr.result.checks   # check points: outside the adjustment, their own test against sigma only
    crit = vr.result.variant.critical_value
    sigmas = c.sigma_px if c.sigma_px is not None else np.full(c.point.size, np.nan)
    for sid, dl, dp, st, sig in zip(c.strip, c.line, c.pixel, c.status, sigmas):
        for unit, v in (("line", dl), ("px", dp)):
            verdict = "not projected" if st != 0 else "check failed" if abs(v / sig) > crit else "check"
            acc.setdefault((str(sid), "check", unit), []).append((rel.delta0 * float(sig), math.nan, math.nan, verdict))
    out = []
    for (strip, kind, unit), items in sorted(acc.items()):
        mdb = np.array([x[0] for x in items])
        fin = mdb[np.isfinite(mdb)]
        status = [x[3] for x in items]
        out.append({"strip": strip, "kind": kind, "unit": unit, "rows": len(items),
                    **{s.replace(" ", "_"): status.count(s) for s in _ORDER + _CHECK if status.count(s)},
                    "mdb_median": _num(np.median(fin)) if fin.size else None,
                    "mdb_max": _num(fin.max()) if fin.size else None,
                    "ext_point_max_m": _finite_max([x[1] for x in items]),
                    "ext_orientation_max_m": _finite_max([x[2] for x in items])})
    return out


def _finite_max(values: list[float]) -> float | None:
    """The largest finite value (None if there is none)."""
    fin = [x for x in values if math.isfinite(x)]
    return max(fin) if fin else None


def _num(x) -> float | None:
    return None if x is None or not math.isfinite(float(x)) else float(x)


def reliability_dict(vr: VariantReliability) -> dict:
    """Everything of ``reliability.json``."""
    result, rel = vr.result, vr.reliability
    groups = result.adjustment.solution.groups
    strips = {}
    for sid, (size, gi, i) in sorted(rel.ext_strip.items()):
        g = groups[gi]
        by = size > 0   # 0: the orientation is not adjusted (DG), no blunder moves it
        label = f"{g.name} {g.ids[i]} {g.components[i]}"
        strips[sid] = {"ext_orientation_max_m": _num(size), "by": label if by else None,
                       "mdb": _num(rel.mdb[gi][i]) if by else None, "unit": str(g.units[i]) if by else None}
    positions = {p.strip: [[_num(x), _num(y), _num(e)] for (x, y), e in zip(p.xy, rel.ext_positions[p.strip])]
                 for p in vr.probes if p.xy is not None and p.strip in rel.ext_positions}
    return {"alpha0": rel.alpha0, "beta": rel.beta, "delta0": rel.delta0, "lambda0": rel.delta0 ** 2,
            "min_redundancy": MIN_REDUNDANCY, "probe_grid": list(vr.grid), "strips": strips,
            "positions": positions,
            "summary": summary(vr),
            "non_separable": [{"point": r.id, "group": r.group, "components": list(r.components), "w": _num(r.w),
                               "round": r.round, "note": r.note}
                              for r in result.adjustment.rejections if not r.separable]}


def write_reliability(result: VariantResult, folder, vr: VariantReliability | None = None) -> None:
    """``reliability.csv`` and ``reliability.json`` of a variant into ``folder`` (temporary names,
    renamed when complete); ``vr`` the reliability if already computed."""
    vr = vr if vr is not None else variant_reliability(result)
    folder = Path(folder)
    where = {UNIT_COLUMNS.index(c) for c in ("x", "y", "H")}  # map coordinates to the mm, not 4 digits

    def text(k: int, x):
        if not isinstance(x, float):
            return x
        return (f"{x:.3f}" if math.isfinite(x) else "") if k in where else _fmt_inf(x)

    write_csv(folder / "reliability.csv", UNIT_COLUMNS, ([text(k, x) for k, x in enumerate(r)] for r in unit_table(vr)))
    write_text(folder / "reliability.json", json.dumps(reliability_dict(vr), indent=1))


__all__ = ["COLUMNS", "UNIT_COLUMNS", "VariantReliability", "check_columns", "reliability_dict", "reliability_lines",
           "row_columns",
           "strip_probes", "summary", "unit_table", "variant_reliability", "write_reliability"]
