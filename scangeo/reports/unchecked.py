"""The report of a project without points: a direct georeferencing whose accuracy nothing checks.

An imported line without GCPs (``scangeo import lcf`` or ``parge`` without control) has no
measurements to clean, diagnose or compare: ``scangeo run`` rectifies it with its GPS/IMU as
measured (the variant DG) and this page says, where a compared project's report shows the
recommendation and the check-point accuracy, that the orthoimage is **unchecked**.
"""
from __future__ import annotations

import datetime
import json
from pathlib import Path

import numpy as np

from scangeo.atomic import write_text
from scangeo.io.project import Project
from scangeo.reports import html
from scangeo.reports.quicklook import quicklook_section
from scangeo.version import __version__

#: What the report and the manifest say of such an orthoimage.
UNCHECKED = ("unchecked: a direct georeferencing (the GPS/IMU as measured, the variant DG); no control or check "
             "points, so nothing measures its accuracy")


def write_unchecked_report(project: Project, frames: dict, folder: Path) -> Path:
    """Write ``report.html`` of a project without points into ``folder``; ``frames``: each strip's
    :class:`~scangeo.reports.figures.StripFrame`."""
    root = project.root
    sections = [html.Section("Recommendation and accuracy", "recommendation", [
        html.paragraph(f"Rectified: DG, {UNCHECKED}.", cls="warn"),
        html.paragraph("Add GCPs (ground.csv and points.csv; for an imported line: import it again with its "
                       "ground.csv and points.csv) for an adjusted orthoimage and its check-point accuracy.")])]
    sections.append(quicklook_section(root / "results", "DG", {sid: f.footprint for sid, f in frames.items()},
                                      np.zeros((0, 2))))
    rows = []
    for sid, frame in frames.items():
        xy = np.asarray(frame.footprint)
        rows.append([sid, str(project.n_lines(sid)), f"{np.ptp(xy[:, 0]):.1f} x {np.ptp(xy[:, 1]):.1f}"])
    sections.append(html.Section("Strips", "strips", [html.table(["strip", "lines", "footprint extent (m, x by y)"],
                                                                 rows, "strips")]))
    imported = root / "import.json"
    if imported.exists():
        record = json.loads(imported.read_text(encoding="utf-8"))
        items = [f"{d['topic']}: {d['choice']}" for d in record.get("decisions", [])]
        items += [f"warning: {w}" for w in record.get("warnings", [])] + [f"note: {n}" for n in record.get("notes", [])]
        sections.append(html.Section("How the line was imported", "import", [
            html.paragraph(f"from {imported.name} (every decision with its figures)"), html.bullet_list(items)]))
    stamp = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
    intro = [html.paragraph(f"Project {root.resolve()} ({project.crs}, {len(frames)} strips): no points.csv; "
                            f"scangeo {__version__}, {stamp}.")]
    return write_text(folder / "report.html", html.document(f"scangeo report: {root.name} (unchecked)", intro,
                                                            sections))


__all__ = ["UNCHECKED", "write_unchecked_report"]
