"""``scangeo lidar adjust PROJECT``: simultaneous georeferencing of laser strips with tie patches.

A thin shell over :func:`scangeo.lidar.workflow.adjust_laser`.
"""

from __future__ import annotations

import argparse
from pathlib import Path


def add_adjust(sub, common) -> None:
    p = sub.add_parser(
        "adjust",
        parents=[common],
        help="adjust laser strips with tie patches (GPS/IMU correction polynomials, boresight; Kager 2003)",
        description="Find planar patches in every strip, tie overlapping strips by them, adjust GPS/IMU "
        "correction polynomials, the boresight and the patch planes (or, without trajectories, XYZ correction "
        "polynomials per strip), write corrected strips, strip differences and a report.",
    )
    p.add_argument("project", type=Path, help="laser project folder (project.toml with [sensor] kind = 'laser')")
    p.add_argument("--out", type=Path, default=None, help="output folder (default PROJECT/lidar-adjust)")
    p.add_argument("--ground", type=Path, default=None, help="control/check patches CSV (default PROJECT/ground.csv)")
    p.add_argument(
        "--mode",
        choices=("auto", "trajectory", "points"),
        default=None,
        help="trajectory (GPS/IMU corrections) or points (trajectory-free); default auto",
    )
    p.add_argument("--patch-search", choices=("rows", "grid"), default=None,
                   help="rows: row buffer and seeded second pass (default); grid: fixed grid cells")
    p.add_argument("--patch-size", type=float, default=None, help="patch size, m")
    p.add_argument("--models", choices=("strip", "mission", "block"), default=None,
                   help="GPS/IMU models: per strip (default), per mission, or one for the block")
    p.add_argument("--position-degree", type=int, default=None, help="degree of the position correction polynomials")
    p.add_argument("--attitude-degree", type=int, default=None, help="degree of the attitude correction polynomials")
    p.add_argument("--workers", type=int, default=None, help="strips searched for patches at once (processes)")
    p.add_argument("--scheduler", default=None,
                   help="address of a Dask scheduler (tcp://host:8786): the patch search runs there, a task per strip")
    p.add_argument("--no-strips", action="store_true", help="do not write corrected LAS/LAZ strips")
    p.set_defaults(func=run_adjust, writes_project=True)


def add_compare(sub, common) -> None:
    p = sub.add_parser(
        "compare",
        parents=[common],
        help="laser adjustment variants side by side (GPS/IMU models per mission, per strip, ...)",
        description="Find the patches once, adjust every variant on them, and write comparison.json and "
        "comparison.html; variants from a TOML file of [NAME] tables of [adjustment] keys (default: the "
        "paper's per mission and per strip).",
    )
    p.add_argument("project", type=Path, help="laser project folder")
    p.add_argument("--variants", type=Path, default=None, help="TOML file of variant tables")
    p.add_argument("--out", type=Path, default=None, help="output folder (default PROJECT/lidar-compare)")
    p.add_argument("--ground", type=Path, default=None, help="control/check patches CSV (default PROJECT/ground.csv)")
    p.set_defaults(func=run_compare, writes_project=True)


def run_compare(args: argparse.Namespace) -> int:
    # imported here: the command line starts without loading the adjustment (start-up cost)
    # here, not at the top: start-up cost (see scangeo.cli)
    from scangeo.cli import progress_of
    from scangeo.lidar.variants import compare_laser, read_variants, write_comparison

    variants = read_variants(args.variants) if args.variants is not None else None
    comparison = compare_laser(args.project, variants, args.ground, progress_of(args))
    out = args.out or args.project / "lidar-compare"
    write_comparison(out, comparison)
    rows = comparison.table()
    heads = list(rows[0])
    print("  ".join(heads))
    for r in rows:
        print("  ".join("-" if r[h] is None else (f"{r[h]:.3f}" if isinstance(r[h], float) else str(r[h]))
                        for h in heads))
    print(f"comparison: {out / 'comparison.html'}")
    return 0


def run_adjust(args: argparse.Namespace) -> int:
    # imported here: the command line starts without loading the adjustment (start-up cost)
    # here, not at the top: start-up cost (see scangeo.cli)
    from scangeo.cli import progress_of
    from scangeo.lidar.workflow import adjust_laser

    out = args.out or args.project / "lidar-adjust"
    result = adjust_laser(
        args.project,
        out,
        args.ground,
        progress_of(args),
        not args.no_strips,
        mode=args.mode,
        patch_search=args.patch_search,
        patch_size=args.patch_size,
        models=args.models,
        position_degree=args.position_degree,
        attitude_degree=args.attitude_degree,
        workers=args.workers,
        scheduler=args.scheduler,
    )
    ev = result.evaluation or {}
    acc = result.accounting
    print(f"mode: {result.mode_description}")
    print(
        f"patches: {result.patches['tie']} tie, {result.patches['control']} control, "
        f"{result.patches['height']} height control, {result.patches['check']} check; "
        f"{acc['observations']} observations, {acc['unknowns']} unknowns, "
        f"redundancy {acc['redundancy']}, sigma0 {result.sigma0:.3f}"
    )
    for key, label in (
        ("strip_differences_rms_m", "strip differences rms"),
        ("strip_differences_flat_rms_m", "  on flat cells"),
        ("check_patches_rms_m", "check patches rms"),
        ("control_check_points_rms_m", "check points on control rms"),
        ("tie_patch_discrepancies_rms_m", "tie patch discrepancies rms"),
    ):
        if key in ev and ev[key]["before"] == ev[key]["before"]:  # NaN: no such patches
            print(f"{label:28s} {100 * ev[key]['before']:8.2f} cm -> {100 * ev[key]['after']:8.2f} cm")
    for e in result.calibration:
        print(f"{e.key.label:14s} {e.component:8s} {e.value:+.5f} +- {e.sigma:.5f} {e.unit}"
              f"{'' if e.significant else '  (not significant)'}")
    weak = [e for e in result.corrections if not e.significant]
    print(f"correction coefficients: {len(result.corrections)}, {len(weak)} not significant at 5 %")
    t = result.tilts
    print(f"patch tilts: {t.significant} of {t.patches} planes tilted significantly (largest t {t.max_t:.1f})")
    names = sorted({f"{r.key.label}[{r.component}]" for r in result.regularised if not r.is_plane})
    planes = {r.key for r in result.regularised if r.is_plane}
    if names:
        print(f"regularised ({len(names)}): {', '.join(names[:12])}{' ...' if len(names) > 12 else ''}")
    if planes:
        print(f"regularised {len(planes)} plane(s) of patches that data snooping left with one strip")
    if result.rejections:
        print(
            f"data snooping rejected {len(result.rejections)} patch observation(s): "
            + ", ".join(f"{r.patch} ({r.group}, w {r.w:.1f})" for r in result.rejections[:8])
        )
    print(f"report: {out / 'report.html'}")
    return 0
