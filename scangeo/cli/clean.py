"""``scangeo clean PROJECT``: find the blunders among the measurements and set them aside.

A thin shell over :func:`scangeo.strategy.cleaning.clean` (and :func:`~scangeo.strategy.cleaning.restore`).
"""
from __future__ import annotations

import sys


def add_parser(subparsers, common) -> None:
    p = subparsers.add_parser(
        "clean", parents=[common], help="find blunders by a robust adjustment and set them aside",
        description="Adjust the block once in a flexible model (every strip split into pieces, a linear GPS/IMU "
                    "correction per piece, DTM heights at tie points, check points as control) with data snooping, "
                    "and write the measurements it rejects to PROJECT/results/cleaning/rejected.csv (with w, MDB and "
                    "separability) and cleaning.json. Every later adjustment (diagnose, adjust, compare, "
                    "cross-validation) leaves them out; --restore brings them back (docs/adjustment.md, 'Cleaning').",
    )
    p.add_argument("project", help="the project folder")
    p.add_argument("--piece-lines", type=float, default=None, metavar="LINES",
                   help="length of the pieces of the flexible model (default 700 lines)")
    p.add_argument("--critical-value", type=float, default=None, metavar="W",
                   help="critical value of |w| (default 3.29, alpha0 = 0.1 %%)")
    p.add_argument("--dtm-height-points", nargs="+", default=None, metavar="PATTERN",
                   help="glob patterns of the tie points on open terrain (default: all)")
    p.add_argument("--restore", action="store_true",
                   help="bring every set-aside measurement back (delete PROJECT/results/cleaning/) and exit")
    p.set_defaults(func=run, writes_project=True)  # one run at a time (scangeo.atomic.OutputLock)


def run(args) -> int:
    from dataclasses import replace

    # here, not at the top: start-up cost (see scangeo.cli)
    from scangeo.cli import progress_of
    from scangeo.strategy.cleaning import CleaningOptions, clean, restore, summary_lines

    if args.restore:
        done = restore(args.project)
        print("cleaning removed: every measurement is used again" if done else "no cleaning to remove")
        return 0
    options = CleaningOptions()
    if args.piece_lines is not None:
        options = replace(options, piece_lines=args.piece_lines)
    if args.critical_value is not None:
        options = replace(options, critical_value=args.critical_value)
    if args.dtm_height_points is not None:
        options = replace(options, dtm_height_points=tuple(args.dtm_height_points))
    cleaning = clean(args.project, options, progress_of(args))
    print("\n".join(summary_lines(cleaning)))
    print(f"written: {cleaning.project}/results/cleaning/rejected.csv, cleaning.json", file=sys.stderr)
    return 0
