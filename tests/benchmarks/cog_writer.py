"""Benchmark: scangeo's own COG writer against GDAL's COG driver with libdeflate (rasterio's wheel), side
by side in one process on the same working file.

A strip-like orthoimage (``--bands`` bands of uint16, ``--width`` x ``--lines`` cells: a smooth field,
sensor noise, a nodata margin) is written once as an uncompressed tiled GeoTIFF (set-up, not timed).
Then :func:`scangeo.rectify.geotiff.finalise` turns it into the final COG (deflate, predictor 2,
overviews averaged by scangeo) by each route, ``--repeat`` times, alternating:

* ``scangeo``: :class:`~scangeo.rectify.cog_writer.CogWriter`, ISA-L deflate in worker threads;
* ``gdal``: GDAL's COG driver (libdeflate, ``NUM_THREADS`` as the profile's threads), the overviews
  handed over through a VRT.

Printed per route: CPU seconds of the process (every thread), wall seconds, the file's size; then the
ratios gdal / scangeo (the least of the repeats). The deflate level is GDAL's (1 unless ``--level``).

Run: python tests/benchmarks/cog_writer.py [--lines 10000] [--width 760] [--bands 11] [--repeat 3]
[--level 1] [--threads ALL_CPUS]
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import rasterio
from affine import Affine

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from scangeo.rectify.geotiff import GeoTiffProfile, finalise  # noqa: E402


def working_file(path: Path, width: int, lines: int, bands: int) -> None:
    rng = np.random.default_rng(0)
    y, x = np.mgrid[0:256, 0:width]
    with rasterio.open(path, "w", driver="GTiff", width=width, height=lines, count=bands, dtype="uint16",
                       crs="EPSG:32633", transform=Affine(2.5, 0, 600000.0, 0, -2.5, 5350000.0), nodata=0,
                       tiled=True, blockxsize=512, blockysize=512) as dst:
        for r in range(0, lines, 256):
            h = min(256, lines - r)
            base = 2000 + 600 * np.sin(x[:h] / 37.0) + 400 * np.cos((y[:h] + r) / 53.0)
            tile = np.stack([base * (1 + 0.05 * b) + rng.normal(0, 8, base.shape) for b in range(bands)])
            tile = tile.astype(np.uint16)
            tile[:, :, :30] = 0  # the swath's nodata margin
            dst.write(tile, window=rasterio.windows.Window(0, r, width, h))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lines", type=int, default=10000)
    ap.add_argument("--width", type=int, default=760)
    ap.add_argument("--bands", type=int, default=11)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--level", type=int, default=None)
    ap.add_argument("--threads", default="ALL_CPUS")
    args = ap.parse_args()
    print(f"load {os.getloadavg()[0]:.1f}; GDAL {rasterio.__gdal_version__}; "
          f"OPENBLAS_CORETYPE={os.environ.get('OPENBLAS_CORETYPE')}", flush=True)
    with tempfile.TemporaryDirectory(prefix="cogbench_") as tmp:
        work = Path(tmp) / "working.tif"
        working_file(work, args.width, args.lines, args.bands)
        best: dict[str, tuple[float, float, int]] = {}
        for rep in range(args.repeat):
            for writer in ("scangeo", "gdal"):
                profile = GeoTiffProfile(overviews=True, writer=writer, level=args.level, threads=args.threads)
                out = Path(tmp) / f"{writer}.tif"
                out.unlink(missing_ok=True)
                cpu, wall = time.process_time(), time.perf_counter()
                finalise(work, out, profile, np.uint16)
                cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
                size = out.stat().st_size
                print(f"{rep} {writer:8s} CPU {cpu:6.2f} s  wall {wall:6.2f} s  {size / 1e6:7.1f} MB", flush=True)
                if writer not in best or cpu < best[writer][0]:
                    best[writer] = (cpu, wall, size)
        s, g = best["scangeo"], best["gdal"]
        print(f"\nleast of {args.repeat}: scangeo {s[0]:.2f} CPU s / {s[1]:.2f} wall s / {s[2] / 1e6:.1f} MB; "
              f"gdal {g[0]:.2f} / {g[1]:.2f} / {g[2] / 1e6:.1f} MB; gdal / scangeo: CPU {g[0] / s[0]:.2f}x, "
              f"wall {g[1] / s[1]:.2f}x, size {g[2] / s[2]:.3f}x; load {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
