"""``scangeo compare PROJECT``: every strategy of a variants file, the comparison table and the report.

A thin shell over :func:`scangeo.compare` (``scangeo.workflow``).
"""
from __future__ import annotations

import argparse
import sys

from scangeo.cli import option_argument, settings_argument


def add_parser(subparsers, common) -> None:
    p = subparsers.add_parser(
        "compare", parents=[common], help="adjust every strategy of a variants file and compare them",
        description="Run every variant (docs/adjustment.md) on the project, write each one's results to "
                    "PROJECT/results/NAME/, the comparison table to PROJECT/results/comparison.{md,csv,json} and "
                    "the report (report.html, residuals.gpkg; docs/reports.md). Without PROJECT/variants.toml the "
                    "project is diagnosed (scangeo diagnose: problem strips and breaks from an SE adjustment) and the "
                    "default variants (shipped with scangeo; docs/reports.md) are filled in and written there. A "
                    "cross-validation over the control points, weighed with the check points, recommends a variant. "
                    "Settings: the [compare] table of PROJECT/run.toml (or --config), replaced by the flags.",
    )
    p.add_argument("project", help="the project folder")
    p.add_argument("--variants", dest="variants_file", default=None, metavar="FILE",
                   help="variants file (default PROJECT/variants.toml)")
    p.add_argument("--only", nargs="+", default=None, metavar="NAME", help="run only these variants")
    option_argument(p, "--reference-variant", metavar="NAME", option="scangeo.workflow:compare.reference_variant",
                    help="the variant that is 100 %%")
    p.add_argument("--problem-strip", default=None, metavar="ID",
                   help="for the default variants: the strip with the GPS/IMU problem (default: diagnosed)")
    p.add_argument("--breaks-lines", type=float, nargs="+", default=None, metavar="LINE",
                   help="for the default variants: the problem strip's break lines")
    option_argument(p, "--folds", type=int, metavar="N", option="scangeo.pipeline.settings:CompareSettings.folds",
                    help="folds of the cross-validation over the control points (0: none)")
    option_argument(p, "--report", action=argparse.BooleanOptionalAction, option="scangeo.workflow:compare.report",
                    help="also write report.html and residuals.gpkg (--no-report: the tables only)")
    settings_argument(p)
    p.set_defaults(func=run, writes_project=True)  # one run at a time (scangeo.atomic.OutputLock)


def run(args) -> int:
    # here, not at the top: start-up cost (see scangeo.cli)
    from scangeo.cli import passed, progress_of, project_settings, with_flags
    from scangeo.reports.tables import markdown_tables, text_table
    from scangeo.workflow import compare

    settings = with_flags(project_settings(args).compare, args)
    run = compare(args.project, variants_file=args.variants_file, names=args.only, problem_strip=args.problem_strip,
                  breaks_lines=args.breaks_lines, folds=settings.folds, progress=progress_of(args),
                  **passed(args, "reference_variant", "report"))
    comparison = run.comparison
    print(text_table(*markdown_tables(comparison)["check points"]))
    if comparison.best:
        print(f"reference {comparison.reference}; best (lowest check-point rms): {comparison.best}")
    if comparison.recommended:
        cv = comparison.crossvalidation or {}
        evidence = cv.get("evidence") or {}
        print(f"recommended: {comparison.recommended} ({cv.get('reason', '')})")
        if evidence.get("margin"):
            print(f"  margin: {evidence['margin']}")
        if evidence.get("disagreement"):
            print(f"  THE EVIDENCE DISAGREES: {evidence['disagreement']}")
        for other, why in (evidence.get("contradicts_checks") or {}).items():
            print(f"  NOTE: {comparison.recommended} is significantly worse at the check points than {other}: {why}")
        if (evidence.get("independent_check") or {}).get("text"):
            print(f"  {evidence['independent_check']['text']}")
    for v in comparison.variants:
        if v.error:
            print(f"variant {v.name} failed: {v.error}")
    print("tables: " + ", ".join(str(p) for p in run.files), file=sys.stderr)
    if run.report:
        files = run.report
        print(f"report: {files.html}" + (f", {files.geopackage}" if files.geopackage else ""), file=sys.stderr)
    return 0
