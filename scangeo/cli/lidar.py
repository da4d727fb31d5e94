"""``scangeo lidar``: the laser scanner's analysis tools: error model, calibration flights, budget,
network design, real data.

A thin shell over :mod:`scangeo.lidar`: parse options (lengths and their sigmas in metres, angles in
degrees at this edge), call the library, print a table or JSON. A flag that sets a library option is
bound to it (:func:`scangeo.cli.option_argument`): ``--help`` states the library's default. The strip
adjustment of a laser project is ``scangeo run PROJECT`` (stages patches, clean, compare, apply,
report; docs/run.md).
"""
from __future__ import annotations

import argparse
import json
import math
import statistics

from scangeo.cli import option_argument, passed, with_flags

DEG = math.pi / 180.0

_GEOMETRY = "scangeo.lidar.laser_equation:FlightGeometry"
_ERRORS = "scangeo.lidar.laser_equation:SystematicErrors"
_EXAMPLE_GEOMETRY = "scangeo.lidar.calibration_flights:EXAMPLE_GEOMETRY"
_EXAMPLE_ERRORS = "scangeo.lidar.calibration_flights:EXAMPLE_ERRORS"
_SIGMAS = "scangeo.lidar.budget:BudgetSigmas"
_LAYOUT = "scangeo.lidar.network:BlockLayout"


def _floats(count: int):
    """argparse type: ``count`` comma-separated numbers."""

    def parse(text: str) -> tuple[float, ...]:
        try:
            values = tuple(float(v) for v in text.split(","))
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r}: expected {count} comma-separated numbers") from None
        if len(values) != count:
            raise argparse.ArgumentTypeError(f"{text!r}: expected {count} comma-separated numbers, got {len(values)}")
        return values

    return parse


def _print_json(obj: object) -> None:
    print(json.dumps(obj, indent=2))


def _error_flags(p: argparse.ArgumentParser, owner: str) -> None:
    """The flags of the systematic errors both ``errors`` and ``forward-reverse`` take (fields of
    ``owner``: SystematicErrors, or the example flights' errors)."""
    option_argument(p, "--range-error", type=float, metavar="M", option=f"{owner}.range_offset",
                    help="range offset, m")
    option_argument(p, "--scan-angle-error", type=float, metavar="DEG", option=f"{owner}.scan_angle_error",
                    scale=DEG, help="error of the total scan angle, deg")
    option_argument(p, "--mounting", type=_floats(3), metavar="DEG,DEG,DEG", option=f"{owner}.mounting",
                    scale=DEG, help="mounting (boresight) error roll, pitch, heading, deg")
    option_argument(p, "--imu", type=_floats(3), metavar="DEG,DEG,DEG", option=f"{owner}.imu", scale=DEG,
                    help="IMU attitude error roll, pitch, heading, deg")
    option_argument(p, "--lever-arm", type=_floats(3), metavar="M,M,M", option=f"{owner}.lever_arm",
                    help="lever-arm error in the body frame (forward, right, down), m")
    option_argument(p, "--gps", type=_floats(3), metavar="M,M,M", option=f"{owner}.gps",
                    help="GPS position offset north, east, down, m")


# --------------------------------------------------------------------------------------- errors
def _add_errors(sub, common) -> None:
    p = sub.add_parser(
        "errors", parents=[common],
        help="error vectors of systematic errors at the start, middle and end of a scan line",
        description="Error vectors (computed minus true; along, across to the right, vertical up; m) of "
        "each given systematic error at the start (right edge), middle (nadir) and end (left edge) of a "
        "scan line over a plane, and the apparent across-track tilt of a horizontal plane. "
        "Each error is the part of the true value the processing ignores (true = used + error).",
    )
    p.add_argument("--height", type=float, required=True, metavar="M", help="flying height above ground, m")
    p.add_argument("--scan-angle", type=float, required=True, metavar="DEG", help="total scan angle, deg")
    option_argument(p, "--heading", type=float, metavar="DEG", option=f"{_GEOMETRY}.heading", scale=DEG,
                    help="flight heading, deg")
    p.add_argument("--slope", type=_floats(2), default=(0.0, 0.0), metavar="DEG,DEG",
                   help="terrain slope along, across the flight direction, deg (default: level, 0,0)")
    option_argument(p, "--index-error", type=float, metavar="DEG", option=f"{_ERRORS}.index_error", scale=DEG,
                    help="scan-angle index error, deg")
    p.add_argument("--plane-tilt", type=_floats(2), default=(0.0, 0.0), metavar="DEG,DEG",
                   help="scan-plane tilts: lean (about the across axis), skew (about the vertical), deg "
                        "(default: none, 0,0)")
    _error_flags(p, _ERRORS)
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=run_errors)


def run_errors(args: argparse.Namespace) -> int:
    # here, not at the top: start-up cost (see scangeo.cli)
    from scangeo.lidar.error_sources import error_budget_by_source
    from scangeo.lidar.laser_equation import FlightGeometry, SystematicErrors

    geometry = with_flags(FlightGeometry(height=args.height, fov=args.scan_angle * DEG,
                                         slope_along=math.tan(args.slope[0] * DEG),
                                         slope_across=math.tan(args.slope[1] * DEG)), args)
    errors = with_flags(SystematicErrors(plane_lean=args.plane_tilt[0] * DEG, plane_skew=args.plane_tilt[1] * DEG),
                        args)
    table = error_budget_by_source(geometry, errors)
    sources = {name: line.as_dict() for name, line in table.items() if name != "total"}
    if args.json:
        for entry in sources.values():
            entry.pop("height_on_terrain")
        total = table["total"].as_dict()
        total.pop("height_on_terrain")
        _print_json({"sources": sources, "total": total})
        return 0
    print(f"flying height {args.height:g} m, total scan angle {args.scan_angle:g} deg; "
          "error vectors (along, across, vertical up) in m, computed minus true")
    print(f"{'source':<10} {'position':<7} {'along':>9} {'across':>9} {'vertical':>9} {'dh terrain':>10}  plane tilt")
    for name, line in table.items():
        d = line.as_dict()
        for k, pos in enumerate(("start", "middle", "end")):
            a, c, v = d[pos]
            tilt = f"  {d['plane_tilt_deg']:+.5f} deg" if k == 0 else ""
            label = name if k == 0 else ""
            print(f"{label:<10} {pos:<7} {a:+9.4f} {c:+9.4f} {v:+9.4f} {d['height_on_terrain'][k]:+10.4f}{tilt}")
    return 0


# --------------------------------------------------------------------------------------- budget
def _add_budget(sub, common) -> None:
    p = sub.add_parser(
        "budget", parents=[common], help="height precision of the mean terrain height of an area",
        description="Error budget of an area's mean height: seasonal and daily variation (not reduced), "
        "local variation and point noise (by the number of points), short-wave strip errors (by the "
        "number of ~100 m strip pieces), long-wave strip errors (by the number of strips), strip offset "
        "(by the factor alpha only). Sigmas in m (assumed typical values by default: docs/lidar.md); the "
        "contributions are printed in cm (in m with --json).",
    )
    p.add_argument("--points", type=int, required=True, metavar="N", help="number of points in the area")
    p.add_argument("--pieces", type=int, required=True, metavar="N", help="number of ~100 m strip pieces in the area")
    p.add_argument("--strip-count", dest="n_strips", type=int, required=True, metavar="N",
                   help="number of strips covering the area")
    g = p.add_mutually_exclusive_group()
    option_argument(g, "--alpha", type=float, metavar="FACTOR", option="scangeo.lidar.budget:area_mean_budget.alpha",
                    help="offset reduction factor, 1 without a strip adjustment")
    g.add_argument("--offset-covariance", metavar="FILE",
                   help="covariance (m^2) of the offsets of the covering strips (.npy or text matrix); gives alpha")
    for name in ("seasonal", "daily", "local", "noise", "short", "long", "offset"):
        option_argument(p, f"--sigma-{name}", type=float, metavar="M", option=f"{_SIGMAS}.{name}",
                        help=f"sigma of the {name} component")
    p.add_argument("--scenarios", action="store_true",
                   help="also print the cost-benefit table of flight scenarios")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=run_budget)


def _in_metres(budget: dict) -> dict:
    """A budget of the library as ``--json`` prints it: ``total_m``, and ``components`` as ``components_m``."""
    out = {k: v for k, v in budget.items() if k != "components"}
    return {**out, "components_m": dict(budget["components"])}


def run_budget(args: argparse.Namespace) -> int:
    # here, not at the top: start-up cost (see scangeo.cli)
    from scangeo.lidar.budget import BudgetSigmas, alpha_from_covariance, area_mean_budget

    sigmas = with_flags(BudgetSigmas(), args)
    alpha = passed(args, "alpha")
    if args.offset_covariance:
        alpha = {"alpha": alpha_from_covariance(args.offset_covariance, sigmas.offset)}
    result = area_mean_budget(args.points, args.pieces, args.n_strips, sigmas=sigmas, **alpha)
    table = _scenario_table(sigmas) if args.scenarios else None
    if args.json:  # metres, as every JSON of scangeo
        out = {"total_m": result["total_m"], "components_m": dict(result["components"])}
        if table is not None:
            out["scenarios"] = [_in_metres(row) for row in table]
        _print_json(out)
        return 0
    print(f"mean height of an area: {args.points} points, {args.pieces} strip pieces, {args.n_strips} strips, "
          f"alpha {result['alpha']:.3f}")
    for name, m in result["components"].items():
        print(f"  {name:<9} {100.0 * m:7.3f} cm")
    print(f"  {'total':<9} {100.0 * result['total_m']:7.3f} cm")
    if table is not None:
        print()
        print(f"{'scenario':<40} {'points':>7} {'alpha':>6} {'total cm':>9} {'cost':>6}")
        for row in table:
            print(
                f"{row['name']:<40} {row['points']:7d} {row['alpha']:6.3f} "
                f"{100.0 * row['total_m']:9.3f} {row['relative_cost']:6.2f}"
            )
    return 0


def _scenario_table(sigmas) -> list[dict]:
    """The budgets (m) of the default flight scenarios, their alphas from the default network design."""
    # here, not at the top: start-up cost (see scangeo.cli)
    from scangeo.lidar.budget import default_scenarios, scenario_row
    from scangeo.lidar.network import BlockLayout, offset_precision

    layout = BlockLayout()

    def alpha(controls) -> float:  # the mean adjusted offset sigma over the offset sigma before
        mean = float(offset_precision(layout, controls)[: layout.n_strips].mean())
        return mean / sigmas.offset if sigmas.offset > 0 else 0.0

    few, many = alpha(layout.corner_controls()), alpha(layout.ends_controls(4))
    return [scenario_row(s, sigmas=sigmas) for s in default_scenarios(few, many)]


# -------------------------------------------------------------------------------------- network
def _add_network(sub, common) -> None:
    p = sub.add_parser(
        "network",
        parents=[common],
        help="network design of a 1D strip adjustment (plot + table)",
        description="Precision of the strip offsets of a regular block from its configuration alone: "
        "without and with cross strips, with 4 corner control areas or control at both ends of every "
        "4th strip.",
    )
    option_argument(p, "--strip-count", dest="n_strips", type=int, metavar="N", option=f"{_LAYOUT}.n_strips",
                    help="number of parallel strips")
    option_argument(p, "--cross", dest="n_cross", type=int, metavar="N", option=f"{_LAYOUT}.n_cross",
                    help="number of cross strips")
    option_argument(p, "--length", type=float, metavar="M", option=f"{_LAYOUT}.length", help="strip length")
    option_argument(p, "--swath", type=float, metavar="M", option=f"{_LAYOUT}.swath", help="swath width")
    option_argument(p, "--overlap", type=float, metavar="FRACTION", option=f"{_LAYOUT}.overlap",
                    help="side overlap fraction")
    option_argument(p, "--sigma-tie", type=float, metavar="M", option=f"{_LAYOUT}.sigma_tie", help="tie-area sigma")
    option_argument(p, "--sigma-control", type=float, metavar="M", option=f"{_LAYOUT}.sigma_control",
                    help="control-area sigma")
    p.add_argument("--plot", metavar="PNG", help="write the design plot")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=run_network)


def run_network(args: argparse.Namespace) -> int:
    # here, not at the top: start-up cost (see scangeo.cli)
    from scangeo.lidar.network import BlockLayout, design_scenarios, plot_design

    layout = with_flags(BlockLayout(), args)
    scenarios = plot_design(layout, args.plot) if args.plot else design_scenarios(layout)
    if args.json:  # metres, as every JSON of scangeo (to 10 micrometres)
        _print_json({"offset_sigma_m": {name: [round(float(v), 5) for v in sig] for name, sig in scenarios.items()}})
        return 0
    for name, sig in scenarios.items():
        cm = [round(100 * float(v), 3) for v in sig]
        print(f"{name}: mean {statistics.fmean(cm):.2f} cm, max {max(cm):.2f} cm")
        print("   " + " ".join(f"{v:.2f}" for v in cm))
    return 0


# ---------------------------------------------------------------------------------- real data
def _add_check(sub, common) -> None:
    p = sub.add_parser(
        "check-returns",
        parents=[common],
        help="recompute real returns from SBET, boresight, scan angle, range",
        description="Recompute every LAS return from the SBET trajectory, the boresight and lever arm of a "
        "leeward config.toml, the return's scan angle and its range, and report the rms of recomputed minus "
        "given coordinates, before and after fitting small boresight rotations and a scan-angle scale.",
    )
    p.add_argument("--sbet", required=True, metavar="FILE", help="Applanix SBET (.out)")
    p.add_argument("--las", required=True, metavar="FILE", help="LAS/LAZ returns with GPS time and scan angle")
    p.add_argument("--system", required=True, metavar="FILE",
                   help="the scanner system: a leeward config.toml (boresight rad, lever arm m, utm_zone)")
    option_argument(p, "--sbet-heading", dest="heading", metavar="HEADING",
                    option="scangeo.lidar.real_data:consistency.heading",
                    help="platform: the SBET's heading field as it is; true: that minus the wander angle")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=run_check)


def run_check(args: argparse.Namespace) -> int:
    # here, not at the top: start-up cost (see scangeo.cli)
    from scangeo.lidar.real_data import consistency

    r = consistency(args.sbet, args.las, args.system, **passed(args, "heading"))
    if args.json:
        _print_json(r)
        return 0
    e, n, u = r["rms_enu_m"]
    print(f"{r['returns']} returns, mean range {r['mean_range_m']:.1f} m, heading = {r['heading']}")
    print(
        f"recomputed - given, configured boresight: rms east {e:.3f} north {n:.3f} up {u:.3f} m, "
        f"3D {r['rms_3d_m']:.3f} m"
    )
    f = r["fit_deg"]
    print(
        f"fitted boresight corrections: roll {f['boresight_roll']:+.4f} pitch {f['boresight_pitch']:+.4f} "
        f"yaw {f['boresight_yaw']:+.4f} deg, scan-angle scale {r['fit_scan_scale']:+.5f}"
    )
    e, n, u = r["fit_rms_enu_m"]
    print(
        f"after the fit: rms east {e:.3f} north {n:.3f} up {u:.3f} m, 3D {r['fit_rms_3d_m']:.3f} m "
        f"(whole-degree scan angles alone: {r['expected_rms_from_whole_degree_scan_angles_m']:.3f} m)"
    )
    return 0


# ---------------------------------------------------------------------------- forward/reverse
def _add_forward_reverse(sub, common) -> None:
    p = sub.add_parser(
        "forward-reverse",
        parents=[common],
        help="recover attitude errors from forward/reverse flights",
        description="Simulate a strip flown north (A), the same line flown south (B) and a parallel strip "
        "flown north half a swath east (C) with the given errors, and recover roll and pitch from the A-B "
        "differences at nadir and heading from the A-C difference.",
    )
    option_argument(p, "--height", type=float, metavar="M", option=f"{_EXAMPLE_GEOMETRY}.height",
                    help="flying height above ground, m")
    option_argument(p, "--scan-angle", type=float, metavar="DEG", option=f"{_EXAMPLE_GEOMETRY}.fov",
                    scale=DEG, help="total scan angle, deg")
    _error_flags(p, _EXAMPLE_ERRORS)
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=run_forward_reverse)


def run_forward_reverse(args: argparse.Namespace) -> int:
    # here, not at the top: start-up cost (see scangeo.cli)
    from scangeo.lidar.calibration_flights import EXAMPLE_ERRORS, EXAMPLE_GEOMETRY, recover_attitude

    geometry = with_flags(EXAMPLE_GEOMETRY, args, "EXAMPLE_GEOMETRY")
    errors = with_flags(EXAMPLE_ERRORS, args, "EXAMPLE_ERRORS")
    r = recover_attitude(geometry, errors)
    got = {"roll": r.roll / DEG, "pitch": r.pitch / DEG, "heading": r.heading / DEG}
    injected = {k: math.degrees(a + b) for k, a, b in zip(("roll", "pitch", "heading"), errors.imu, errors.mounting)}
    if args.json:
        _print_json(
            {
                "recovered_deg": got,
                "imu_plus_mounting_deg": injected,
                "heading_from_forward_reverse_edges_deg": r.heading_from_edges / DEG,
            }
        )
        return 0
    print(f"{'angle':<8} {'injected (IMU+mounting) deg':>28} {'recovered deg':>14} {'rel. error':>11}")
    for k in got:
        rel = (got[k] - injected[k]) / injected[k] if injected[k] else float("nan")
        print(f"{k:<8} {injected[k]:28.5f} {got[k]:14.5f} {rel:11.2e}")
    print(f"heading from the A-B edge differences: {r.heading_from_edges / DEG:.2e} deg (cancels)")
    return 0


def add_parser(subparsers, common) -> None:
    """Add ``scangeo lidar`` and its sub-commands."""
    parser = subparsers.add_parser("lidar", help="laser scanners: error model, calibration flights, budget, network")
    sub = parser.add_subparsers(dest="lidar_command", metavar="SUBCOMMAND")
    _add_errors(sub, common)
    _add_budget(sub, common)
    _add_network(sub, common)
    _add_forward_reverse(sub, common)
    _add_check(sub, common)
    parser.set_defaults(func=lambda args: (parser.print_help(), 2)[1])


__all__ = ["add_parser"]
