"""``scangeo report PROJECT``: the HTML residual report and GeoPackage of a compared project.

A thin shell over :func:`scangeo.report` (it reads what ``scangeo compare`` wrote).
"""
from __future__ import annotations

import argparse

from scangeo.cli import option_argument


def add_parser(subparsers, common) -> None:
    p = subparsers.add_parser(
        "report", parents=[common], help="write the HTML residual report of a compared project",
        description="Write PROJECT/results/report.html (one self-contained file: the comparison table, residual "
                    "vectors, correction functions, GPS/IMU data, accounting, notes) and residuals.gpkg from the "
                    "results of 'scangeo compare' (docs/reports.md).",
    )
    p.add_argument("project", help="the project folder (compared with 'scangeo compare')")
    option_argument(p, "--geopackage", action=argparse.BooleanOptionalAction,
                    option="scangeo.workflow:report.geopackage", help="also write residuals.gpkg")
    p.set_defaults(func=run, writes_project=True)  # one run at a time (scangeo.atomic.OutputLock)


def run(args) -> int:
    # here, not at the top: start-up cost (see scangeo.cli)
    from scangeo.cli import passed, progress_of
    from scangeo.workflow import report

    files = report(args.project, progress=progress_of(args), **passed(args, "geopackage"))
    print(f"report: {files.html} ({files.figures} figures)")
    if files.geopackage:
        print(f"residual vectors: {files.geopackage}")
    return 0
