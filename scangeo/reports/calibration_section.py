"""The report's calibration section: what each variant's calibration found, how well it is
determined, and what it bought.

For every variant that calibrates something (``report.json``'s ``calibration``,
:mod:`scangeo.adjustment.calibration`):

* a table of what it bought: the variant's control, cross-validated and check-point rms beside the
  reference's;
* its calibration unknowns: start value (project.toml's), estimate, change with sigma and the
  change's t-test, prior and data share (how much of the estimate is the observations', not the
  prior's), and the ``test_calibration`` decisions (kept or fixed, t against the critical value);
* the correlations among them, the pairs above 0.95 named;
* the GCP residuals against pixel and against line, control and check points, along and across.

A user sees at a glance whether the calibration is determined (t, data share, correlations) and
what it bought (the rms against the reference's).
"""
from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from scangeo.adjustment.outputs import read_report
from scangeo.adjustment.summary import Comparison
from scangeo.errors import ScangeoError
from scangeo.io.points import ImagePoints
from scangeo.reports import html
from scangeo.reports.figures import png


def _fmt(value, digits: int = 4) -> str:
    return "–" if value is None else f"{value:.{digits}g}"


def _calibrated(results: Path, c: Comparison) -> dict[str, dict]:
    out = {}
    for v in c.variants:
        if v.error is None:
            cal = read_report(results, v.name).get("calibration", {})
            if cal.get("parameters") or cal.get("tests"):
                out[v.name] = cal
    return out


def _bought_table(c: Comparison, calibrated: dict[str, dict]) -> str:
    cv = (c.crossvalidation or {}).get("rms_px", {})
    rows = []
    for v in c.variants:
        if v.error is not None:
            continue
        control = [e.get("control", {}) for e in v.strips.values()]
        check = [e.get("check", {}) for e in v.strips.values()]

        def pooled(entries, key):
            n = sum(e.get("n") or 0 for e in entries)
            ss = sum((e.get("n") or 0) * (e.get(key) or 0.0) ** 2 for e in entries)
            return None if n == 0 else (ss / n) ** 0.5

        free = [p["name"] for p in calibrated.get(v.name, {}).get("parameters", [])]
        rows.append([v.name + (" (ref.)" if v.name == c.reference else ""), ", ".join(free) or "–",
                     _fmt(pooled(control, "rms_along_px"), 3), _fmt(pooled(control, "rms_across_px"), 3),
                     _fmt(cv.get(v.name), 3), _fmt(pooled(check, "rms_along_px"), 3),
                     _fmt(pooled(check, "rms_across_px"), 3), _fmt(v.sigma0, 3)])
    return html.table(["variant", "calibrated (after the tests)", "control along (lines)", "control across (px)",
                       "cross-validated (px)", "check along (lines)", "check across (px)", "sigma0"], rows,
                      table_id="calibration-bought", text_columns=(0, 1))


def _parameter_table(cal: dict, name: str) -> str:
    rows = []
    for p in cal["parameters"]:
        unit = f" {p['unit']}" if p.get("unit") else ""
        verdict = "changed" if p.get("significant_change") else "not significantly changed"
        rows.append([p["name"], _fmt(p.get("start"), 5) + unit, _fmt(p.get("value"), 5) + unit,
                     f"{_fmt(p.get('change'), 3)} +- {_fmt(p.get('sigma'), 2)}{unit}", _fmt(p.get("t_change"), 3),
                     verdict, _fmt(p.get("prior_sigma"), 3), _fmt(p.get("data_share"), 3)])
    return html.table(["unknown", "start", "estimate", "change +- sigma", "t of the change", "verdict",
                       "prior sigma", "data share"], rows, table_id=f"calibration-{name}", text_columns=(0, 5))


def _tests_table(cal: dict, name: str) -> str:
    rows = [[t["name"], _fmt(t.get("t"), 3), _fmt(t.get("critical"), 3),
             "kept" if t["kept"] else "fixed at its start value"] for t in cal["tests"]]
    return html.table(["unknown", "t", "critical value", "decision"], rows, table_id=f"calibration-tests-{name}",
                      text_columns=(0, 3))


def _correlation_table(cal: dict, name: str) -> str:
    names = cal["correlation"]["names"]
    rows = [[n] + [_fmt(v, 3) for v in row] for n, row in zip(names, cal["correlation"]["matrix"])]
    return html.table(["", *names], rows, table_id=f"calibration-correlation-{name}", text_columns=(0,))


def residual_plot(name: str, points: ImagePoints, residuals: Path, pixels: int) -> bytes | None:
    """Control and check residuals (along in lines, across in pixels) against pixel and line."""
    if not residuals.exists():
        return None
    where = {(str(p), str(s)): (float(line), float(px))
             for p, s, line, px in zip(points.point, points.strip, points.line, points.pixel)}
    data: dict[tuple[str, str], list[tuple[float, float, float]]] = {}
    with open(residuals, newline="", encoding="utf-8") as fh:
        for row in csv.DictReader(fh):
            if row["kind"] not in ("control", "check") or row["component"] not in ("line", "pixel"):
                continue
            at = where.get((row["id"], row["strip"]))
            if at is None:
                continue
            data.setdefault((row["kind"], row["component"]), []).append((at[1], at[0], float(row["residual"])))
    if not data:
        return None
    fig = Figure(figsize=(10, 5.6))
    axes = fig.subplots(2, 2, sharey="row")
    for r, (component, unit) in enumerate((("line", "along, lines"), ("pixel", "across, px"))):
        for c, (xi, xlabel) in enumerate(((0, "pixel"), (1, "line"))):
            ax = axes[r, c]
            for kind, marker, colour in (("control", "o", "#1f77b4"), ("check", "^", "#d62728")):
                values = np.array(data.get((kind, component), []), float).reshape(-1, 3)
                if len(values):
                    ax.scatter(values[:, xi], values[:, 2], s=16, marker=marker, color=colour,
                               label=f"{kind} ({len(values)})")
            ax.axhline(0.0, color="0.5", lw=0.8)
            ax.grid(alpha=0.3)
            if xi == 0:
                ax.set_xlim(-0.5, pixels - 0.5)
            if r == 1:
                ax.set_xlabel(xlabel)
            if c == 0:
                ax.set_ylabel(f"residual ({unit})")
    axes[0, 0].legend(fontsize=8)
    fig.suptitle(f"{name}: GCP residuals (model - measured) against pixel and line", fontsize=10)
    return png(fig)


def calibration_section(root: Path, c: Comparison, pixels: int) -> html.Section | None:
    """The section, or None when no variant calibrates anything."""
    results = root / "results"
    calibrated = _calibrated(results, c)
    if not calibrated:
        return None
    sec = html.Section("Calibration", "calibration")
    sec.parts.append(html.paragraph(
        "What each variant's calibration bought: the rms at the control points it used, over the held-out folds "
        "of the cross-validation, and at the check points it never saw, beside the reference's. Then, per "
        "variant, its calibration unknowns: the change from the start value (project.toml's) with its sigma and "
        "t-test, the prior and the data share (1: determined by the observations alone, 0: only by its prior), "
        "the decisions of test_calibration, and their correlations (pairs above 0.95 move the image alike: the "
        "observations fix their combination)."))
    sec.parts.append(_bought_table(c, calibrated))
    try:
        points: ImagePoints | None = ImagePoints.read(root / "points.csv")
    except ScangeoError:  # the residual plots need the measurements; the tables do not
        points = None
    for name, cal in calibrated.items():
        sec.parts.append(f"<h3>{html.esc(name)}</h3>")
        if cal.get("parameters"):
            sec.parts.append(_parameter_table(cal, name))
        if cal.get("tests"):
            sec.parts.append(html.paragraph("test_calibration: a component whose change is not significant is fixed "
                                            "at its start value and the variant adjusted again."))
            sec.parts.append(_tests_table(cal, name))
        if len(cal.get("correlation", {}).get("names", [])) > 1:
            sec.parts.append(_correlation_table(cal, name))
        sec.parts.append(html.bullet_list([p["note"] for p in cal.get("correlated", [])]))
        figure = residual_plot(name, points, results / name / "residuals.csv", pixels) if points else None
        if figure is not None:
            sec.parts.append(html.figure(figure, f"{name}: GCP residuals against pixel and line",
                                         f"fig-calibration-{name}"))
    return sec


__all__ = ["calibration_section", "residual_plot"]
