"""The comparison table as Markdown, CSV and JSON (``PROJECT/results/comparison.{md,csv,json}``).

* Markdown: one row per variant: type, control configuration, maximum degree, sigma0 and sigma0 in
  % of the reference, and per strip the number of check-point measurements and their rms along and
  across track in pixels with the % of the reference; a second table with the accounting; on a
  simulated project a third with the true error of every variant.
* CSV: one row per variant and strip with every figure (a tidy table for spreadsheets).
* JSON: :meth:`Comparison.as_dict` (what ``scangeo report`` reads back).

Every file is written under a temporary name and renamed.
"""
from __future__ import annotations

import csv
import io
import json
from pathlib import Path

from scangeo.adjustment.summary import Comparison, VariantSummary
from scangeo.atomic import write_text
from scangeo.errors import ProjectFileError
from scangeo.reports.correlations import explanation, pair_kind

FILES = ("comparison.md", "comparison.csv", "comparison.json")


def _f(x, digits: int = 2) -> str:
    return "–" if x is None else f"{x:.{digits}f}"


def _pct(x) -> str:
    return "" if x is None else f" ({x:.0f} %)"


def _check_cell(c: Comparison, v: VariantSummary, sid: str, key: str) -> str:
    value = v.strips.get(sid, {}).get("check", {}).get(f"rms_{key}_px")
    return _f(value) + _pct(c.check_percent(v, sid, key))


def markdown_tables(c: Comparison) -> dict[str, tuple[list[str], list[list[str]]]]:
    """The tables (header, rows) by title: ``check points``, ``accounting`` and, with truth, ``true error``."""
    ident = f"{c.reference}_DTM"
    head = ["variant", "type", "control", "max degree", "sigma0", f"sigma0 % {c.reference} (paper: other observations)",
            f"sigma0 % {ident} (same observations)"]
    for sid in c.strips:
        head += [f"{sid} n", f"{sid} along px (%)", f"{sid} across px (%)"]
    rows = []
    for v in c.variants:
        if v.error:
            rows.append([v.name, v.strategy, f"failed: {v.error}"] + [""] * (len(head) - 3))
            continue
        row = [v.name, v.strategy, v.control_label, "–" if v.max_degree is None else str(v.max_degree),
               _f(v.sigma0, 3), _f(c.sigma0_percent(v), 0), _f(c.sigma0_identical_percent(v), 0)]
        for sid in c.strips:
            row += [str(v.strips.get(sid, {}).get("check", {}).get("n", 0)),
                    _check_cell(c, v, sid, "along"), _check_cell(c, v, sid, "across")]
        rows.append(row)
    tables = {"check points": (head, rows)}
    acc_head = ["variant", "description", "DTM heights", "observations", "pseudo-observations", "parameters",
                "conditions", "unknowns", "redundancy", "rejected", "regularised", "converged", "seconds"]
    acc_rows = []
    for v in c.variants:
        a = v.accounting
        acc_rows.append([v.name, v.description, str(v.dtm_heights)] + [str(a.get(k, "")) for k in (
            "observations", "pseudo_observations", "parameters", "conditions", "unknowns", "redundancy")]
            + [str(v.rejected), str(v.regularised), "yes" if v.converged else "NO", f"{v.seconds:.1f}"])
    tables["accounting"] = (acc_head, acc_rows)
    if c.truth:
        t_head = ["variant"]
        for sid in c.strips:
            t_head += [f"{sid} along px", f"{sid} across px", f"{sid} ground m"]
        t_rows = []
        for v in c.variants:
            row = [v.name]
            for sid in c.strips:
                t = v.strips.get(sid, {}).get("true", {})
                row += [_f(t.get("rms_along_px")), _f(t.get("rms_across_px")), _f(t.get("rms_ground_m"))]
            t_rows.append(row)
        tables["true error"] = (t_head, t_rows)
    cv = c.crossvalidation
    if cv:
        evidence = cv.get("evidence") or {}
        rms = evidence.get("rms_px") or {}
        rejected = evidence.get("rejected_by_checks") or {}
        cv_head = ["variant", "cross-validated rms px", "held-out measurements", "check-point rms px",
                   "held-out and check rms px", "AIC", "observations (group)",
                   "significantly worse at check points than", "recommended"]
        cv_rows = [[v.name, _f(cv["rms_px"].get(v.name), 3), str(cv["n"].get(v.name, "")),
                    _f((rms.get(v.name) or {}).get("check"), 3), _f((rms.get(v.name) or {}).get("all"), 3),
                    _f(cv.get("aic", {}).get(v.name), 1), cv["group"].get(v.name, ""),
                    ", ".join(rejected.get(v.name, {})) or "-",
                    "**yes**" if v.name == cv.get("recommended") else ""] for v in c.variants if v.error is None]
        tables["cross-validation"] = (cv_head, cv_rows)
    kinds = correlation_kinds(c)
    if kinds:
        rows = [[kind, variant, ", ".join(f"{model} {r:+.3f}" for model, r in pairs)]
                for kind, (_, by_variant) in kinds.items() for variant, pairs in by_variant.items()]
        tables["correlations"] = (["pair", "variant", "models (r)"], rows)
    return tables


def correlation_kinds(c: Comparison) -> dict[str, tuple[str, dict[str, list[tuple[str, float]]]]]:
    """The correlated pairs of all variants by kind of pair (``shift in x ~ roll``), the most frequent
    kind first: ``{kind: (explanation, {variant: [(model, r)]})}``; each kind is explained once."""
    kinds: dict[str, tuple[str, dict[str, list[tuple[str, float]]]]] = {}
    for v in c.variants:
        for p in v.correlations:
            kind = pair_kind(p["a"], p["b"])
            entry = kinds.setdefault(kind, (explanation(p["a"], p["b"]), {}))
            entry[1].setdefault(v.name, []).append((p["model"], p["r"]))
    return dict(sorted(kinds.items(), key=lambda kv: -sum(map(len, kv[1][1].values()))))


def text_table(head: list[str], rows: list[list[str]]) -> str:
    """A plain-text table with aligned columns (for the terminal)."""
    widths = [max(len(str(x)) for x in col) for col in zip(head, *rows)]
    return "\n".join("  ".join(str(x).ljust(w) for x, w in zip(r, widths)).rstrip() for r in [head, *rows])


def _md_table(head: list[str], rows: list[list[str]]) -> str:
    def esc(s):
        return str(s).replace("|", "\\|")
    lines = ["| " + " | ".join(map(esc, head)) + " |", "|" + "---|" * len(head)]
    lines += ["| " + " | ".join(map(esc, r)) + " |" for r in rows]
    return "\n".join(lines)


def markdown(c: Comparison) -> str:
    """The comparison as a Markdown document."""
    tables = markdown_tables(c)
    best = c.best
    rec = c.recommended
    out = [f"# Comparison of strategies: {c.project}", "",
           f"Variants from `{c.variants_file}`. Reference: **{c.reference}** (100 %)"
           + (f"; best (lowest check-point rms): **{best}**" if best else "")
           + (f"; recommended (cross-validation weighed with the check points): **{rec}**." if rec else "."),
           f"sigma0 % {c.reference}: the paper's ratio (P/S carry DTM heights the reference does not); sigma0 % "
           f"{c.reference}_DTM: over the same observations (the reference run with the same DTM heights).",
           "Check points: rms of the residuals (model - measured) along track in lines (= pixels) and across "
           "track in pixels, per strip, with the % of the reference.", "",
           _md_table(*tables["check points"]), "", "## Accounting", "", _md_table(*tables["accounting"])]
    if "true error" in tables:
        out += ["", "## True error (simulated project)", "",
                "rms of the adjusted orientation's error against truth/ over a grid of image positions: "
                "along and across track in pixels, horizontal ground error in metres.", "",
                _md_table(*tables["true error"])]
    if "cross-validation" in tables:
        cv = c.crossvalidation or {}
        evidence = cv.get("evidence") or {}
        out += ["", "## Recommendation", "",
                f"{cv.get('folds')}-fold cross-validation over the {cv.get('points')} control points (each fold "
                "held out as check points in turn; rms along and across together), weighed with the check points "
                "(docs/reports.md), and AIC over identical observations. "
                f"Recommended: **{rec}** ({cv.get('reason', '')}).", ""]
        notes = [f"margin: {evidence['margin']}" if evidence.get("margin") else "",
                 (f"the cross-validation alone would choose {evidence.get('cv_choice') or '-'}, the check points alone "
                  f"{evidence.get('check_choice') or '-'}") if evidence.get("cv_choice") else "",
                 f"**the evidence disagrees**: {evidence['disagreement']}" if evidence.get("disagreement") else "",
                 *(f"**{rec} is significantly worse at the check points than {k}**: {v}"
                   for k, v in (evidence.get("contradicts_checks") or {}).items()),
                 (evidence.get("independent_check") or {}).get("text", "")]
        out += [f"* {n}" for n in notes if n] + ["", _md_table(*tables["cross-validation"])]
    if "correlations" in tables:
        out += ["", "## Correlated unknowns (|r| > 0.95)", ""]
        out += [f"* **{kind}**: {text}" for kind, (text, _) in correlation_kinds(c).items()]
        out += ["", _md_table(*tables["correlations"])]
    return "\n".join(out) + "\n"


CSV_FIELDS = ["variant", "type", "description", "control", "dtm_heights", "max_degree", "unknowns", "redundancy",
              "rejected", "sigma0", "sigma0_percent", "sigma0_identical_percent", "cv_rms_px", "strip", "check_n",
              "check_rms_along_px",
              "check_rms_across_px", "check_along_percent", "check_across_percent", "control_n",
              "control_rms_along_px", "control_rms_across_px", "true_n", "true_rms_along_px", "true_rms_across_px",
              "true_rms_ground_m", "true_max_ground_m", "error"]


def csv_text(c: Comparison) -> str:
    """One row per variant and strip (``CSV_FIELDS``); empty cells where a figure does not exist."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(CSV_FIELDS)
    def g(x):
        return "" if x is None else (f"{x:.6g}" if isinstance(x, float) else str(x))
    for v in c.variants:
        for sid in c.strips:
            e = v.strips.get(sid, {})
            ch, co, tr = e.get("check", {}), e.get("control", {}), e.get("true", {})
            w.writerow([g(x) for x in (
                v.name, v.strategy, v.description, v.control_label, v.dtm_heights, v.max_degree,
                v.accounting.get("unknowns"), v.accounting.get("redundancy"), v.rejected, v.sigma0,
                c.sigma0_percent(v), c.sigma0_identical_percent(v),
                (c.crossvalidation or {}).get("rms_px", {}).get(v.name), sid, ch.get("n"), ch.get("rms_along_px"),
                ch.get("rms_across_px"),
                c.check_percent(v, sid, "along"), c.check_percent(v, sid, "across"), co.get("n"),
                co.get("rms_along_px"), co.get("rms_across_px"), tr.get("n"), tr.get("rms_along_px"),
                tr.get("rms_across_px"), tr.get("rms_ground_m"), tr.get("max_ground_m"), v.error)])
    return buf.getvalue()


def _write(path: Path, text: str) -> None:
    write_text(path, text)


def write_comparison(c: Comparison, folder=None) -> list[Path]:
    """Write comparison.md, .csv and .json to ``folder`` (default PROJECT/results); returns the paths."""
    out = Path(folder) if folder else Path(c.project) / "results"
    out.mkdir(parents=True, exist_ok=True)
    texts = (markdown(c), csv_text(c), json.dumps(c.as_dict(), indent=1) + "\n")
    paths = [out / name for name in FILES]
    for p, t in zip(paths, texts):
        _write(p, t)
    return paths


def read_comparison(folder) -> Comparison:
    """The comparison written by :func:`write_comparison` (``PROJECT/results/comparison.json``)."""
    path = Path(folder) / "comparison.json"
    if not path.exists():
        raise ProjectFileError(f"{path}: no comparison yet (run 'scangeo compare' on the project first)")
    try:
        return Comparison.from_dict(json.loads(path.read_text(encoding="utf-8")))
    except (ValueError, KeyError, TypeError) as exc:
        raise ProjectFileError(f"{path}: not a comparison written by scangeo compare ({exc})") from exc


__all__ = ["CSV_FIELDS", "FILES", "csv_text", "markdown", "markdown_tables", "read_comparison", "text_table",
           "write_comparison"]
