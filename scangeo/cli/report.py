"""``scangeo report PROJECT``: the HTML residual report and GeoPackage of a compared project.

A thin shell over :func:`scangeo.reports.report.write_report` (it reads what ``scangeo compare`` wrote).
"""
from __future__ import annotations


def add_parser(subparsers, common) -> None:
    p = subparsers.add_parser(
        "report", parents=[common], help="write the HTML residual report of a compared project",
        description="Write PROJECT/results/report.html (one self-contained file: the comparison table, residual "
                    "vectors, correction functions, GPS/IMU data, accounting, notes) and residuals.gpkg from the "
                    "results of 'scangeo compare' (docs/reports.md).",
    )
    p.add_argument("project", help="the project folder (compared with 'scangeo compare')")
    p.add_argument("--out", default=None, help="output folder (default PROJECT/results)")
    p.add_argument("--no-geopackage", dest="geopackage", action="store_false",
                   help="do not write residuals.gpkg")
    p.set_defaults(func=run, writes_project=True)  # one run at a time (scangeo.atomic.OutputLock)


def run(args) -> int:
    # here, not at the top: start-up cost (see scangeo.cli)
    from scangeo.cli import progress_of
    from scangeo.reports.report import write_report

    files = write_report(args.project, args.out, geopackage=args.geopackage, callback=progress_of(args))
    print(f"report: {files.html} ({files.figures} figures)")
    if files.geopackage:
        print(f"residual vectors: {files.geopackage}")
    return 0
