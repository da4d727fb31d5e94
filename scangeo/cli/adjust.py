"""``scangeo adjust PROJECT --variant NAME``: one adjustment strategy, results in PROJECT/results/NAME.

A thin shell over :func:`scangeo.adjust` (``scangeo.workflow``).
"""
from __future__ import annotations

import sys

from scangeo.cli import option_argument


def add_parser(subparsers, common) -> None:
    p = subparsers.add_parser(
        "adjust", parents=[common], help="adjust a project's orientation with one strategy (variant)",
        description="Hybrid least-squares adjustment of GPS/IMU, control, tie and check points and DTM "
                    "heights (docs/adjustment.md). Writes PROJECT/results/NAME/.",
    )
    p.add_argument("project", help="the project folder (with project.toml, points.csv, ground.csv)")
    option_argument(p, "--variant", option="scangeo.workflow:adjust.variant",
                    help="variant name from the variants file or built in: DG, BE, SE")
    p.add_argument("--variants", dest="variants_file", default=None, metavar="FILE",
                   help="variants file (default PROJECT/variants.toml)")
    p.set_defaults(func=run, writes_project=True)  # one run at a time (scangeo.atomic.OutputLock)


def run(args) -> int:
    # here, not at the top: start-up cost (see scangeo.cli)
    from scangeo.adjustment.reliability_summary import reliability_lines, variant_reliability
    from scangeo.cli import passed, progress_of
    from scangeo.workflow import adjust

    adjusted = adjust(args.project, variants_file=args.variants_file, progress=progress_of(args),
                      **passed(args, "variant"))
    result, out = adjusted.result, adjusted.folder
    stats = result.adjustment.statistics
    acc = stats.accounting
    print(
        f"variant {result.variant.name} ({result.variant.strategy}): sigma0 {stats.sigma0:.3f}, "
        f"{acc.observations} observations + {acc.pseudo_observations} pseudo, {acc.unknowns} unknowns "
        f"({acc.parameters} parameters - {acc.conditions} conditions), redundancy {acc.redundancy}, "
        f"{len(result.adjustment.solution.iterations)} iterations, {len(result.adjustment.rejections)} rejected"
    )
    for sid, e in result.rms_per_strip().items():
        for kind in ("control", "check"):
            r = e[kind]
            if r["n"]:
                print(
                    f"  strip {sid} {kind:7s} n={r['n']:3d}  rms along {r['rms_along_lines']:.2f} lines, "
                    f"across {r['rms_across_px']:.2f} px"
                )
    for note in result.notes:
        print(f"  note: {note}")
    for n in result.adjustment.solution.regularisation:
        print(f"  regularised: {n.key.label}[{n.component}] with sigma {n.sigma:g} ({n.reason})")
    for line in reliability_lines(variant_reliability(result)):
        print(f"  {line}")
    print(f"results in {out}", file=sys.stderr)
    return 0
