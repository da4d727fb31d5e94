"""Benchmark: the cost and the benefit of internal overviews in the orthoimages (issue 11 item 7).

Run: python tests/benchmarks/overviews.py [--rows 7000] [--cols 900] [--bands 11] [--repeat 2]

Set-up (not timed): an uncompressed tiled working GeoTIFF like the one ``rectify_strip`` writes
before its last step: ROWS x COLS cells (default: a vienna2000 strip at 2.5 m, 7,000 x 900), BANDS
uint16 bands of smooth texture plus noise (deflate compresses it about as much as a Daedalus image).
Then, in this process, the last step (``scangeo.rectify.geotiff.finalise``) with ``overviews``
false and true, as a COG (the default) and as a plain tiled GeoTIFF, and what a viewer does when
zoomed out: read the whole extent at 1/16 of the resolution, from the file without and with
overviews. Figures: seconds (best of ``--repeat``), file size, ratios against the run without
overviews.
"""
from __future__ import annotations

import argparse
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


if __name__ == "__main__":
    main()
