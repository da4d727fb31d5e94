"""``scangeo plan PROJECT --variant NAME``: the reliability of a planned block, before the flight.

A thin shell over :func:`scangeo.adjustment.planning.plan_block` and
:func:`scangeo.reports.reliability.write_plan` (docs/adjustment.md, "Reliability").
"""
from __future__ import annotations

import sys

from scangeo.cli import option_argument


def add_parser(subparsers, common) -> None:
    p = subparsers.add_parser(
        "plan", parents=[common], help="reliability of a planned block: weak areas before the flight",
        description="Makes image measurements of the planned control (ground.csv) and a grid of tie points from "
                    "the planned trajectories, adjusts the variant once and writes the minimal detectable blunders "
                    "and external reliability with a weak-area map to PROJECT/results/plan_NAME/ (plan.html).",
    )
    p.add_argument("project", help="the project folder (planned trajectories in project.toml, planned control in "
                                   "ground.csv)")
    option_argument(p, "--variant", option="scangeo.adjustment.planning:plan_block.variant",
                    help="variant name from the variants file or built in")
    p.add_argument("--variants", dest="variants_file", default=None, metavar="FILE",
                   help="variants file (default PROJECT/variants.toml)")
    option_argument(p, "--tie-spacing", type=float, dest="tie_spacing_m", metavar="M",
                    option="scangeo.adjustment.planning:plan_block.tie_spacing_m",
                    help="grid spacing of the planned tie points, m")
    option_argument(p, "--sigma-px", type=float, metavar="PX", option="scangeo.adjustment.planning:plan_block.sigma_px",
                    help="image measurement sigma, px")
    p.set_defaults(func=run, writes_project=True)


def run(args) -> int:
    # here, not at the top: start-up cost (see scangeo.cli)
    from scangeo.adjustment.planning import plan_block
    from scangeo.adjustment.reliability_summary import reliability_lines
    from scangeo.cli import passed, progress_of
    from scangeo.reports.reliability import write_plan

    plan = plan_block(args.project, variants_file=args.variants_file, callback=progress_of(args),
                      **passed(args, "variant", "tie_spacing_m", "sigma_px"))
    out = write_plan(plan)
    print(f"plan {plan.result.variant.name}: {plan.tie_points} tie points, {plan.control_points} control points, "
          f"redundancy {plan.result.adjustment.statistics.redundancy}")
    for line in reliability_lines(plan.reliability):
        print(f"  {line}")
    print(f"results in {out}", file=sys.stderr)
    return 0
