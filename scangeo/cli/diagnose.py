"""``scangeo diagnose PROJECT``: problem strips and their breaks from an SE adjustment, and variants for them.

A thin shell over :func:`scangeo.diagnose` (``scangeo.workflow``).
"""
from __future__ import annotations

import sys


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
    p.add_argument("--dtm-height-points", nargs="+", default=["*"], metavar="PATTERN",
                   help="glob patterns of the tie points on open terrain (default: all)")
    p.add_argument("--max-breaks", type=int, default=4, help="most breaks per strip (default 4)")
    p.add_argument("--no-refine", dest="refine", action="store_false",
                   help="keep the BIC's break lines (default: place each by adjusting the S model around it)")
    p.add_argument("--no-variants", dest="variants", action="store_false",
                   help="do not write PROJECT/variants.toml")
    p.add_argument("--overwrite", action="store_true", help="replace an existing PROJECT/variants.toml")
    p.set_defaults(func=run, writes_project=True)  # one run at a time (scangeo.atomic.OutputLock)


def run(args) -> int:
    # here, not at the top: start-up cost (see scangeo.cli)
    from scangeo.adjustment.diagnosis.output import summary_lines
    from scangeo.cli import progress_of
    from scangeo.workflow import diagnose

    run = diagnose(args.project, dtm_height_points=args.dtm_height_points, max_breaks=args.max_breaks,
                   refine=args.refine, variants=args.variants, overwrite=args.overwrite, progress=progress_of(args))
    print("\n".join(summary_lines(run.diagnosis)))
    print("written: " + ", ".join(str(f) for f in run.files), file=sys.stderr)
    return 0
