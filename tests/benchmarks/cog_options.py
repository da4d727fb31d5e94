"""Benchmark: the orthoimage's last step (the working file into its final compressed COG with
overviews) under the layout options every GeoTIFF reader decodes.

Run: python tests/benchmarks/cog_options.py [--lines 10000] [--keep DIR] [--repeat 2]

Set-up (not timed): the project of ``tests/benchmarks/rectify.py`` (one simulated Daedalus strip of
716 px x ``--lines`` lines, 11 uint16 bands; ``--keep`` shares it with that script), rectified once by
passes 1 and 2 into the uncompressed working GeoTIFF that ``scangeo.rectify.geotiff.finalise``
starts from. Then, side by side in this process, that file is finalised with each profile:

* the default (deflate level 1, horizontal predictor, ``NUM_THREADS=ALL_CPUS``, 512-cell blocks,
  overviews averaged by scangeo and handed to GDAL through a VRT);
* deflate levels 2 and 6 (GDAL's default), no predictor, 1 compression thread, blocks of 256 and 1024;
* the overviews made by GDAL's COG driver (``OVERVIEW_RESAMPLING=AVERAGE``, the route before);
* zstd level 1 (not the default: not every reader decodes it) and no compression, for scale.

Figures: wall and CPU seconds of the step (CPU of every thread of the process, GDAL's compression
threads included), the output's size, and the best of ``--repeat`` runs (alternating the profiles).
"""
from __future__ import annotations

import argparse
import os
import resource
import shutil
import sys
import tempfile
import time
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
warnings.simplefilter("ignore")


def cpu_seconds() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def working_file(root: Path, out_dir: Path) -> tuple[Path, np.dtype]:
    """Passes 1 and 2 of the benchmark strip into an uncompressed working GeoTIFF in ``out_dir``."""
    import rasterio

    from scangeo.io.project import Project
    from scangeo.rectify.cell_map import map_cells
    from scangeo.rectify.core_geometry import CoreStripGeometry
    from scangeo.rectify.geotiff import bands_of
    from scangeo.rectify.options import RectifyOptions
    from scangeo.rectify.strip import open_strip_image, resample
    from scangeo.rectify.strip_run import gdal_cache, start_run, strip_grid

    project = Project.load(root)
    geometry = CoreStripGeometry(project.geometry("01"), project.dtm)
    options = RectifyOptions(resolution=2.5)
    grid = strip_grid(geometry, options)
    with rasterio.Env(GDAL_CACHEMAX=gdal_cache(options)), \
            open_strip_image(root / "images" / "01.tif", geometry) as src:
        run = start_run(geometry, grid, options, src, out_dir / "ortho.tif", out_dir)
        map_cells(run, lambda *a: None)
        resampled = resample(run, bands_of(src), {}, lambda *a: None)
    return resampled.image, resampled.dtype


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lines", type=int, default=10_000)
    ap.add_argument("--keep", default=None, help="the project folder of tests/benchmarks/rectify.py (kept)")
    ap.add_argument("--repeat", type=int, default=2)
    args = ap.parse_args()

    import rasterio

    from scangeo.rectify.geotiff import GeoTiffProfile, finalise
    from scangeo.rectify.options import RectifyOptions
    from scangeo.rectify.strip_run import gdal_cache
    from tests.benchmarks.rectify import make_project

    tmp = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="scangeo-bench-cog-"))
    root = tmp / "project"
    if not (root / "project.toml").exists():
        make_project(root, args.lines)
    work = Path(tempfile.mkdtemp(prefix="cog-", dir=tmp))
    try:
        working, dtype = working_file(root, work)
        with rasterio.open(working) as src:
            shape = (src.count, src.height, src.width)
        raw = int(np.prod(shape)) * np.dtype(dtype).itemsize
        default = GeoTiffProfile()
        profiles = {
            "default: deflate 1, predictor, ALL_CPUS, 512": default,
            "deflate 2": replace(default, level=2),
            "deflate 6 (GDAL's default level)": replace(default, level=6),
            "no predictor": replace(default, predictor=False),
            "1 compression thread": replace(default, threads="1"),
            "blocks of 256": replace(default, blocksize=256),
            "blocks of 1024": replace(default, blocksize=1024),
            "overviews by GDAL (AVERAGE)": "gdal",
            "zstd 1 (not the default)": replace(default, compress="zstd"),
            "no compression": replace(default, compress="none"),
        }
        best: dict[str, tuple[float, float, int]] = {}
        cache = gdal_cache(RectifyOptions())
        for _ in range(args.repeat):
            for name, profile in profiles.items():
                out = work / "final.tif"
                out.unlink(missing_ok=True)
                t0, c0 = time.perf_counter(), cpu_seconds()
                with rasterio.Env(GDAL_CACHEMAX=cache):
                    if profile == "gdal":
                        opts = default.creation_options(dtype, True)
                        opts.update(OVERVIEWS="AUTO", OVERVIEW_RESAMPLING="AVERAGE")
                        rasterio.shutil.copy(str(working), str(out), driver="COG", **opts)
                    else:
                        finalise(working, out, profile, dtype)
                dt, dc = time.perf_counter() - t0, cpu_seconds() - c0
                size = out.stat().st_size
                if name not in best or dt < best[name][0]:
                    best[name] = (dt, dc, size)
        print(f"working file {shape[0]} x {shape[1]} x {shape[2]} {np.dtype(dtype).name} ({raw / 1e6:.0f} MB), "
              f"best of {args.repeat}; cores {os.cpu_count()}, load average {os.getloadavg()[0]:.1f}")
        print(f"{'profile':<46}{'wall s':>8}{'cpu s':>8}{'MB':>8}{'x default cpu':>15}")
        ref = best[next(iter(profiles))][1]
        for name, (dt, dc, size) in best.items():
            print(f"{name:<46}{dt:>8.2f}{dc:>8.2f}{size / 1e6:>8.1f}{dc / ref:>15.2f}")
    finally:
        shutil.rmtree(work, ignore_errors=True)
        if not args.keep:
            shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
