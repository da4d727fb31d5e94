"""Benchmark: what the overviews of outputs of 513-2048 cells cost, which strict COG validation asks for.

Run: python tests/benchmarks/cog_strict.py [--repeat 3] [--bands 11]

rio-cogeo's strict validation (``cog_validate(strict=True)``: its warnings are errors) asks for
internal overviews on every raster larger than 512 cells on a side. With ``overviews = "auto"`` scangeo
writes them above ``OVERVIEW_MIN_SIZE`` cells: 2048 before (the baseline: ``overviews = false`` for
these sizes), 512 now (``overviews = "auto"``). For each size, an uncompressed tiled working file like
the one rectification writes before its last step (BANDS uint16 bands of smooth texture plus noise, and
a one-band float32 layer; set-up not timed), then that last step (``scangeo.rectify.geotiff.finalise``:
the levels averaged by scangeo, the COG assembled by scangeo's COG writer), side by side in this process:
wall and CPU seconds (best of ``--repeat``; CPU of every thread of this process; numba's kernels loaded
before), file size, the ratio against the baseline, and rio-cogeo's strict verdict on both files.
"""
from __future__ import annotations

import argparse
import os
import tempfile
import warnings
from pathlib import Path

import numpy as np
import rasterio
from rasterio.transform import from_origin
from rio_cogeo import cogeo

from scangeo.rectify.geotiff import OVERVIEW_MIN_SIZE, GeoTiffProfile, finalise
from tests.benchmarks.overviews import timed

warnings.simplefilter("ignore")

#: (rows, cols) of the outputs measured: a small mosaic, a square tile, a short strip, the old threshold
SIZES = ((600, 600), (1024, 1024), (2048, 760), (2048, 2048))


def working_file(path: Path, rows: int, cols: int, bands: int, dtype: str) -> None:
    rng = np.random.default_rng(1)
    y, x = np.mgrid[0:rows, 0:cols].astype(np.float32)
    profile = {"driver": "GTiff", "width": cols, "height": rows, "count": bands, "dtype": dtype,
               "crs": "EPSG:32633", "transform": from_origin(500000.0, 5300000.0, 2.5, 2.5),
               "nodata": 0 if dtype == "uint16" else float("nan"), "tiled": True, "blockxsize": 256,
               "blockysize": 256, "compress": "none", "interleave": "band"}
    with rasterio.open(path, "w", **profile) as dst:
        for b in range(1, bands + 1):
            texture = 2000 + 600 * np.sin(x / (17.0 + b)) * np.cos(y / (23.0 + b)) + 300 * np.sin((x + y) / 91.0)
            dst.write((texture + rng.normal(0, 40, texture.shape)).astype(dtype), b)


def strict(path: Path) -> str:
    valid, errors, warns = cogeo.cog_validate(str(path), strict=True, quiet=True)
    return "valid" if valid else "INVALID (" + "; ".join(errors + warns)[:60] + ")"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--bands", type=int, default=11)
    args = parser.parse_args()
    print(f"load average {os.getloadavg()[0]:.1f}; OVERVIEW_MIN_SIZE = {OVERVIEW_MIN_SIZE}; best of {args.repeat}")
    print(f"{'output':<28}{'overviews':<26}{'wall s':>8}{'cpu s':>8}{'MB':>8}  strict validation")
    totals = {False: 0.0, "auto": 0.0}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        working_file(tmp / "warm.tif", 600, 600, 1, "uint16")  # numba's kernels loaded before any timing
        finalise(tmp / "warm.tif", tmp / "warm-out.tif", GeoTiffProfile(overviews=True), np.dtype("uint16"))
        for rows, cols in SIZES:
            for bands, dtype in ((args.bands, "uint16"), (1, "float32")):
                work = tmp / f"work-{rows}-{cols}-{dtype}.tif"
                working_file(work, rows, cols, bands, dtype)
                label = f"{rows} x {cols} x {bands} {dtype}"
                figures = {}
                for overviews, name in ((False, "none (baseline)"), ("auto", "auto (default now)")):
                    out = tmp / f"out-{rows}-{cols}-{dtype}-{overviews}.tif"
                    wall, cpu = timed(args.repeat, finalise, work, out, GeoTiffProfile(overviews=overviews),
                                      np.dtype(dtype))
                    with rasterio.open(out) as src:
                        levels = src.overviews(1)
                    figures[overviews] = (wall, cpu)
                    totals[overviews] += cpu
                    print(f"{label:<28}{name + ' ' + str(levels):<26}{wall:>8.3f}{cpu:>8.3f}"
                          f"{out.stat().st_size / 1e6:>8.2f}  {strict(out)}")
                (w0, c0), (w1, c1) = figures[False], figures["auto"]
                print(f"{label:<28}{'ratio auto / baseline':<26}{w1 / w0:>7.2f}x{c1 / c0:>7.2f}x")
    print(f"all outputs, CPU s: baseline {totals[False]:.2f}, auto {totals['auto']:.2f}, "
          f"ratio {totals['auto'] / totals[False]:.2f}x")


if __name__ == "__main__":
    main()
