"""``scangeo rectify PROJECT --variant NAME``: orthoimages of the strips onto the DTM.

A thin shell over :func:`scangeo.rectify_strips` (``scangeo.workflow``): the ``[rectify]`` settings of
the project's settings file (PROJECT/run.toml or ``--config``, docs/run.md) replaced by the flags, a
progress bar, a one-line summary per strip.
"""
from __future__ import annotations

import argparse

from scangeo.cli import option_argument, settings_argument

_OPTIONS = "scangeo.rectify.options:RectifyOptions"


def add_parser(subparsers, common) -> None:
    p = subparsers.add_parser(
        "rectify", parents=[common], help="orthorectify strips onto the DTM (GeoTIFF/COG per strip, mosaic)",
        description="Rectify the strips of a project with a variant's orientation (docs/rectify.md). "
        "Outputs go to PROJECT/results/VARIANT/ortho/; complete outputs of an earlier run are skipped. "
        "Settings: the [rectify] table of PROJECT/run.toml (or --config), replaced by the flags.",
    )
    p.add_argument("project", help="the project folder")
    p.add_argument("--variant", required=True, help="variant whose orientation is used (DG: GPS/IMU as measured)")
    p.add_argument("--strips", nargs="+", default=None, metavar="ID", help="strip ids (default: all with an image)")
    option_argument(p, "--resolution", type=float, metavar="SIZE", option=f"{_OPTIONS}.resolution",
                    help="output cell size, map units")
    option_argument(p, "--bounds", type=float, nargs=4, metavar=("XMIN", "YMIN", "XMAX", "YMAX"),
                    option=f"{_OPTIONS}.bounds", help="output bounds, map CRS")
    option_argument(p, "--resampling", metavar="METHOD", option=f"{_OPTIONS}.resampling",
                    help="resampling of the image")
    option_argument(p, "--layers", nargs="+", metavar="LAYER", option=f"{_OPTIONS}.layers",
                    help="optional per-cell layers, written to NAME.layers.tif")
    option_argument(p, "--igm", action=argparse.BooleanOptionalAction, option=f"{_OPTIONS}.igm",
                    help="also write the ENVI IGM of every strip")
    option_argument(p, "--glt", action=argparse.BooleanOptionalAction, option=f"{_OPTIONS}.glt",
                    help="also write the ENVI GLT of every strip")
    option_argument(p, "--mosaic", action=argparse.BooleanOptionalAction, option=f"{_OPTIONS}.mosaic",
                    help="also write mosaic.tif of the strips rectified (closest to nadir wins; a platform: "
                         "mosaic-SENSOR.tif per sensor)")
    option_argument(p, "--occlusion", action=argparse.BooleanOptionalAction, option=f"{_OPTIONS}.occlusion",
                    help="make ground hidden by terrain nodata")
    option_argument(p, "--max-error", type=float, dest="max_error_px", metavar="PX", option=f"{_OPTIONS}.max_error_px",
                    help="tolerated inverse-map error on the validation sample")
    option_argument(p, "--memory", type=float, dest="memory_budget_mb", metavar="MIB",
                    option=f"{_OPTIONS}.memory_budget_mb",
                    help="memory budget per strip")
    option_argument(p, "--overviews", action=argparse.BooleanOptionalAction,
                    option="scangeo.rectify.geotiff:GeoTiffProfile.overviews",
                    help="internal overviews in the GeoTIFFs (auto: for outputs larger than 2048 cells)")
    settings_argument(p)
    option_argument(p, "--workers", type=int, metavar="N", option="scangeo.workflow:rectify_strips.workers",
                    help="strips rectified at once (local processes)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="run the strips on a Dask distributed scheduler")
    p.set_defaults(func=run, writes_project=True)  # one run at a time (scangeo.atomic.OutputLock)


def options_of(args: argparse.Namespace):
    """RectifyOptions of the settings file (``--config`` or PROJECT/run.toml) with the flags given."""
    # here, not at the top: start-up cost (see scangeo.cli)
    from scangeo.cli import project_settings, with_flags

    options = with_flags(project_settings(args).rectify, args)
    if args.overviews is not None:
        options = options.replace(geotiff=with_flags(options.geotiff, args))
    return options


def run(args: argparse.Namespace) -> int:
    # here, not at the top: start-up cost (see scangeo.cli)
    from scangeo.cli import passed, progress_of
    from scangeo.workflow import rectify_strips

    result = rectify_strips(args.project, args.variant, strips=args.strips, options=options_of(args),
                            scheduler=args.scheduler, progress=progress_of(args), **passed(args, "workers"))
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
    else:  # a platform's: one per sensor
        for sensor, path in result.mosaics.items():
            print(f"mosaic of sensor {sensor}: {path}")
    for fid, path in result.stacks.items():
        print(f"flight line {fid}: its sensors' bands stacked in {path}")
    for sid, c in result.coregistration.items():
        median, top = (f"{c[k]:.3f} m" if c[k] is not None else "-" for k in ("median_m", "max_m"))
        print(f"strip {sid}: co-registration to strip {c['reference']} in {c['path']} (propagated 1-sigma "
              f"relative displacement: median {median}, max {top})")
    if result.stacks:
        print(f"one grid for every sensor: {result.resolution:g} map units ({result.resolution_source})")
    print(f"{len(result.strips)} strips in {result.folder} ({result.seconds:.1f} s)")
    return 0
