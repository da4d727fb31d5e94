"""``scangeo info FILE``: what a trajectory, DTM, image, points file or project holds.

A thin shell over :func:`scangeo.io.summary.summarise`.
"""
from __future__ import annotations

import argparse
import json

#: The kinds of file ``scangeo.io.summary`` summarises (its ``KINDS``; listed here so that --help does not
#: import the readers, tests/cli/test_info.py checks they agree).
KINDS = ("trajectory", "dtm", "image", "points", "ground", "project")


def add_parser(subparsers, common: argparse.ArgumentParser) -> None:
    p = subparsers.add_parser(
        "info", parents=[common], help="summarise a trajectory, DTM, image, points file or project",
        description="Summarise a file by its kind (found from its extension and content): a trajectory "
        "(records, rate, time span, extent, attitude ranges), a DTM (size, CRS, resolution, heights, "
        "nodata), an image (lines x pixels x bands), points.csv / ground.csv (counts) or a project "
        "folder / project.toml (CRS, sensor, strips, time spans, point counts).",
    )
    p.add_argument("file", metavar="FILE", help="file or project folder")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--kind", choices=KINDS, help="the file's kind (default: detected)")
    p.add_argument("--crs", help="map CRS of a trajectory CSV with x,y,z columns (e.g. EPSG:32615)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    # here, not at the top: start-up cost (see scangeo.cli)
    from scangeo.errors import TrajectoryError
    from scangeo.io.summary import summarise, summary_text

    try:
        summary = summarise(args.file, kind=args.kind, crs=args.crs)
    except TrajectoryError as exc:
        if args.crs is None and "need the CRS" in str(exc):
            raise TrajectoryError(f"{exc}; give it with --crs") from exc
        raise
    print(json.dumps(summary, indent=2) if args.json else summary_text(summary))
    return 0
