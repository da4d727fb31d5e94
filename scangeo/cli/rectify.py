"""``scangeo rectify PROJECT --variant NAME``: orthoimages of the strips onto the DTM.

A thin shell over :func:`scangeo.rectify_strips` (``scangeo.workflow``): settings from ``--config``
(a TOML file with a ``[rectify]`` table, docs/rectify.md) overridden by the flags, a progress bar,
a one-line summary per strip.
"""
from __future__ import annotations

import argparse


def add_parser(subparsers, common) -> None:
    p = subparsers.add_parser(
        "rectify", parents=[common], help="orthorectify strips onto the DTM (GeoTIFF/COG per strip, mosaic)",
        description="Rectify the strips of a project with a variant's orientation (docs/rectify.md). "
        "Outputs go to PROJECT/results/VARIANT/ortho/; complete outputs of an earlier run are skipped.",
    )
    p.add_argument("project", help="the project folder")
    p.add_argument("--variant", required=True, help="variant whose orientation is used (DG: GPS/IMU as measured)")
    p.add_argument("--strips", nargs="+", default=None, metavar="ID", help="strip ids (default: all)")
    p.add_argument("--resolution", type=float, default=None, help="output cell size, map units (default: nadir pixel)")
    p.add_argument("--bounds", type=float, nargs=4, default=None, metavar=("XMIN", "YMIN", "XMAX", "YMAX"),
                   help="output bounds, map units (default: each strip's footprint)")
    p.add_argument("--resampling", choices=("nearest", "bilinear", "cubic"), default=None)
    p.add_argument("--layers", nargs="+", default=None, metavar="LAYER",
                   help="optional layers: scan_angle view_zenith time ground_pixel")
    p.add_argument("--igm", action="store_true", default=None, help="also write the ENVI IGM of every strip")
    p.add_argument("--glt", action="store_true", default=None, help="also write the ENVI GLT of every strip")
    p.add_argument("--mosaic", action="store_true", default=None, help="also write mosaic.tif (closest to nadir wins)")
    p.add_argument("--no-occlusion", dest="occlusion", action="store_false", default=None,
                   help="do not make ground hidden by terrain nodata")
    p.add_argument("--max-error", type=float, default=None, dest="max_error_px",
                   help="tolerated inverse-map error on the validation sample, pixels (default 0.05)")
    p.add_argument("--memory", type=float, default=None, dest="memory_budget_mb", help="memory budget per strip, MiB")
    p.add_argument("--overviews", action=argparse.BooleanOptionalAction, default=None,
                   help="internal overviews in the GeoTIFFs (default: for outputs larger than 2048 cells, "
                        "[rectify.geotiff] overviews = \"auto\")")
    p.add_argument("--config", default=None, help="TOML file with a [rectify] table of settings")
    p.add_argument("--workers", type=int, default=1, help="strips rectified at once (local processes)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="run the strips on a Dask distributed scheduler")
    p.set_defaults(func=run, writes_project=True)  # one run at a time (scangeo.atomic.OutputLock)


def options_of(args: argparse.Namespace):
    """RectifyOptions from ``--config`` and the flags (flags win)."""
    # here, not at the top: start-up cost (see scangeo.cli)
    from scangeo.cli import settings_table
    from scangeo.rectify.options import RectifyOptions

    table = settings_table(args.config, "rectify")
    for key in ("resolution", "bounds", "resampling", "layers", "igm", "glt", "mosaic", "occlusion",
                "max_error_px", "memory_budget_mb"):
        value = getattr(args, key)
        if value is not None:
            table[key] = value
    if args.overviews is not None:
        table["geotiff"] = {**table.get("geotiff", {}), "overviews": args.overviews}
    return RectifyOptions.from_dict(table, source=args.config or "rectify options")


def run(args: argparse.Namespace) -> int:
    # here, not at the top: start-up cost (see scangeo.cli)
    from scangeo.cli import progress_of
    from scangeo.workflow import rectify_strips

    result = rectify_strips(args.project, args.variant, strips=args.strips, options=options_of(args),
                            workers=args.workers, scheduler=args.scheduler, progress=progress_of(args))
    for sid, s in result.strips.items():
        if s["status"] == "skipped":
            print(f"strip {sid}: complete from an earlier run, skipped ({s['path']})")
        else:
            g = s["grid"]
            print(f"strip {sid}: {s['path']} ({g['width']} x {g['height']} cells at {g['resolution']:g}, "
                  f"{s['valid_cells']} valid, {s['hidden_cells']} hidden, inverse map max error "
                  f"{s['inverse_map_max_error_px']:.3f} px, {s['seconds']:.1f} s)")
    if result.mosaic:
        print(f"mosaic: {result.mosaic}")
    print(f"{len(result.strips)} strips in {result.folder} ({result.seconds:.1f} s)")
    return 0
