"""Benchmark: the cost and the benefit of internal overviews in the orthoimages.

Run: python tests/benchmarks/overviews.py [--rows 7000] [--cols 900] [--bands 11] [--repeat 2]

Set-up (not timed): an uncompressed tiled working GeoTIFF like the one ``rectify_strip`` writes
before its last step: ROWS x COLS cells (default: a vienna2000 strip at 2.5 m, 7,000 x 900), BANDS
uint16 bands of smooth texture plus noise (deflate compresses it about as much as a Daedalus image).
Then, in this process, the last step (``scangeo.rectify.geotiff.finalise``) with ``overviews``
false and true, as a COG (the default) and as a plain tiled GeoTIFF, and what a viewer does when
zoomed out: read the whole extent at 1/16 of the resolution, from the file without and with
overviews. Figures: seconds (best of ``--repeat``), file size, ratios against the run without
overviews.

Second table: the overviews computed by scangeo (``scangeo.rectify.overviews``, the
default) against the previous route, GDAL's COG driver generating them itself (``OVERVIEWS=AUTO``,
``OVERVIEW_RESAMPLING=AVERAGE``; the baseline), for deflate (the default) and zstd compression:
wall and CPU seconds (CPU of every thread of this process: GDAL compresses with 2 threads), the
largest difference between the two routes' first overview levels.
"""
from __future__ import annotations

import argparse
import resource
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
import rasterio
from rasterio.transform import from_origin

from scangeo.rectify.geotiff import GeoTiffProfile, finalise

warnings.simplefilter("ignore")


def working_file(path: Path, rows: int, cols: int, bands: int) -> None:
    rng = np.random.default_rng(1)
    y, x = np.mgrid[0:rows, 0:cols].astype(np.float32)
    profile = {"driver": "GTiff", "width": cols, "height": rows, "count": bands, "dtype": "uint16",
               "crs": "EPSG:32633", "transform": from_origin(500000.0, 5300000.0, 2.5, 2.5), "nodata": 0,
               "tiled": True, "blockxsize": 256, "blockysize": 256, "compress": "none", "interleave": "band"}
    with rasterio.open(path, "w", **profile) as dst:
        for b in range(1, bands + 1):
            texture = 2000 + 600 * np.sin(x / (17.0 + b)) * np.cos(y / (23.0 + b)) + 300 * np.sin((x + y) / 91.0)
            dst.write((texture + rng.normal(0, 40, texture.shape)).astype(np.uint16), b)


def best_of(repeat: int, job, *args) -> float:
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        job(*args)
        times.append(time.perf_counter() - t)
    return min(times)


def zoomed_out_read(path: Path, shape: tuple[int, int, int]) -> None:
    with rasterio.open(path) as src:
        src.read(out_shape=shape)


def cpu_seconds() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def gdal_overviews(work: Path, out: Path, profile: GeoTiffProfile) -> None:
    """The previous route (the baseline): GDAL's COG driver generates the averaged overviews."""
    import rasterio.shutil

    opts = profile.creation_options(np.uint16, overviews=False)
    opts.update(OVERVIEWS="AUTO", OVERVIEW_RESAMPLING="AVERAGE")
    rasterio.shutil.copy(str(work), str(out), driver="COG", **opts)


def timed(repeat: int, job, *args) -> tuple[float, float]:
    """Best wall seconds and the CPU seconds of that run."""
    best = (float("inf"), float("inf"))
    for _ in range(repeat):
        t, c = time.perf_counter(), cpu_seconds()
        job(*args)
        best = min(best, (time.perf_counter() - t, cpu_seconds() - c))
    return best


def compare_routes(tmp: Path, work: Path, repeat: int) -> None:
    print("\noverviews computed by scangeo against GDAL's COG driver (baseline), COG output:")
    print(f"{'compression':<12}{'route':<22}{'wall s':>8}{'cpu s':>8}{'MB':>8}")
    for compress in ("deflate", "zstd"):
        profile = GeoTiffProfile(overviews=True, compress=compress)
        ours, theirs = tmp / f"ours-{compress}.tif", tmp / f"gdal-{compress}.tif"
        t_gdal = timed(repeat, gdal_overviews, work, theirs, profile)
        t_ours = timed(repeat, finalise, work, ours, profile, np.uint16)
        for name, (wall, cpu), path in (("GDAL (baseline)", t_gdal, theirs), ("scangeo", t_ours, ours)):
            print(f"{compress:<12}{name:<22}{wall:>8.2f}{cpu:>8.2f}{path.stat().st_size / 1e6:>8.1f}")
        with rasterio.open(ours) as a, rasterio.open(theirs) as b:
            shape = (a.count, (a.height + 1) // 2, (a.width + 1) // 2)
            diff = np.abs(a.read(out_shape=shape).astype(int) - b.read(out_shape=shape).astype(int)).max()
        print(f"{compress:<12}ratio GDAL / scangeo: wall x{t_gdal[0] / t_ours[0]:.2f}, "
              f"cpu x{t_gdal[1] / t_ours[1]:.2f}; "
              f"first level max |difference| {diff} DN")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--rows", type=int, default=7000)
    parser.add_argument("--cols", type=int, default=900)
    parser.add_argument("--bands", type=int, default=11)
    parser.add_argument("--repeat", type=int, default=2)
    args = parser.parse_args()

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        work = tmp / "working.tif"
        working_file(work, args.rows, args.cols, args.bands)
        print(f"{args.rows} x {args.cols} cells x {args.bands} bands uint16 "
              f"({args.rows * args.cols * args.bands * 2 / 1e6:.0f} MB uncompressed)")
        for cog in (True, False):
            rows = {}
            for overviews in (False, True):
                out = tmp / f"out-{cog}-{overviews}.tif"
                profile = GeoTiffProfile(overviews=overviews, cog=cog)
                seconds = best_of(args.repeat, finalise, work, out, profile, np.uint16)
                with rasterio.open(out) as src:
                    levels = src.overviews(1)
                    shape = (args.bands, max(1, args.rows // 16), max(1, args.cols // 16))
                view = best_of(args.repeat, zoomed_out_read, out, shape)
                rows[overviews] = (seconds, out.stat().st_size / 1e6, view, levels)
            (s0, mb0, v0, _), (s1, mb1, v1, levels) = rows[False], rows[True]
            kind = "COG" if cog else "tiled GeoTIFF"
            print(f"{kind}: write without overviews {s0:.2f} s ({mb0:.1f} MB), with overviews {levels} "
                  f"{s1:.2f} s ({mb1:.1f} MB): x{s1 / s0:.2f} time (+{s1 - s0:.2f} s), x{mb1 / mb0:.3f} size")
            print(f"{kind}: zoomed-out read (1/16) without overviews {v0 * 1000:.0f} ms, with {v1 * 1000:.0f} ms: "
                  f"x{v0 / max(v1, 1e-9):.1f} faster")
        compare_routes(tmp, work, args.repeat)


if __name__ == "__main__":
    main()
