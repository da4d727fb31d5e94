"""``scangeo locate PROJECT --strip ID [--variant NAME] (--image pts.csv | --ground pts.csv) [-o out.csv]``.

Image points -> map coordinates on the DTM, or map points -> image coordinates, for one strip with
direct georeferencing or a variant's adjusted orientation (its ``orientation.json``). A thin shell
over :func:`scangeo.locate.locate_points`.
"""
from __future__ import annotations

import argparse
import csv
import sys

from scangeo.cli import option_argument


def add_parser(subparsers, common: argparse.ArgumentParser) -> None:
    p = subparsers.add_parser(
        "locate", parents=[common], help="image points -> map coordinates, or map points -> image coordinates",
        description="For one strip with direct georeferencing or a variant's adjusted orientation: convert image "
        "points (point,line,pixel) to "
        "map coordinates x,y,z on the project's DTM, or map points (point,x,y[,z]; orthometric z, a "
        "missing z is taken from the DTM) to line,pixel. One output row per input row; NaN and a reason "
        "where there is no answer.",
    )
    p.add_argument("project", metavar="PROJECT", help="project folder or project.toml")
    p.add_argument("--strip", required=True, help="strip id")
    option_argument(p, "--variant", option="scangeo.locate:locate_points.variant",
                    help="orientation: DG (the GPS/IMU as measured) or an adjusted variant "
                         "(PROJECT/results/NAME/orientation.json)")
    which = p.add_mutually_exclusive_group(required=True)
    which.add_argument("--image", metavar="CSV", help="image points: point,line,pixel")
    which.add_argument("--ground", metavar="CSV", help="map points: point,x,y[,z]")
    p.add_argument("-o", "--output", metavar="CSV", help="output CSV (default: standard output)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    # here, not at the top: start-up cost (see scangeo.cli)
    from scangeo.cli import passed
    from scangeo.locate import locate_points

    result = locate_points(args.project, args.strip, image=args.image, ground=args.ground, **passed(args, "variant"))
    if args.output:
        result.write(args.output)
    else:
        writer = csv.writer(sys.stdout, lineterminator="\n")
        writer.writerow(result.header)
        writer.writerows(result.rows)
    missing = sum(1 for row in result.rows if "NaN" in row)
    if missing:
        print(f"scangeo locate: {missing} of {len(result.rows)} points have no answer (see the reason column)",
              file=sys.stderr)
    return 0
