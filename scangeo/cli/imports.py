"""``scangeo import parge STATUS.gcs OUT`` and ``scangeo import lcf CUBE OUT``: a sensor's or another tool's files
as a scangeo project.

Thin shells over :func:`scangeo.importers.parge.import_parge` and :func:`scangeo.importers.lcf.import_lcf`
(docs/real-data.md).
"""
from __future__ import annotations

import sys


def add_parser(subparsers, common) -> None:
    p = subparsers.add_parser(
        "import", parents=[common],
        help="a sensor's or another tool's files (a drone line's .lcf, a PARGE status file) as a scangeo project",
        description="Write a scangeo project from the files a sensor or another tool wrote (docs/real-data.md).",
    )
    sub = p.add_subparsers(dest="tool", metavar="TOOL", required=True)
    q = sub.add_parser(
        "parge", parents=[common], help="a PARGE status file (.gcs) of a HySpex line",
        description="Write a scangeo project from a PARGE 3.4 status file: the line's navigation in "
                    "scangeo's conventions, the look angles, PARGE's boresight, its GCPs as control (used) "
                    "and check (unused) points, a DTM, and the variants PARGE, BORESIGHT and CALIBRATED. "
                    "What was decided and why is in OUT/import.json (docs/real-data.md).",
    )
    q.add_argument("status", help="the PARGE status file (.gcs)")
    q.add_argument("out", help="the project folder to write (new or empty)")
    q.add_argument("--sensor-model", default=None, metavar="FILE",
                   help="a HySpex sensor-model file (pixel vinkelx vinkely) instead of the status file's look "
                        "angles")
    q.add_argument("--cube", default=None, metavar="CUBE",
                   help="the line's cube (ENVI: PARGE's .img with its .hdr), of the status file's pixels and lines")
    q.add_argument("--dtm", default=None, metavar="FILE",
                   help="the DTM (orthometric heights), or a height in metres: a plane; default: a surface through "
                        "the GCPs' heights, labelled; without GCPs none (the project then needs one)")
    q.add_argument("--geoid", default=None, metavar="N|FILE",
                   help="geoid undulation in metres, or a raster of it (default: PARGE's height offset)")
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
    for note in r.notes:
        print(f"note: {note}")
    for warning in r.warnings:
        print(f"warning: {warning}")
    print(f"project written to {r.folder}", file=sys.stderr)
    return 0


def run(args) -> int:
    # here, not at the top: start-up cost (see scangeo.cli)
    from scangeo.cli import progress_of
    from scangeo.importers.parge import import_parge

    r = import_parge(args.status, args.out, sensor_model=args.sensor_model, dtm=args.dtm, geoid=args.geoid,
                     image=args.cube, progress=progress_of(args))
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
    for note in r.notes:
        print(f"note: {note}")
    for warning in r.warnings:
        print(f"warning: {warning}")
    print(f"project written to {r.folder}", file=sys.stderr)
    return 0
