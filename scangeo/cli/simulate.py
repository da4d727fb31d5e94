"""``scangeo simulate OUT --preset NAME``: a simulated block with known truth.

A thin shell over :func:`scangeo.simulate_project` (``scangeo.workflow``): the preset (a name of the
presets shipped in scangeo/data/presets or a TOML file) with ``--set`` overrides; prints a summary.
"""
from __future__ import annotations

import argparse
import tomllib

from scangeo.cli import option_argument
from scangeo.errors import OptionsError


def _override(text: str) -> dict:
    """``section.key=value`` (value in TOML syntax) -> nested dict."""
    if "=" not in text:
        raise argparse.ArgumentTypeError(f"{text!r}: expected KEY=VALUE, e.g. points.blunders=10")
    key, value = text.split("=", 1)
    try:
        parsed = tomllib.loads(f"v = {value.strip()}")["v"]
    except tomllib.TOMLDecodeError:
        parsed = value.strip()  # a bare string
    out: dict = {}
    node = out
    parts = [p.strip() for p in key.strip().split(".")]
    for part in parts[:-1]:
        node = node.setdefault(part, {})
    node[parts[-1]] = parsed
    return out


def add_parser(subparsers, common) -> None:
    p = subparsers.add_parser(
        "simulate", parents=[common], help="simulate a block (project + truth/) from a preset",
        description="Write a simulated project folder with a truth/ folder (docs/simulate.md).",
    )
    p.add_argument("out", nargs="?", help="the project folder to create")
    option_argument(p, "--preset", option="scangeo.workflow:simulate_project.preset",
                    help="preset name (see --list-presets) or a TOML file")
    p.add_argument("--seed", type=int, default=None, help="random seed (default: the preset's)")
    p.add_argument("--dtm", default=None, metavar="FILE",
                   help="a real DTM file for the true terrain (any GDAL raster with a CRS)")
    p.add_argument("--texture", default=None, help="an RGB orthophoto for the scene instead of procedural land cover")
    p.add_argument("--set", dest="overrides", action="append", type=_override, default=[], metavar="KEY=VALUE",
                   help="override a preset key, e.g. --set points.blunders=10 --set flight.lines=1200")
    option_argument(p, "--images", action=argparse.BooleanOptionalAction,
                    option="scangeo.workflow:simulate_project.images",
                    help="render the images and the truth orthoimage")
    option_argument(p, "--overwrite", action=argparse.BooleanOptionalAction,
                    option="scangeo.workflow:simulate_project.overwrite", help="replace OUT if it exists")
    p.add_argument("--list-presets", action="store_true", help="list the shipped presets and exit")
    p.add_argument("--show-preset", metavar="NAME", default=None,
                   help="print a shipped preset's TOML (to copy and edit: --show-preset small > my.toml) and exit")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    # here, not at the top: start-up cost (see scangeo.cli)
    from scangeo.cli import passed, progress_of
    from scangeo.simulate.config import available_presets, merge, preset_path
    from scangeo.workflow import LaserSimulation, simulate_project

    if args.list_presets:
        for name in available_presets():
            print(name)
        return 0
    if args.show_preset:
        print(preset_path(args.show_preset).read_text(encoding="utf-8"), end="")
        return 0
    if not args.out:
        raise OptionsError("give the folder OUT to write (or --list-presets, --show-preset)")
    overrides: dict = {}
    for o in args.overrides:
        overrides = merge(overrides, o)
    block = simulate_project(args.out, seed=args.seed, overrides=overrides, dtm=args.dtm, texture=args.texture,
                             progress=progress_of(args), **passed(args, "preset", "images", "overwrite"))
    if isinstance(block, LaserSimulation):
        strips = block.summary["truth"]["strips"]
        cfg = block.summary["config"]
        print(f"simulated laser block (seed {block.seed}) into {block.root}: {len(strips)} strips, "
              f"{sum(s['returns'] for s in strips.values())} returns, {block.summary['buildings']} buildings, "
              f"{cfg['control_patches']} control and {cfg['check_patches']} check patches; truth in truth.json")
        return 0
    config = block.config
    pts = block.points
    counts = {k: int((pts.kind == k).sum()) for k in "EBKHT"}
    print(f"simulated {config.block.name!r} (seed {block.seed}) into {block.root}")
    print(f"  CRS {block.map_frame.crs.to_string()}, flight height {block.plan.flight_height_m:.0f} m, "
          f"swath {block.plan.swath_m:.0f} m, strip spacing {block.plan.spacing_m:.0f} m")
    if config.is_platform:
        lengths = {s.sensor: s.geometry.n_lines for s in block.strips}
        returns = {s.sensor: 0 for s in block.laser_strips}
        for laser in block.laser_strips:
            returns[laser.sensor] += laser.returns
        print(f"  flight lines: {', '.join(line.line_id for line in block.flight_lines)}, each recorded by "
              + ", ".join(f"{s.id} ({s.kind}, {returns[s.id]} returns in all)" if s.kind == "laser" else
                          f"{s.id} ({s.kind}, {lengths[s.id]} lines x {s.pixels} pixels"
                          + ("" if s.measures_control else ", no control") + ")" for s in config.sensors()))
    else:
        print(f"  strips: {', '.join(s.strip_id for s in block.strips)} x {config.flight.lines} lines x "
              f"{config.sensor.pixels} pixels")
    print(f"  points: {counts['E']} control, {counts['B']} break-band, {counts['K']} check, {counts['H']} height, "
          f"{counts['T']} tie; {len(pts.m_point)} measurements ({int(pts.blunder.sum())} blunders)")
    return 0
