"""``scangeo plan PROJECT --variant NAME``: the reliability of a planned block, before the flight.

A thin shell over :func:`scangeo.adjustment.planning.plan_block` and
:func:`scangeo.reports.reliability.write_plan` (docs/adjustment.md, "Reliability").
"""
from __future__ import annotations

import sys


def add_parser(subparsers, common) -> None:
    p = subparsers.add_parser(
        "plan", parents=[common], help="reliability of a planned block: weak areas before the flight",
        description="Makes image measurements of the planned control (ground.csv) and a grid of tie points from "
                    "the planned trajectories, adjusts the variant once and writes the minimal detectable blunders "
                    "and external reliability with a weak-area map to PROJECT/results/plan_NAME/ (plan.html).",
    )
    p.add_argument("project", help="the project folder (planned trajectories in project.toml, planned control in "
                                   "ground.csv)")
    p.add_argument("--variant", default="SE", help="variant name from variants.toml or built in (default SE)")
    p.add_argument("--variants", default=None, help="variants file (default PROJECT/variants.toml)")
    p.add_argument("--tie-spacing", type=float, default=500.0, help="grid spacing of the planned tie points, m (500)")
    p.add_argument("--sigma-px", type=float, default=0.3, help="image measurement sigma, px (0.3)")
    p.add_argument("--out", default=None, help="output folder (default PROJECT/results/plan_NAME)")
    p.set_defaults(func=run, writes_project=True)


def run(args) -> int:
    # here, not at the top: start-up cost (see scangeo.cli)
    from scangeo.adjustment.planning import plan_block
    from scangeo.adjustment.reliability_summary import reliability_lines
    from scangeo.cli import progress_of
    from scangeo.reports.reliability import write_plan

    plan = plan_block(args.project, args.variant, args.variants, args.tie_spacing, args.sigma_px, progress_of(args))
    out = write_plan(plan, args.out)
    print(f"plan {plan.result.variant.name}: {plan.tie_points} tie points, {plan.control_points} control points, "
          f"redundancy {plan.result.adjustment.statistics.redundancy}")
    for line in reliability_lines(plan.reliability):
        print(f"  {line}")
    print(f"results in {out}", file=sys.stderr)
    return 0
