"""Reliability in the reports: MDB and external reliability maps, non-separable points, interpretation.

- :func:`reliability_section`: a section of the residual report (``scangeo report``) from the
  ``reliability.csv`` and ``reliability.json`` each variant's results hold: per strip a map of the
  image measurements' MDBs (pixels; uncontrolled ones, r = 0, as red crosses) and of the external
  reliability (the largest shift of the strip's ground positions any single undetected MDB-sized
  blunder causes, on a grid of image positions, with each point's own shift), the non-separable
  points, and a sentence of interpretation;
- :func:`write_plan_report`: ``plan.html`` of ``scangeo plan``, the weak-area map of a planned block;
  :func:`write_plan` writes it with the plan's reliability tables and planned measurements.
"""
from __future__ import annotations

import csv
import datetime
import json
import math
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from scangeo.adjustment.planning import Plan
from scangeo.adjustment.reliability_summary import UNIT_COLUMNS, reliability_dict, unit_table, write_reliability
from scangeo.atomic import write_text
from scangeo.reports import html
from scangeo.reports.figures import png
from scangeo.version import __version__


def read_variant_reliability(folder: Path) -> tuple[list[dict], dict] | None:
    """(rows of reliability.csv, reliability.json) of a variant's results folder, or None."""
    table, summary = folder / "reliability.csv", folder / "reliability.json"
    if not (table.exists() and summary.exists()):
        return None
    with open(table, newline="") as f:
        rows = list(csv.DictReader(f))
    return rows, json.loads(summary.read_text())


def _f(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        return math.nan


def _scatter_panel(ax, fig, x, y, c, label, cmap, marker="o", size=22, vmax=None):
    fin = np.isfinite(c)
    if fin.any():
        vmax = vmax or float(np.nanpercentile(c[fin], 98)) or 1.0
        sc = ax.scatter(x[fin], y[fin], c=c[fin], s=size, cmap=cmap, vmin=0.0, vmax=vmax, marker=marker,
                        edgecolors="k", linewidths=0.3)
        fig.colorbar(sc, ax=ax, shrink=0.8, label=label)
    if (~fin).any():
        ax.scatter(x[~fin], y[~fin], c="#d62728", marker="x", s=40, label="r = 0: uncontrolled")
        ax.legend(loc="upper right", fontsize=7)


def strip_map(strip: str, rows: list[dict], positions: list | None) -> bytes:
    """Two panels over map x, y: MDB (px) of the strip's image measurements, and the external
    reliability (m): the probe grid's largest shift, with each point's own shift on top."""
    fig = Figure(figsize=(11, 4.6))
    ax1, ax2 = fig.subplots(1, 2)
    img = [r for r in rows if r["strip"] == strip]
    x = np.array([_f(r["x"]) for r in img])
    y = np.array([_f(r["y"]) for r in img])
    _scatter_panel(ax1, fig, x, y, np.array([_f(r["mdb"]) for r in img]), "MDB (px)", "viridis")
    ax1.set_title(f"Strip {strip}: minimal detectable blunder", fontsize=9)
    if positions:
        p = np.array(positions, dtype=float)
        _scatter_panel(ax2, fig, p[:, 0], p[:, 1], p[:, 2], "ground shift (m)", "magma_r", marker="s", size=60)
    ax2.scatter(x, y, c="none", edgecolors="#1f77b4", s=22, linewidths=0.8)
    ax2.set_title(f"Strip {strip}: external reliability (largest shift of its ground positions)", fontsize=9)
    for ax in (ax1, ax2):
        ax.set_aspect("equal", adjustable="datalim")
        ax.tick_params(labelsize=7)
        ax.set_xlabel("x (m)", fontsize=8)
    return png(fig)


def interpretation(name: str, summary: dict, rows: list[dict]) -> str:
    """One sentence on what the reliability of a variant means for its user."""
    strips = summary.get("strips", {})
    parts = [f"{name}: data snooping finds a single blunder of {summary['delta0']:.2f} sigma / sqrt(r) "
             f"(MDB; alpha0 = {100 * summary['alpha0']:g} %, power {100 * summary['beta']:g} %)"]
    if strips:
        sid, worst = max(strips.items(), key=lambda kv: kv[1]["ext_orientation_max_m"] or 0.0)
        if worst["by"]:
            parts.append(f"one undetected would shift strip {sid}'s ground positions by up to "
                         f"{worst['ext_orientation_max_m']:.2f} m (the worst case: {worst['by']})")
        else:
            parts.append("the orientation is not adjusted, so an undetected blunder moves only its own point")
    unc = sorted({r["point"] for r in rows if r["status"] == "uncontrolled"})
    if unc:
        parts.append(f"{len(unc)} points have measurements no other observation checks (r = 0: "
                     f"{', '.join(unc[:6])}{', ...' if len(unc) > 6 else ''}); a blunder there goes unnoticed, "
                     "so add control or tie points near them")
    ns = summary.get("non_separable", [])
    if ns:
        parts.append(f"{len(ns)} points were removed whole because the adjustment cannot tell which of their "
                     "measurements holds the blunder")
    return "; ".join(parts) + "."


def reliability_section(results: Path, names: list[str]) -> html.Section:
    """The report's reliability section for the variants ``names`` (results in ``results/NAME``)."""
    sec = html.Section("Reliability", "reliability")
    sec.parts.append(html.paragraph(
        "Minimal detectable blunder (MDB): the smallest blunder of a measurement that data snooping finds with "
        "80 % probability at 0.1 % significance, sigma * 4.13 / sqrt(r) for redundancy number r. External "
        "reliability: how far such a blunder, left undetected, moves the ground positions. Red crosses: "
        "measurements with r = 0, which nothing checks. Weak areas are where the maps are bright or crossed."))
    for name in names:
        data = read_variant_reliability(results / name)
        if data is None:
            continue
        rows, summary = data
        sec.parts.append(f"<h3>{html.esc(name)}</h3>")
        sec.parts.append(html.paragraph(interpretation(name, summary, rows)))
        for sid in sorted({r["strip"] for r in rows if r["strip"]}):
            sec.parts.append(html.figure(strip_map(sid, rows, summary.get("positions", {}).get(sid)),
                                         f"{name}, strip {sid}: MDB and external reliability", f"fig-rel-{name}-{sid}"))
        ns = summary.get("non_separable", [])
        sec.parts.append(html.paragraph(f"non-separable points: {len(ns) or 'none'}"))
        sec.parts.append(html.bullet_list([f"{x['point']} (|w| = {x['w']:.1f}): {x['note']}" for x in ns]))
        sec.parts.append(html.table(["strip", "kind", "unit", "rows", "uncontrolled", "MDB median", "MDB max",
                                     "ext. point max (m)", "ext. orientation max (m)"],
                                    [[s["strip"], s["kind"], s["unit"], str(s["rows"]), str(s.get("uncontrolled", 0)),
                                      _g(s["mdb_median"]), _g(s["mdb_max"]), _g(s["ext_point_max_m"]),
                                      _g(s["ext_orientation_max_m"])] for s in summary["summary"]],
                                    text_columns=(0, 1, 2)))
    return sec


def _g(x) -> str:
    return "-" if x is None else f"{x:.3g}"


def plan_map(positions: dict, rows: list[dict]) -> bytes:
    """The weak-area map of a planned block: every strip's grid of ground positions coloured by the
    largest shift an undetected blunder causes there; control as triangles, tie points as dots,
    uncontrolled measurements as red crosses."""
    fig = Figure(figsize=(9, 7))
    ax = fig.subplots()
    p = np.array([q for v in positions.values() for q in v], dtype=float).reshape(-1, 3)
    if p.size:
        _scatter_panel(ax, fig, p[:, 0], p[:, 1], p[:, 2], "largest ground shift (m)", "magma_r", marker="s", size=80)
    for kind, marker, colour in (("tie", ".", "#1f77b4"), ("control", "^", "#2ca02c"), ("height", "v", "#2ca02c"),
                                 ("planimetric", "<", "#2ca02c")):
        sel = [r for r in rows if r["kind"] == kind and r["group"].startswith("image")]
        if sel:
            ax.scatter([_f(r["x"]) for r in sel], [_f(r["y"]) for r in sel], marker=marker, c=colour, s=30, label=kind)
    unc = [r for r in rows if r["status"] == "uncontrolled"]
    if unc:
        ax.scatter([_f(r["x"]) for r in unc], [_f(r["y"]) for r in unc], marker="x", c="#d62728", s=50,
                   label="uncontrolled (r = 0)")
    ax.legend(loc="upper right", fontsize=7)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title("Planned block: weak areas (external reliability)")
    return png(fig)


def write_plan_report(plan: Plan, path: Path) -> Path:
    """``plan.html``: the planned block's weak-area map, per-strip maps and the summary table."""
    vr = plan.reliability
    summary = reliability_dict(vr)
    rows = [dict(zip(UNIT_COLUMNS, (str(x) for x in r))) for r in unit_table(vr)]
    name = plan.result.variant.name
    sec = html.Section("Weak areas", "weak-areas")
    sec.parts.append(html.paragraph(
        f"Planned block for variant {name}: {plan.tie_points} tie points on the grid, {plan.control_points} control "
        "points; measurements made from the planned orientation, so only the geometry and the sigmas count. "
        + interpretation(name, summary, rows)))
    sec.parts.append(html.figure(plan_map(summary["positions"], rows), "Weak areas of the planned block", "fig-plan"))
    strips = html.Section("Per strip", "strips")
    for sid in sorted({r["strip"] for r in rows if r["strip"]}):
        strips.parts.append(html.figure(strip_map(sid, rows, summary["positions"].get(sid)),
                                        f"Strip {sid}: MDB and external reliability", f"fig-plan-{sid}"))
    root = plan.result.block.project.root
    stamp = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
    intro = [html.paragraph(f"Project {root.resolve()}; scangeo {__version__}, {stamp}.")]
    text = html.document(f"scangeo plan: {root.name}, variant {name}", intro, [sec, strips])
    return write_text(path, text)


def write_plan(plan: Plan, out_dir=None) -> Path:
    """``reliability.csv``, ``reliability.json``, ``points.csv`` (the planned measurements) and
    ``plan.html`` into ``out_dir`` (default PROJECT/results/plan_NAME); returns the folder."""
    result = plan.result
    out = Path(out_dir) if out_dir else result.block.project.root / "results" / f"plan_{result.variant.name}"
    out.mkdir(parents=True, exist_ok=True)
    write_reliability(result, out, plan.reliability)
    result.block.points.write(out / "points.csv")
    write_plan_report(plan, out / "plan.html")
    return out


__all__ = ["interpretation", "plan_map", "read_variant_reliability", "reliability_section", "strip_map",
           "write_plan", "write_plan_report"]
