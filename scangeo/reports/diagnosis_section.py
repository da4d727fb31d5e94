"""The report's section on the diagnosis and the recommendation (docs/reports.md).

Per strip, the tie points' DTM misclosures after SE over the image lines, with the proposed breaks
and their 95 % intervals (``PROJECT/results/diagnosis.json``); the recommendation of the
cross-validation and BIC; and the pairs of unknowns correlated above 0.95 with their notes.
"""
from __future__ import annotations

from pathlib import Path

from matplotlib.figure import Figure

from scangeo.adjustment.diagnosis.output import read_diagnosis
from scangeo.adjustment.summary import Comparison
from scangeo.reports import html
from scangeo.reports.figures import png
from scangeo.reports.tables import correlation_kinds, markdown_tables


def misclosure_plot(diagnosis: dict) -> bytes:
    """One panel per strip: DTM misclosures of its tie points over lines, breaks and their intervals."""
    series = diagnosis.get("series", [])
    fig = Figure(figsize=(10, 1.9 * max(1, len(series)) + 0.6))
    for i, s in enumerate(series):
        ax = fig.add_subplot(len(series), 1, i + 1)
        ax.plot(s["tie"]["line"], s["tie"]["misclosure_m"], ".", ms=4, color="#1f77b4")
        ax.axhline(0.0, color="#999", lw=0.6)
        for b in diagnosis.get("breaks", []):
            if b["strip"] == s["strip"]:
                ax.axvspan(b["low"], b["high"], color="#d62728", alpha=0.15)
                ax.axvline(b["line"], color="#d62728", lw=1.2)
        ax.set_xlim(0, s["n_lines"] - 1)
        verdict = "problem strip" if s["strip"] in diagnosis.get("problem_strips", []) else "good"
        ax.set_ylabel("m")
        ax.set_title(f"strip {s['strip']} ({verdict})", fontsize=9, loc="left")
        if i == len(series) - 1:
            ax.set_xlabel("image line")
    fig.tight_layout()
    return png(fig)


def diagnosis_section(project_root, comparison: Comparison) -> html.Section:
    """The section (module docstring); parts that are missing say so."""
    sec = html.Section("Diagnosis and recommendation", "diagnosis")
    d = read_diagnosis(Path(project_root))
    if d is None:
        sec.parts.append(html.paragraph("No diagnosis: the variants came from a variants.toml given by the user "
                                        "(run 'scangeo diagnose PROJECT --no-write-variants' to see one)."))
    else:
        crit = d.get("criterion", {})
        problems = ", ".join(d.get("problem_strips", [])) or "none"
        sec.parts.append(html.paragraph(
            f"From an SE adjustment (degree 0, no DTM heights; sigma0 {d.get('se_sigma0', float('nan')):.3f}): C0 "
            "piecewise-linear error functions of every strip fitted to the tie points' DTM misclosures and the "
            "control points' across-track residuals, breaks chosen by BIC "
            f"({crit.get('with_breaks', float('nan')):.1f} with, {crit.get('without_breaks', float('nan')):.1f} "
            f"without), each break then placed where the split model (S2's set-up) adjusts best and tested there "
            "(F test of the parameters it adds; a strip's extra breaks that fail it at 5 % are dropped). "
            f"Problem strips: {problems}. Check points were not used."))
        rows = [[b["strip"], f"{b['line']:.0f}", f"{b['low']:.0f} - {b['high']:.0f}",
                 "-" if b.get("bic_line") is None else f"{b['bic_line']:.0f}",
                 "-" if b.get("p_value") is None else f"{b['f_statistic']:.2f} (p {b['p_value']:.2g})"]
                for b in d.get("breaks", [])]
        if rows:
            sec.parts.append(html.table(["strip", "break line", "95 % interval", "BIC's line",
                                         "F test in the split model"], rows, table_id="breaks-table"))
        if d.get("notes"):  # a sigma0 far above 1 (with its likely causes), breaks the split model dropped
            sec.parts.append(html.bullet_list([f"note: {n}" for n in d["notes"]]))
        if d.get("series"):
            sec.parts.append(html.figure(misclosure_plot(d), "DTM misclosures of the tie points after SE; red: "
                                         "proposed breaks with their 95 % intervals", "fig-diagnosis"))
    tables = markdown_tables(comparison)
    if "cross-validation" in tables:
        cv = comparison.crossvalidation or {}
        sec.parts.append(html.paragraph(
            f"Recommended without check points: {comparison.recommended} ({cv.get('reason', '')}). "
            f"{cv.get('folds')}-fold cross-validation over the {cv.get('points')} control points (each fold held out "
            "as check points in turn), BIC within groups of identical observations."))
        sec.parts.append(html.table(*tables["cross-validation"], table_id="crossvalidation-table",
                                    text_columns=(0, 4)))
    if "correlations" in tables:
        sec.parts.append("<h3>Correlated unknowns (|r| &gt; 0.95)</h3>")
        kinds = correlation_kinds(comparison)
        sec.parts.append(html.bullet_list([f"{kind}: {text}" for kind, (text, _) in kinds.items()]))
        sec.parts.append(html.table(*tables["correlations"], table_id="correlations-table",
                                    text_columns=(0, 1, 2), wide_columns=(2,)))
    return sec


__all__ = ["diagnosis_section", "misclosure_plot"]
