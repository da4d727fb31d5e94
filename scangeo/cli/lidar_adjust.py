"""``scangeo lidar adjust PROJECT``: simultaneous georeferencing of laser strips with tie patches.

A thin shell over :func:`scangeo.lidar.outputs.adjust_project`.
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
    p.add_argument("--patch-size", type=float, default=None, help="patch (grid cell) size, m")
    p.add_argument("--position-degree", type=int, default=None, help="degree of the position correction polynomials")
    p.add_argument("--attitude-degree", type=int, default=None, help="degree of the attitude correction polynomials")
    p.add_argument("--workers", type=int, default=None, help="strips searched for patches at once (processes)")
    p.add_argument("--no-strips", action="store_true", help="do not write corrected LAS/LAZ strips")
    p.set_defaults(func=run_adjust, writes_project=True)


def run_adjust(args: argparse.Namespace) -> int:
    from scangeo.cli import progress_of
    from scangeo.lidar.outputs import adjust_project

    out = args.out or args.project / "lidar-adjust"
    results = adjust_project(
        args.project,
        out,
        args.ground,
        progress_of(args),
        not args.no_strips,
        mode=args.mode,
        patch_size=args.patch_size,
        position_degree=args.position_degree,
        attitude_degree=args.attitude_degree,
        workers=args.workers,
    )
    ev = results["evaluation"] or {}
    acc = results["accounting"]
    print(f"mode: {results['mode_description']}")
    print(
        f"patches: {results['patches']['tie']} tie, {results['patches']['control']} control, "
        f"{results['patches']['check']} check; {acc['observations']} observations, {acc['unknowns']} unknowns, "
        f"redundancy {acc['redundancy']}, sigma0 {results['sigma0']:.3f}"
    )
    for key, label in (
        ("strip_differences_rms_m", "strip differences rms"),
        ("strip_differences_flat_rms_m", "  on flat cells"),
        ("check_patches_rms_m", "check patches rms"),
        ("tie_patch_discrepancies_rms_m", "tie patch discrepancies rms"),
    ):
        if key in ev and ev[key]["before"] == ev[key]["before"]:  # NaN: no such patches
            print(f"{label:28s} {100 * ev[key]['before']:8.2f} cm -> {100 * ev[key]['after']:8.2f} cm")
    for p in results["parameters"]:
        if p["key"] in ("Boresight()", "LeverArm()", "RangeOffset()", "ScanIndex()"):
            print(f"{p['key']:14s} {p['component']:8s} {p['value']:+.5f} +- {p['sigma']:.5f} {p['unit']}")
    reg = results["regularisation"]
    names = sorted({f"{r['key']}[{r['component']}]" for r in reg if not r["key"].startswith("Plane(")})
    planes = {r["key"] for r in reg if r["key"].startswith("Plane(")}
    if names:
        print(f"regularised ({len(names)}): {', '.join(names[:12])}{' ...' if len(names) > 12 else ''}")
    if planes:
        print(f"regularised {len(planes)} plane(s) of patches that data snooping left with one strip")
    if results["rejections"]:
        print(
            f"data snooping rejected {len(results['rejections'])} patch observation(s): "
            + ", ".join(f"{r['patch']} ({r['group']}, w {r['w']:.1f})" for r in results["rejections"][:8])
        )
    print(f"report: {out / 'report.html'}")
    return 0
