"""The match report in the HTML report of ``scangeo report``: a map of the points and a table.

:func:`match_section` reads ``PROJECT/results/match_report.json`` (written by ``scangeo match``) and returns
an HTML section: the strips' footprints with every matched tie point (by the number of strips it
was measured in), control and check point, the cells without points marked; and a table per
overlap and per strip and reference (points, cells, cells without points, rejected share, the
precision from the matches' consistency).
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from scangeo.match.run import report_path
from scangeo.reports import figures, html


def distribution_figure(report: dict, footprints: dict[str, np.ndarray] | None = None) -> bytes:
    """PNG: footprints (polygons, else the report's boxes), matched points, cells without points."""
    fig = Figure(figsize=(7, 7))
    ax = fig.add_subplot(1, 1, 1)
    for i, (sid, box) in enumerate(report.get("footprints", {}).items()):
        poly = footprints.get(sid) if footprints else None
        if poly is None:
            x0, y0, x1, y1 = box
            poly = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1], [x0, y0]])
        ax.plot(poly[:, 0], poly[:, 1], color=figures.colour(i), lw=1.0, label=f"strip {sid}")
    pos = report.get("positions", [])
    styles = {"tie": ("o", "tab:blue", 6), "control": ("^", "tab:red", 22), "check": ("s", "tab:green", 16)}
    for kind, (marker, colour, size) in styles.items():
        pts = np.array([[p[0], p[1]] for p in pos if p[2] == kind]).reshape(-1, 2)
        if len(pts):
            ax.scatter(pts[:, 0], pts[:, 1], s=size, marker=marker, color=colour, label=f"{kind} ({len(pts)})")
    triples = np.array([[p[0], p[1]] for p in pos if p[2] == "tie" and p[3] > 2]).reshape(-1, 2)
    if len(triples):
        ax.scatter(triples[:, 0], triples[:, 1], s=20, facecolors="none", edgecolors="k",
                   label=f"tie in 3+ strips ({len(triples)})")
    empty = np.array([c for o in report.get("overlaps", {}).values()
                      for c, n in zip(o.get("cell_centres", []), o.get("points_per_cell", [])) if n == 0])
    if len(empty):
        ax.scatter(empty[:, 0], empty[:, 1], s=30, marker="x", color="0.4", label=f"cell without points ({len(empty)})")
    ax.set_aspect("equal")
    ax.ticklabel_format(useOffset=False, style="plain")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.legend(loc="best", fontsize=7)
    return figures.png(fig)


def table_rows(report: dict) -> list[list[str]]:
    rows = []
    for name, o in list(report.get("overlaps", {}).items()) + list(report.get("control", {}).items()):
        cand = o.get("candidates", 0)
        cons = o.get("consistency", {})
        outliers = sum(s["outliers"] for s in cons.values())
        rejected = sum(o.get("rejected", {}).values()) + outliers
        prec = [s["precision_cells"] for s in cons.values() if s.get("precision_cells") is not None]
        kind = "ties" if name in report.get("overlaps", {}) else "control"
        rows.append([name, kind, str(o.get("points", 0)), str(o.get("cells", 0)), str(o.get("cells_without_points", 0)),
                     f"{100 * rejected / cand:.0f} %" if cand else "-",
                     f"{np.nanmean(prec):.2f}" if prec and np.isfinite(np.nanmean(prec)) else "-"])
    return rows


def match_section(project_root: str | Path, footprints: dict[str, np.ndarray] | None = None) -> html.Section | None:
    """The HTML section of the match report, or None when the project has no match_report.json."""
    path = report_path(Path(project_root), existing=True)
    if not path.exists():
        return None
    try:
        report = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return html.Section("Matched points", "match", [html.paragraph(f"{path.name} cannot be read")])
    s = report.get("summary", {})
    intro = html.paragraph(
        f"scangeo match ({report.get('variant', 'DG')} orientation, chips of {report.get('resolution', 0):g} m): "
        f"{s.get('tie_points', 0)} tie, {s.get('control_points', 0)} control and {s.get('check_points', 0)} check "
        f"points; {100 * s.get('rejected_share', 0):.0f} % of {s.get('candidates', 0)} candidates rejected. "
        "Precision: the rms leave-one-out residual of the matches to the local affine of their neighbours "
        "(chip cells, about image pixels): the matching precision estimated from the matches alone.")
    head = ["overlap / strip", "kind", "points", "cells", "cells without points", "rejected", "precision"]
    parts = [intro, html.figure(distribution_figure(report, footprints), "Matched points over the strips' footprints",
                                "fig-match"),
             html.table(head, table_rows(report), "table-match", text_columns=(0, 1))]
    return html.Section("Matched points", "match", parts)
