"""``scangeo match PROJECT``: measure tie points (and control against reference orthoimages).

A thin shell over :func:`scangeo.match_points` (``scangeo.workflow``): settings from ``--config`` (a TOML file
with a ``[match]`` table, docs/match.md) overridden by the flags, a progress bar, a summary per
overlap and per strip.
"""
from __future__ import annotations

import argparse


def add_parser(subparsers, common) -> None:
    p = subparsers.add_parser(
        "match", parents=[common], help="measure tie and control points automatically (points.csv, ground.csv)",
        description="Measure tie points between overlapping strips and, with --reference, control and check "
        "points against reference orthoimages (docs/match.md). Matched rows of points.csv and ground.csv "
        "are replaced; other rows are kept.",
    )
    p.add_argument("project", help="the project folder")
    p.add_argument("--variant", default="DG", help="orientation that predicts where to look (default: DG)")
    p.add_argument("--reference", nargs="+", default=[], metavar="ORTHO",
                   help="reference orthoimage(s) for control points (any raster with a CRS)")
    p.add_argument("--reference-dtm", default=None, metavar="DTM",
                   help="heights of control points (default: the project's DTM)")
    p.add_argument("--reference-dtm-sigma", type=float, default=None, metavar="M",
                   help="accuracy of the reference DTM, m (default: the project's dtm_sigma_m)")
    p.add_argument("--per-overlap", type=int, default=None, dest="per_overlap", help="tie points per overlap (60)")
    p.add_argument("--control-per-strip", type=int, default=None, dest="control_per_strip",
                   help="control and check points per strip and reference (30)")
    p.add_argument("--check-share", type=float, default=None, dest="check_share",
                   help="share of control points held back as check points (0.3)")
    p.add_argument("--bands", type=int, nargs="+", default=None, metavar="B",
                   help="1-based strip bands to match on (default: visible bands, never thermal)")
    p.add_argument("--config", default=None, help="TOML file with a [match] table of settings")
    p.add_argument("--workers", type=int, default=1, help="tasks run at once (local processes)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS", help="run the tasks on a Dask distributed scheduler")
    p.set_defaults(func=run, writes_project=True)


def options_of(args: argparse.Namespace):
    """MatchOptions from ``--config`` and the flags (flags win)."""
    # here, not at the top: start-up cost (see scangeo.cli)
    from scangeo.cli import settings_table
    from scangeo.match.options import MatchOptions

    table = settings_table(args.config, "match")
    for key in ("per_overlap", "control_per_strip", "check_share", "bands"):
        value = getattr(args, key)
        if value is not None:
            table[key] = value
    return MatchOptions.from_dict(table, source=f"{args.config} [match]" if args.config else "match options")


def run(args: argparse.Namespace) -> int:
    # here, not at the top: start-up cost (see scangeo.cli)
    from scangeo.cli import progress_of
    from scangeo.workflow import match_points

    result = match_points(
        args.project, args.variant, references=args.reference, reference_dtm=args.reference_dtm,
        reference_dtm_sigma=args.reference_dtm_sigma, options=options_of(args), workers=args.workers,
        scheduler=args.scheduler, progress=progress_of(args),
    )
    print(summary_text(result.report))
    print(f"written: {result.points_file}, {result.ground_file if result.ground_rows else '(no ground rows)'}, "
          f"match_report.json ({result.seconds:.1f} s)")
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
