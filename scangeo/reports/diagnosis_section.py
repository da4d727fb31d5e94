"""The report's section on the diagnosis and the recommendation (docs/reports.md).

Per strip, the tie points' DTM misclosures after SE over the image lines, with the proposed breaks
and their 95 % intervals (``PROJECT/results/diagnosis.json``); the attribution of every problem strip
against its runner-up (ambiguous or not); the recommendation weighing the cross-validation and the
check points, its margin, each evidence's choice and their disagreement; and the pairs of unknowns
correlated above 0.95 with their notes.
"""
from __future__ import annotations

from pathlib import Path

from matplotlib.figure import Figure

from scangeo.adjustment.diagnosis.output import read_diagnosis
from scangeo.adjustment.summary import Comparison
from scangeo.reports import html
from scangeo.reports.figures import png
from scangeo.reports.tables import correlation_kinds, markdown_tables


def _with_ties(diagnosis: dict) -> list[dict]:
    """The strips of diagnosis.json's series that have tie points with a DTM misclosure."""
    return [s for s in diagnosis.get("series", []) if len(s.get("tie", {}).get("line", []))]


def misclosure_plot(diagnosis: dict) -> bytes:
    """One panel per strip with tie points: their DTM misclosures over lines, breaks and their intervals."""
    series = _with_ties(diagnosis)
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


def _alternative(a: dict | None) -> str:
    """An alternative attribution of diagnosis.json in words: kind, strips and breaks, BIC difference."""
    if not a:
        return "-"
    kind = {"moved": f"on strip {a.get('other')} instead", "merged": f"merged on strip {a.get('other')}",
            "dropped": "none on this strip", "shared": f"shared with strip {a.get('other')}",
            "breaks": f"a problem strip {a.get('strip')}"}.get(a.get("kind", ""), a.get("kind", ""))
    lines = "; ".join(f"{s}: {', '.join(f'{b:.0f}' for b in v) or '-'}" for s, v in (a.get("breaks") or {}).items())
    split = f", split model {a['delta_split']:+.1f}" if a.get("delta_split") is not None else ""
    return f"{kind} ({lines or 'no breaks'}): BIC {a['delta_bic']:+.1f}{split}"


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
        adopted = d.get("adopted")
        if adopted:  # an alternative of the attribution replaced the search's own model (docs/adjustment.md)
            problems += (f" (the attribution's; the search's own model had "
                         f"{', '.join(adopted['search_problem_strips']) or 'none'})")
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
        attribution = d.get("attribution", [])
        if attribution:
            rows = [[a.get("strip") or "none", _alternative(a.get("runner_up")), _alternative(a.get("richer")),
                     "yes" if a.get("ambiguous") else "no"] for a in attribution]
            sec.parts.append(html.table(["problem strip", "runner-up (competing attribution)", "richer alternative",
                                         "ambiguous"], rows, table_id="attribution-table", text_columns=(0, 1, 2),
                                        wide_columns=(1, 2)))
            sec.parts.append(html.paragraph(
                "A competing attribution (the drift on another strip, merged from two, or none) within "
                f"{attribution[0].get('threshold', 10):g} of the chosen one by the BIC or by the split model's own "
                "criterion, or a richer one (the drift shared with another strip) more than "
                f"{-attribution[0].get('richer_threshold', -30):g} better, makes the attribution ambiguous "
                "(docs/adjustment.md, \"Attribution\")."))
            if d.get("ambiguous"):
                sec.parts.append(html.paragraph(
                    "The attribution is ambiguous: the data explain the drift nearly as well on another strip (or "
                    "shared by two). The comparison built the P and S variants of every plausible attribution "
                    "(named with its strips as a suffix) and lets the cross-validation and the check points decide.",
                    "note warn"))
        if d.get("notes"):  # a sigma0 far above 1 (with its likely causes), breaks the split model dropped
            sec.parts.append(html.bullet_list([f"note: {n}" for n in d["notes"]]))
        shown = _with_ties(d)
        without = [s["strip"] for s in d.get("series", []) if s not in shown]
        if shown:
            sec.parts.append(html.figure(misclosure_plot(d), "DTM misclosures of the tie points after SE; red: "
                                         "proposed breaks with their 95 % intervals"
                                         + (f"; no tie points on strip {', '.join(without)}" if without else ""),
                                         "fig-diagnosis"))
        elif d.get("series") and not any("tie point" in n for n in d.get("notes", [])):  # one line why, no plot
            sec.parts.append(html.paragraph("No misclosure plot: no strip has a tie point with a DTM misclosure."))
    tables = markdown_tables(comparison)
    if "cross-validation" in tables:
        cv = comparison.crossvalidation or {}
        evidence = cv.get("evidence") or {}
        sec.parts.append(html.paragraph(
            f"Recommended: {comparison.recommended} ({cv.get('reason', '')}). "
            f"{cv.get('folds')}-fold cross-validation over the {cv.get('points')} control points (each fold held out "
            "as check points in turn), weighed with the check points: no variant significantly worse at the check "
            "points than another, then the lowest rms over held-out control and check points within its noise, "
            "then BIC within groups of identical observations and the most control points."))
        items = []
        if evidence.get("margin"):
            items.append(f"margin: {evidence['margin']}")
        if evidence.get("cv_choice") or evidence.get("check_choice"):
            items.append(f"the cross-validation alone would choose {evidence.get('cv_choice') or '-'}, the check "
                         f"points alone {evidence.get('check_choice') or '-'}")
        if (evidence.get("independent_check") or {}).get("text"):
            items.append(evidence["independent_check"]["text"])
        sec.parts.append(html.bullet_list(items))
        if evidence.get("disagreement"):
            sec.parts.append(html.paragraph(f"The evidence disagrees: {evidence['disagreement']}.", "note warn"))
        for other, why in (evidence.get("contradicts_checks") or {}).items():
            sec.parts.append(html.paragraph(f"{comparison.recommended} is significantly worse at the check points "
                                            f"than {other}: {why}.", "note warn"))
        sec.parts.append(html.table(*tables["cross-validation"], table_id="crossvalidation-table",
                                    text_columns=(0, 6, 7)))
    if "correlations" in tables:
        sec.parts.append("<h3>Correlated unknowns (|r| &gt; 0.95)</h3>")
        kinds = correlation_kinds(comparison)
        sec.parts.append(html.bullet_list([f"{kind}: {text}" for kind, (text, _) in kinds.items()]))
        sec.parts.append(html.table(*tables["correlations"], table_id="correlations-table",
                                    text_columns=(0, 1, 2), wide_columns=(2,)))
    return sec


__all__ = ["diagnosis_section", "misclosure_plot"]
