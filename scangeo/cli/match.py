"""``scangeo match PROJECT``: measure tie points (and control against reference orthoimages).

A thin shell over :func:`scangeo.match_points` (``scangeo.workflow``): the ``[match]`` settings of the
project's settings file (PROJECT/run.toml or ``--config``, docs/run.md) replaced by the flags, a
progress bar, a summary per overlap and per strip.
"""
from __future__ import annotations

import argparse

from scangeo.cli import option_argument, settings_argument

_OPTIONS = "scangeo.match.options:MatchOptions"


def add_parser(subparsers, common) -> None:
    p = subparsers.add_parser(
        "match", parents=[common], help="measure tie and control points automatically (points.csv, ground.csv)",
        description="Measure tie points between overlapping strips and, with --reference, control and check "
        "points against reference orthoimages (docs/match.md). Matched rows of points.csv and ground.csv "
        "are replaced; other rows are kept. The report goes to PROJECT/results/match_report.json. Settings: "
        "the [match] table of PROJECT/run.toml (or --config), replaced by the flags.",
    )
    p.add_argument("project", help="the project folder")
    option_argument(p, "--variant", option="scangeo.workflow:match_points.variant",
                    help="orientation that predicts where to look")
    p.add_argument("--reference", dest="references", nargs="+", default=[], metavar="ORTHO",
                   help="reference orthoimage(s) for control points (any raster with a CRS)")
    p.add_argument("--reference-dtm", default=None, metavar="DTM",
                   help="heights of control points (default: the project's DTM)")
    p.add_argument("--reference-dtm-sigma", type=float, default=None, metavar="M",
                   help="accuracy of the reference DTM, m (default: the project's dtm_sigma_m)")
    option_argument(p, "--per-overlap", type=int, metavar="N", option=f"{_OPTIONS}.per_overlap",
                    help="tie points per overlap")
    option_argument(p, "--control-per-strip", type=int, metavar="N", option=f"{_OPTIONS}.control_per_strip",
                    help="control and check points per strip and reference")
    option_argument(p, "--check-share", type=float, metavar="SHARE", option=f"{_OPTIONS}.check_share",
                    help="share of control points held back as check points")
    option_argument(p, "--bands", type=int, nargs="+", metavar="B", option=f"{_OPTIONS}.bands",
                    help="1-based strip bands to match on")
    settings_argument(p)
    option_argument(p, "--workers", type=int, metavar="N", option="scangeo.workflow:match_points.workers",
                    help="tasks run at once (local processes)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS", help="run the tasks on a Dask distributed scheduler")
    p.set_defaults(func=run, writes_project=True)


def options_of(args: argparse.Namespace):
    """MatchOptions of the settings file (``--config`` or PROJECT/run.toml) with the flags given."""
    # here, not at the top: start-up cost (see scangeo.cli)
    from scangeo.cli import project_settings, with_flags

    return with_flags(project_settings(args).match, args)


def run(args: argparse.Namespace) -> int:
    # here, not at the top: start-up cost (see scangeo.cli)
    from scangeo.cli import passed, progress_of
    from scangeo.workflow import match_points

    result = match_points(
        args.project, references=args.references, reference_dtm=args.reference_dtm,
        reference_dtm_sigma=args.reference_dtm_sigma, options=options_of(args), scheduler=args.scheduler,
        progress=progress_of(args), **passed(args, "variant", "workers"),
    )
    print(summary_text(result.report))
    print(f"written: {result.points_file}, {result.ground_file if result.ground_rows else '(no ground rows)'}, "
          f"{result.report_file} ({result.seconds:.1f} s)")
    return 0


def summary_text(report: dict) -> str:
    """The report in a few lines: per overlap, per strip and reference, the totals."""
    lines = []
    for name, o in report["overlaps"].items():
        cons = "; ".join(f"precision {s['precision_cells']:.2f} cells" for s in o.get("consistency", {}).values())
        rejected = ", ".join(f"{k} {v}" for k, v in sorted(o.get("rejected", {}).items())) or "none"
        lines.append(f"overlap {name}: {o.get('points', 0)} tie points in {o['cells']} cells "
                     f"({o.get('cells_without_points', 0)} without; {o.get('triples', 0)} in 3+ strips; "
                     f"rejected: {rejected}){'; ' + cons if cons else ''}")
    for sid in report.get("strips_without_overlap", []):
        lines.append(f"strip {sid}: overlaps no other strip, no tie points")
    for name, c in report["control"].items():
        if not c.get("cells"):
            lines.append(f"control {name}: the reference does not cover this strip")
            continue
        rejected = ", ".join(f"{k} {v}" for k, v in sorted(c.get("rejected", {}).items())) or "none"
        lines.append(f"control {name}: {c.get('points', 0) - c.get('check', 0)} control + {c.get('check', 0)} check "
                     f"in {c['cells']} cells (rejected: {rejected})")
    s = report["summary"]
    lines.append(f"{s['tie_points']} tie, {s['control_points']} control, {s['check_points']} check points; "
                 f"{s['measurements']} measurements; rejected {100 * s['rejected_share']:.0f} % of "
                 f"{s['candidates']} candidates")
    return "\n".join(lines)
