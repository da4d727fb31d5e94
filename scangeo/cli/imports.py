"""``scangeo import parge STATUS.gcs OUT``: another tool's project as a scangeo project.

A thin shell over :func:`scangeo.importers.parge.import_parge` (docs/real-data.md).
"""
from __future__ import annotations

import sys


def add_parser(subparsers, common) -> None:
    p = subparsers.add_parser(
        "import", parents=[common], help="another tool's project (a PARGE status file) as a scangeo project",
        description="Write a scangeo project from another tool's project (docs/real-data.md).",
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
    q.add_argument("--image", default=None, metavar="CUBE",
                   help="the line's cube (ENVI: PARGE's .img with its .hdr), of the status file's pixels and lines")
    q.add_argument("--dtm", default=None, metavar="FILE|HEIGHT",
                   help="the DTM (orthometric heights), or a height in metres: a plane; default: a surface through "
                        "the GCPs' heights, labelled; without GCPs none (the project then needs one)")
    q.add_argument("--geoid", default=None, metavar="N|FILE",
                   help="geoid undulation in metres, or a raster of it (default: PARGE's height offset)")
    q.set_defaults(func=run)


def run(args) -> int:
    # here, not at the top: start-up cost (see scangeo.cli)
    from scangeo.cli import progress_of
    from scangeo.importers.parge import import_parge

    r = import_parge(args.status, args.out, sensor_model=args.sensor_model, dtm=args.dtm, geoid=args.geoid,
                     image=args.image, progress=progress_of(args))
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
