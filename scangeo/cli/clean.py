"""``scangeo clean PROJECT``: find the blunders among the measurements and set them aside.

A thin shell over :func:`scangeo.strategy.cleaning.clean` (and :func:`~scangeo.strategy.cleaning.restore`).
"""
from __future__ import annotations

import sys

from scangeo.cli import option_argument, settings_argument

_OPTIONS = "scangeo.strategy.cleaning:CleaningOptions"


def add_parser(subparsers, common) -> None:
    p = subparsers.add_parser(
        "clean", parents=[common], help="find blunders by a robust adjustment and set them aside",
        description="Adjust the block once in a flexible model (every strip split into pieces, a linear GPS/IMU "
                    "correction per piece, DTM heights at tie points, check points as control) with data snooping, "
                    "and write the measurements it rejects to PROJECT/results/cleaning/rejected.csv (with w, MDB and "
                    "separability) and cleaning.json. Every later adjustment (diagnose, adjust, compare, "
                    "cross-validation) leaves them out; --restore brings them back (docs/adjustment.md, 'Cleaning'). "
                    "Settings: the [clean] table of PROJECT/run.toml (or --config), replaced by the flags.",
    )
    p.add_argument("project", help="the project folder")
    option_argument(p, "--piece-lines", type=float, metavar="LINES", option=f"{_OPTIONS}.piece_lines",
                    help="length of the pieces of the flexible model")
    option_argument(p, "--critical-value", type=float, metavar="W", option=f"{_OPTIONS}.critical_value",
                    help="critical value of |w| (3.29: alpha0 = 0.1 %%, two-sided)")
    option_argument(p, "--dtm-height-points", nargs="+", metavar="PATTERN", option=f"{_OPTIONS}.dtm_height_points",
                    help="glob patterns of the tie points on open terrain")
    settings_argument(p)
    p.add_argument("--restore", action="store_true",
                   help="bring every set-aside measurement back (delete PROJECT/results/cleaning/) and exit")
    p.set_defaults(func=run, writes_project=True)  # one run at a time (scangeo.atomic.OutputLock)


def run(args) -> int:
    # here, not at the top: start-up cost (see scangeo.cli)
    from scangeo.cli import progress_of, project_settings, with_flags
    from scangeo.strategy.cleaning import clean, restore, summary_lines

    if args.restore:
        done = restore(args.project)
        print("cleaning removed: every measurement is used again" if done else "no cleaning to remove")
        return 0
    cleaning = clean(args.project, with_flags(project_settings(args).clean, args), progress_of(args))
    print("\n".join(summary_lines(cleaning)))
    print(f"written: {cleaning.project}/results/cleaning/rejected.csv, cleaning.json", file=sys.stderr)
    return 0
