"""``scangeo locate PROJECT --strip ID [--variant NAME] (--image pts.csv | --ground pts.csv) [-o out.csv]``.

Image points -> map coordinates on the DTM, or map points -> image coordinates, for one strip with
direct georeferencing or a variant's adjusted orientation (its ``orientation.json``). A thin shell
over :mod:`scangeo.locate`.
"""
from __future__ import annotations

import argparse
import csv
import sys


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
    p.add_argument("--variant", default="DG",
                   help="orientation: DG (the GPS/IMU as measured, default) or an adjusted variant "
                        "(PROJECT/results/NAME/orientation.json)")
    which = p.add_mutually_exclusive_group(required=True)
    which.add_argument("--image", metavar="CSV", help="image points: point,line,pixel")
    which.add_argument("--ground", metavar="CSV", help="map points: point,x,y[,z]")
    p.add_argument("-o", "--output", metavar="CSV", help="output CSV (default: standard output)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from scangeo.io.project import Project
    from scangeo.locate import locate_ground_file, locate_image_file
    from scangeo.orientation.file import FILE_NAME, load_adjusted_geometry, results_folder

    project = Project.load(args.project)
    project.strip(args.strip)  # an unknown strip is named before any orientation is read
    if args.variant.upper() == "DG" and not (results_folder(project, args.variant) / FILE_NAME).exists():
        # direct georeferencing unchecked: lines beyond the trajectory are answered point by point
        geometry = project.geometry(args.strip, check=False)
    else:
        geometry = load_adjusted_geometry(project, args.variant, args.strip)
    if args.image:
        result = locate_image_file(project, args.strip, args.image, geometry)
    else:
        result = locate_ground_file(project, args.strip, args.ground, geometry)
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
