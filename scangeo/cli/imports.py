"""``scangeo import parge STATUS.gcs [STATUS.gcs ...] OUT`` and ``scangeo import lcf CUBE OUT``: a sensor's or
another tool's files as a scangeo project.

Thin shells over :func:`scangeo.importers.parge.import_parge` (one status file),
:func:`scangeo.importers.parge_platform.import_parge_platform` (several) and :func:`scangeo.importers.lcf.import_lcf`
(docs/real-data.md).
"""
from __future__ import annotations

import sys
from pathlib import Path


def add_parser(subparsers, common) -> None:
    p = subparsers.add_parser(
        "import", parents=[common],
        help="a sensor's or another tool's files (a drone line's .lcf, a PARGE status file) as a scangeo project",
        description="Write a scangeo project from the files a sensor or another tool wrote (docs/real-data.md).",
    )
    sub = p.add_subparsers(dest="tool", metavar="TOOL", required=True)
    q = sub.add_parser(
        "parge", parents=[common], help="PARGE status files (.gcs) of HySpex lines: one line, or a platform's several",
        description="Write a scangeo project from PARGE 3.4 status files. One file: the line's navigation in "
                    "scangeo's conventions, the look angles, PARGE's boresight, its GCPs as control (used) "
                    "and check (unused) points, a DTM, and the variants PARGE, BORESIGHT and CALIBRATED. "
                    "Several files of one flight: one platform project, a sensor per camera, the lines whose "
                    "navigation is one stretch of one INS on one flight line, PARGE's offsets in each sensor's "
                    "mounting. What was decided and why is in OUT/import.json (docs/real-data.md).",
    )
    q.add_argument("paths", nargs="+", metavar="STATUS.gcs [STATUS.gcs ...] OUT",
                   help="the PARGE status files (.gcs), then the project folder to write (new or empty)")
    q.add_argument("--sensor-model", default=None, metavar="FILE", action="append",
                   help="a HySpex sensor-model file (pixel vinkelx vinkely) instead of the status file's look "
                        "angles; with several status files once per file, in their order ('-' for none)")
    q.add_argument("--cube", default=None, metavar="CUBE", action="append",
                   help="the line's cube (ENVI: PARGE's .img with its .hdr), of the status file's pixels and lines; "
                        "with several status files once per file, in their order ('-' for none)")
    q.add_argument("--dtm", default=None, metavar="FILE",
                   help="the DTM (orthometric heights), or a height in metres: a plane; default: a surface through "
                        "the GCPs' heights, labelled; without GCPs none (the project then needs one)")
    q.add_argument("--geoid", default=None, metavar="N|FILE",
                   help="geoid undulation in metres, or a raster of it (default: PARGE's height offset; of several "
                        "lines the first flight line's reference line's)")
    q.add_argument("--relative-mounting", default=None, action="append",
                   metavar="SENSOR:REFERENCE:ROLL,PITCH,HEADING:SIGMA[,SIGMA,SIGMA]",
                   help="several status files: a prior on SENSOR's mounting relative to REFERENCE's (degrees: roll, "
                        "pitch, heading of R_BS(REFERENCE)^T R_BS(SENSOR), and their sigmas); repeatable")
    q.set_defaults(func=run)
    add_lcf_parser(sub, common)


def add_lcf_parser(sub, common) -> None:
    q = sub.add_parser(
        "lcf", parents=[common], help="a Resonon or Specim drone line: ENVI cube, .lcf and .times",
        description="Write a scangeo project from a drone pushbroom line: the ENVI cube, its navigation log (.lcf) "
                    "and its line times (.times), in the conventions of lcf_spec (roll positive right wing up, "
                    "heading from north), the time bases met as the specification says, the altitude's datum "
                    "decided from the data. What was decided and why is in OUT/import.json (docs/real-data.md).",
    )
    q.add_argument("cube", help="the cube's header (.hdr) or data file (.bil, .bip, .bsq, ...)")
    q.add_argument("out", help="the project folder to write (new or empty)")
    q.add_argument("--lcf", default=None, metavar="FILE", help="the navigation log (default: X.lcf beside the cube)")
    q.add_argument("--times", default=None, metavar="FILE",
                   help="the line times (default: X.bil.times or X.times beside the cube)")
    camera = q.add_mutually_exclusive_group(required=True)
    camera.add_argument("--fov", type=float, default=None, metavar="DEG",
                        help="the camera's field of view over the cube's samples (deg)")
    camera.add_argument("--look-angles", default=None, metavar="FILE",
                        help="a look-angle table pixel,along_deg,across_deg of the cube's samples")
    q.add_argument("--pixels-increase", choices=("right", "left"), default="right",
                   help="with --fov: pixel numbers grow to the right or the left of the flight direction "
                        "(default: %(default)s)")
    q.add_argument("--dtm", default=None, metavar="FILE",
                   help="the DTM (orthometric heights), or a height in metres: a plane (over water: the sea "
                        "surface, 0); default: a surface through the GCPs' heights, else none")
    q.add_argument("--geoid", default=None, metavar="N|FILE", help="geoid undulation in metres, or a raster of it")
    q.add_argument("--altitude", choices=("auto", "ellipsoidal", "orthometric"), default="auto",
                   help="the datum of the .lcf's altitude (default: %(default)s, decided from the data)")
    q.add_argument("--ground", default=None, metavar="CSV", help="ground.csv of GCPs (with --measurements)")
    q.add_argument("--measurements", default=None, metavar="CSV",
                   help="points.csv: the GCPs measured in the cube (strip: the line's id)")
    q.add_argument("--crs", default=None, help="the map CRS (default: the line's UTM zone)")
    q.add_argument("--strip", default=None, help="the line's id (default: the cube's name)")
    q.add_argument("--knot-spacing", type=float, default=None, metavar="S",
                   help="the spline's knot spacing in seconds (default: decided from the attitude)")
    q.set_defaults(func=run_lcf)


def run_lcf(args) -> int:
    # here, not at the top: start-up cost (see scangeo.cli)
    from scangeo.cli import progress_of
    from scangeo.importers.lcf import import_lcf

    r = import_lcf(args.cube, args.out, lcf=args.lcf, times=args.times, fov_deg=args.fov,
                   look_angles=args.look_angles, pixels_increase=args.pixels_increase, dtm=args.dtm,
                   geoid=args.geoid, altitude=args.altitude, ground=args.ground, points=args.measurements,
                   crs=args.crs, strip=args.strip, knot_spacing_s=args.knot_spacing, progress=progress_of(args))
    print(f"strip {r.strip}: {r.lines} lines at {r.line_rate_hz:.4f} Hz; {r.control} control and {r.check} check "
          "points")
    for d in r.record.decisions:
        print(f"{d.topic}: {d.choice}")
    return _said(r.notes, r.warnings, r.folder)


def _said(notes, warnings, folder) -> int:
    """Print an import's notes and warnings, and where it wrote the project."""
    for note in notes:
        print(f"note: {note}")
    for warning in warnings:
        print(f"warning: {warning}")
    print(f"project written to {folder}", file=sys.stderr)
    return 0


def run(args) -> int:
    # here, not at the top: start-up cost (see scangeo.cli)
    from scangeo.cli import progress_of
    from scangeo.errors import ArgumentError

    if len(args.paths) < 2:
        raise ArgumentError("paths: expected STATUS.gcs [STATUS.gcs ...] OUT")
    *statuses, out = args.paths
    if len(statuses) > 1:
        return _run_platform(args, statuses, out)
    if args.relative_mounting:
        raise ArgumentError("{relative_mounting}: a prior between sensors needs several status files",
                            relative_mounting=args.relative_mounting[0])
    from scangeo.importers.parge import import_parge

    r = import_parge(statuses[0], out, sensor_model=_one(args.sensor_model, "sensor_model"), dtm=args.dtm,
                     geoid=args.geoid, image=_one(args.cube, "cube"), progress=progress_of(args))
    print(f"strip {r.strip}: {r.control} control and {r.check} check GCPs; line rate {r.line_rate_hz:.4f} Hz "
          f"({r.line_rate_source})")
    print(f"PARGE's boresight in scangeo's convention: roll {r.boresight_deg[0]:.4f}, pitch {r.boresight_deg[1]:.4f}, "
          f"heading {r.boresight_deg[2]:.4f} deg ({r.offsets.description})")
    for h in r.hypotheses:
        fit = (f"GCP rms {h.fit_px[0]:.2f} lines, {h.fit_px[1]:.2f} px" if h.fit_px else "not tested")
        mark = "*" if h.held == r.offsets.held else " "
        print(f"  {mark} {h.description}: {fit}")
    print(f"heights: {r.geoid}")
    print(f"DTM: {r.dtm}")
    return _said(r.notes, r.warnings, r.folder)


def _one(values, name: str):
    from scangeo.errors import ArgumentError

    if not values:
        return None
    if len(values) > 1:
        raise ArgumentError(f"{{{name}}}: given {len(values)} times for one status file", **{name: values[-1]})
    return None if values[0] == "-" else values[0]


def _per_file(values, n: int):
    return None if not values else [None if v == "-" else v for v in values]


def _run_platform(args, statuses, out) -> int:
    from scangeo.cli import progress_of
    from scangeo.importers.parge_platform import import_parge_platform, parse_relative_mounting

    priors = tuple(parse_relative_mounting(text) for text in args.relative_mounting or ())
    r = import_parge_platform(statuses, out, sensor_models=_per_file(args.sensor_model, len(statuses)),
                              cubes=_per_file(args.cube, len(statuses)), dtm=args.dtm, geoid=args.geoid,
                              relative_mountings=priors, progress=progress_of(args))
    for flight_line, strips in r.flight_lines.items():
        print(f"flight line {flight_line}: {', '.join(strips)}")
        for strip in strips[1:]:
            a = r.agreements[Path(r.strips[strip]).name]
            print(f"  {strip} on {strips[0]}'s navigation: time offset {1e3 * a.time_offset_s:+.3f} ms; positions "
                  f"within {a.position_max_shifted_m:.3f} m; attitude {max(a.attitude_rms_shifted_deg):.4f} deg rms "
                  "beyond a constant")
    for sensor, m in r.sensors.items():
        print(f"sensor {sensor} ({m.camera}): boresight roll {m.boresight_deg[0]:.4f}, pitch {m.boresight_deg[1]:.4f}, "
              f"heading {m.boresight_deg[2]:.4f} deg on the INS; its single-line attitude {m.departure_deg[0]:.4f} deg "
              f"rms ({m.departure_deg[1]:.4f} at most) from it")
    print(f"{r.control} control and {r.check} check GCPs; heights: {r.geoid}")
    return _said(r.notes, r.warnings, r.folder)
