"""``scangeo demo [OUT]``: simulate the reference block, then ``scangeo run`` on it.

A thin shell over :func:`scangeo.pipeline.demo.run_demo` (docs/reports.md, docs/run.md).
"""
from __future__ import annotations

import argparse

from scangeo.cli import option_argument


def add_parser(subparsers, common) -> None:
    p = subparsers.add_parser(
        "demo", parents=[common], help="all of it on a built-in block: simulate, then scangeo run",
        description="Simulate the vienna2000 block (three strips of 7,000 lines, the middle one a problem strip) "
                    "into OUT, then run every stage on it (scangeo run: check, clean, diagnose, compare, rectify the "
                    "recommended variant, report; docs/run.md, docs/reports.md). --quick runs the same on the small "
                    "'quick' preset in seconds.",
    )
    p.add_argument("out", nargs="?", default="demo", help="folder to create (default ./demo)")
    option_argument(p, "--preset", option="scangeo.pipeline.demo:run_demo.preset",
                    help="simulation preset or TOML file")
    p.add_argument("--quick", action="store_true",
                   help="reduced size: the 'quick' preset (2 strips x 600 lines) instead of --preset")
    p.add_argument("--seed", type=int, default=None, help="random seed (default: the preset's)")
    option_argument(p, "--rectify", action=argparse.BooleanOptionalAction,
                    option="scangeo.pipeline.demo:run_demo.rectify", help="rectify the recommended variant")
    option_argument(p, "--overwrite", action=argparse.BooleanOptionalAction,
                    option="scangeo.pipeline.demo:run_demo.overwrite", help="replace OUT if it exists")
    p.add_argument("--matched", action="store_true",
                   help="also compare the strategies on points measured by 'scangeo match' (a second table)")
    p.set_defaults(func=run)


def run(args) -> int:
    # here, not at the top: start-up cost (see scangeo.cli)
    from scangeo.cli import passed, progress_of
    from scangeo.cli.run import summary_lines
    from scangeo.pipeline.demo import run_demo
    from scangeo.reports.tables import markdown_tables, text_table

    if args.quick:
        args.preset = "quick"
    result = run_demo(args.out, seed=args.seed, matched=args.matched, callback=progress_of(args),
                      **passed(args, "preset", "rectify", "overwrite"))
    print(text_table(*markdown_tables(result.comparison)["check points"]))
    if result.matched is not None:
        print("\nthe same on matched ties and control (scangeo match; OUT/matched):")
        print(text_table(*markdown_tables(result.matched)["check points"]))
    print(f"lowest check-point rms: {result.best}")
    if result.run is not None:
        print("\n".join(summary_lines(result.run)))
    print("seconds: " + ", ".join(f"{k} {v:.0f}" for k, v in result.seconds.items()))
    return 0
