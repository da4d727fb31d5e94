"""The diagnosis's outputs: ``PROJECT/results/diagnosis.json`` and ``diagnosis.md``, and its summary.

``diagnosis.json`` holds the problem strips, the breaks with their 95 % intervals, the criterion
(BIC with and without breaks, parameters, serial correlation), the attribution (per problem strip its
runner-up, the criterion difference, whether it is ambiguous, and the plausible other attributions
with their breaks; :mod:`~.attribution`) and, per strip, the series the fit saw (tie-point DTM
misclosures and image residuals by line), which the report plots.
"""
from __future__ import annotations

import json
from pathlib import Path

from scangeo.adjustment.diagnosis.diagnose import Diagnosis
from scangeo.atomic import write_text


def summary_lines(d: Diagnosis) -> list[str]:
    """Plain-text lines: the verdict per strip and every break with its interval."""
    c = d.fit
    out = [f"diagnosis of {d.project}: SE (degree 0, no DTM heights) sigma0 {d.sigma0:.3f}; "
           f"BIC {c.bic:.1f} with breaks vs {d.null.bic:.1f} without ({c.k} vs {d.null.k} parameters)"]
    constant = {d.strips[i] for i in c.constant}
    for s in d.strips:
        breaks = [b for b in d.breaks if b.strip == s]
        if breaks:
            text = ", ".join(f"line {b.line:.0f} (95 %: {b.low:.0f}-{b.high:.0f}"
                             + (f"; BIC {b.bic_line:.0f}" if b.bic_line is not None else "")
                             + (f"; F {b.f_statistic:.1f}, p {b.p_value:.2g}" if b.p_value is not None else "") + ")"
                             for b in breaks)
            out.append(f"  strip {s}: PROBLEM STRIP, breaks at {text}")
        elif s in constant:
            out.append(f"  strip {s}: good (a constant correction explains it)")
        else:
            out.append(f"  strip {s}: PROBLEM STRIP, a linear drift without breaks")
    out += [f"  {c.sentence()}" for c in d.attribution]
    out += [f"  note: {n}" for n in d.notes]
    return out


def markdown(d: Diagnosis) -> str:
    lines = ["# Diagnosis", "", *(f"    {x}" for x in summary_lines(d)), "",
             "| strip | lines | verdict | breaks (95 % interval) |", "|---|---|---|---|"]
    constant = {d.strips[i] for i in d.fit.constant}
    for s in d.strips:
        br = [b for b in d.breaks if b.strip == s]
        verdict = "good" if s in constant and not br else "problem strip"
        lines.append(f"| {s} | {d.n_lines[s]} | {verdict} | "
                     + (", ".join(f"{b.line:.0f} ({b.low:.0f}-{b.high:.0f})" for b in br) or "-") + " |")
    if d.attribution:
        lines += ["", "| problem strip | runner-up (competing attribution) | richer alternative | ambiguous |",
                  "|---|---|---|---|"]
        for c in d.attribution:
            lines.append(f"| {c.strip or 'none'} | {c.runner_up.describe() if c.runner_up else '-'} | "
                         f"{c.richer.describe() if c.richer else '-'} | {'**yes**' if c.ambiguous else 'no'} |")
    return "\n".join(lines) + "\n"


def write_diagnosis(d: Diagnosis, out_dir=None) -> list[Path]:
    """Write ``diagnosis.json`` and ``diagnosis.md`` into ``out_dir`` (default ``PROJECT/results``)."""
    out = Path(out_dir) if out_dir is not None else Path(d.project) / "results"
    out.mkdir(parents=True, exist_ok=True)
    return [write_text(out / "diagnosis.json", json.dumps(d.as_dict(), indent=1)),
            write_text(out / "diagnosis.md", markdown(d))]


def read_diagnosis(project_root) -> dict | None:
    """``PROJECT/results/diagnosis.json`` as written (None when there is none)."""
    path = Path(project_root) / "results" / "diagnosis.json"
    if not path.exists():
        return None
    return json.loads(path.read_text(encoding="utf-8"))


__all__ = ["markdown", "read_diagnosis", "summary_lines", "write_diagnosis"]
