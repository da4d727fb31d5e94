"""``scangeo diagnose PROJECT``: problem strips and their breaks from an SE adjustment, and variants for them.

A thin shell over :func:`scangeo.diagnose` (``scangeo.workflow``).
"""
from __future__ import annotations

import argparse
import sys

from scangeo.cli import option_argument


def add_parser(subparsers, common) -> None:
    p = subparsers.add_parser(
        "diagnose", parents=[common], help="find problem strips and breaks; write variants.toml for them",
        description="Adjust the project with strip models of degree 0 (SE, no DTM heights), fit C0 piecewise-linear "
                    "error functions to the tie points' DTM misclosures and the control points' image residuals along "
                    "each strip, choose breaks by BIC and place each by adjusting the split model around it "
                    "(docs/adjustment.md, 'Diagnosis'), write PROJECT/results/diagnosis.{json,md} and "
                    "PROJECT/variants.toml with P and S variants for the "
                    "problem strips found. Check points are not used.",
    )
    p.add_argument("project", help="the project folder")
    option_argument(p, "--dtm-height-points", nargs="+", metavar="PATTERN",
                    option="scangeo.workflow:diagnose.dtm_height_points",
                    help="glob patterns of the tie points on open terrain")
    option_argument(p, "--max-breaks", type=int, metavar="N", option="scangeo.workflow:diagnose.max_breaks",
                    help="most breaks per strip")
    option_argument(p, "--refine", action=argparse.BooleanOptionalAction, option="scangeo.workflow:diagnose.refine",
                    help="place each break by adjusting the S model around it (--no-refine: keep the BIC's lines)")
    option_argument(p, "--write-variants", action=argparse.BooleanOptionalAction,
                    option="scangeo.workflow:diagnose.write_variants", help="write PROJECT/variants.toml")
    option_argument(p, "--overwrite", action=argparse.BooleanOptionalAction,
                    option="scangeo.workflow:diagnose.overwrite", help="replace an existing PROJECT/variants.toml")
    p.set_defaults(func=run, writes_project=True)  # one run at a time (scangeo.atomic.OutputLock)


def run(args) -> int:
    # here, not at the top: start-up cost (see scangeo.cli)
    from scangeo.adjustment.diagnosis.output import summary_lines
    from scangeo.cli import passed, progress_of
    from scangeo.workflow import diagnose

    run = diagnose(args.project, progress=progress_of(args),
                   **passed(args, "dtm_height_points", "max_breaks", "refine", "write_variants", "overwrite"))
    print("\n".join(summary_lines(run.diagnosis)))
    print("written: " + ", ".join(str(f) for f in run.files), file=sys.stderr)
    return 0
