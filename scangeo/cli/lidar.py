"""``scangeo lidar``: laser-scanner error model, calibration flights, strip adjustment, budget, real data.

A thin shell over :mod:`scangeo.lidar`: parse options (degrees and centimetres at this edge), call
the library, print a table or JSON.
"""
from __future__ import annotations

import argparse
import json
import math

from scangeo.errors import LidarError

DEG = math.pi / 180.0


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
    p.add_argument("--height", type=float, required=True, help="flying height above ground, m")
    p.add_argument("--scan-angle", type=float, required=True, help="total scan angle, deg")
    p.add_argument("--heading", type=float, default=0.0, help="flight heading, deg (default 0)")
    p.add_argument("--slope", type=_floats(2), default=(0.0, 0.0), metavar="DEG,DEG",
                   help="terrain slope along, across the flight direction, deg (default 0,0)")
    p.add_argument("--range-error", type=float, default=0.0, metavar="M", help="range offset, m")
    p.add_argument("--index-error", type=float, default=0.0, metavar="DEG", help="scan-angle index error, deg")
    p.add_argument("--scan-angle-error", type=float, default=0.0, metavar="DEG",
                   help="error of the total scan angle, deg")
    p.add_argument("--plane-tilt", type=_floats(2), default=(0.0, 0.0), metavar="DEG,DEG",
                   help="scan-plane tilts: lean (about the across axis), skew (about the vertical), deg")
    p.add_argument("--mounting", type=_floats(3), default=(0.0, 0.0, 0.0), metavar="DEG,DEG,DEG",
                   help="mounting (boresight) error roll, pitch, heading, deg")
    p.add_argument("--imu", type=_floats(3), default=(0.0, 0.0, 0.0), metavar="DEG,DEG,DEG",
                   help="IMU attitude error roll, pitch, heading, deg")
    p.add_argument("--lever-arm", type=_floats(3), default=(0.0, 0.0, 0.0), metavar="M,M,M",
                   help="lever-arm error in the body frame (forward, right, down), m")
    p.add_argument("--gps", type=_floats(3), default=(0.0, 0.0, 0.0), metavar="M,M,M",
                   help="GPS position offset north, east, down, m")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=run_errors)


def run_errors(args: argparse.Namespace) -> int:
    from scangeo.lidar.error_sources import error_budget_by_source
    from scangeo.lidar.laser_equation import FlightGeometry, SystematicErrors

    geometry = FlightGeometry(
        height=args.height, fov=args.scan_angle * DEG, heading=args.heading * DEG,
        slope_along=math.tan(args.slope[0] * DEG), slope_across=math.tan(args.slope[1] * DEG),
    )
    errors = SystematicErrors(
        range_offset=args.range_error, index_error=args.index_error * DEG,
        scan_angle_error=args.scan_angle_error * DEG,
        plane_lean=args.plane_tilt[0] * DEG, plane_skew=args.plane_tilt[1] * DEG,
        mounting=tuple(v * DEG for v in args.mounting), imu=tuple(v * DEG for v in args.imu),
        lever_arm=tuple(args.lever_arm), gps=tuple(args.gps),
    )
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


def add_parser(subparsers, common) -> None:
    """Add ``scangeo lidar`` and its sub-commands."""
    parser = subparsers.add_parser("lidar", help="laser scanners: error model, strip adjustment, budget")
    sub = parser.add_subparsers(dest="lidar_command", metavar="SUBCOMMAND")
    _add_errors(sub, common)
    parser.set_defaults(func=lambda args: (parser.print_help(), 2)[1])


__all__ = ["add_parser", "LidarError"]
