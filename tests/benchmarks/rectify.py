"""Benchmark: rectify one Daedalus strip, scangeo against the GDAL geolocation route.

Run: python tests/benchmarks/rectify.py [--lines 10000] [--resampling bilinear] [--keep DIR] [--pipeline [N]]
[--compress deflate|zstd] [--repeat R] [--gdal-writer]

Set-up (not timed): a simulated project (preset ``small``, one strip of N lines x 716 pixels, its
turbulence, true terrain and DTM at 2.5 m) and an 11-band uint16 image of that size.
Then, side by side in this process, onto the same 2.5 m grid (the strip's footprint):

* scangeo: ``rectify_strip`` (inverse map, z-buffer occlusion, cv2.remap of 11 bands in tiles,
  COG writing), wall time from start to the final file (the refined inverse map; the lattice
  method before it was removed: docs/performance.md keeps its figures);
* GDAL: rasterio ``reproject`` with geolocation arrays (GDAL's geolocation transformer, bilinear, 2
  threads) into memory, same grid; the geolocation arrays (image -> ground of every pixel corner on
  the DTM) are computed before and timed separately: they are the IGM the route needs as input.

With ``--pipeline [N]`` also: the same strip rectified N times in a row (default 2) through a
``Finaliser`` (the COG of one strip compressed and written while the next is computed, as ``scangeo
rectify`` does for several strips), wall and CPU time per strip, beside the single strip's. The last
strip's COG overlaps nothing, so the time per strip of a block (the steady state) is approached as N
grows: with 2 strips a third of the work is not overlapped.

Figures: wall time, CPU time of every thread of the process and their ratio (cores busy), output
megapixel-bands per second (grid cells x bands / time), peak memory
(resident set high-water mark of this process, reset before each route through
/proc/self/clear_refs; it includes the interpreter and libraries, and for the GDAL route the whole
image and geolocation arrays it needs in memory), the inverse map's exact solutions, and the
geometric difference of the two outputs (least-squares shift over the whole strip
and in 128-cell windows). ``--gdal-writer`` also times the pipelined strips with GDAL's COG
driver writing (``[rectify.geotiff] writer = "gdal"``), beside scangeo's own COG writer. With
``--repeat R`` the routes run R times in turn (scangeo, pipelined,
IGM, GDAL, scangeo, ...) and each route's run with the fewest CPU seconds is reported: on a shared
machine the others' load moves CPU seconds by 20-40 % between minutes, and alternating gives every
route the same chances. No tracemalloc: it slows numpy's allocations several-fold.
"""
from __future__ import annotations

import argparse
import os
import shutil
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
import rasterio

warnings.simplefilter("ignore")


def cpu_seconds() -> float:
    """CPU seconds of every thread of this process so far."""
    import resource

    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def reset_peak_rss() -> None:
    try:
        Path("/proc/self/clear_refs").write_text("5")
    except OSError:
        pass


def peak_rss_mb() -> float:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024.0
    return float("nan")


def make_project(root: Path, lines: int) -> None:
    from scangeo.simulate.block import simulate
    from scangeo.simulate.config import load_preset

    over = {
        "flight": {"strips": 1, "lines": lines},
        "terrain": {"resolution_m": 2.5, "dtm_resolution_m": 2.5},
        "output": {"images": False, "truth_ortho": False},
    }
    simulate(root, load_preset("small", over))
    (root / "images").mkdir(exist_ok=True)
    rng = np.random.default_rng(3)
    base = rng.integers(200, 4000, size=(lines // 4 + 1, 716 // 4 + 1)).astype(np.float32)
    import cv2

    smooth = cv2.resize(base, (716, lines), interpolation=cv2.INTER_CUBIC)
    with rasterio.open(root / "images" / "01.tif", "w", driver="GTiff", width=716, height=lines, count=11,
                       dtype="uint16", tiled=True, blockxsize=256, blockysize=256) as dst:
        for b in range(11):
            noise = rng.normal(0, 30, size=smooth.shape).astype(np.float32)
            dst.write(np.clip(smooth * (0.6 + 0.05 * b) + noise, 0, 65535).astype(np.uint16), b + 1)


def lk_shift(a: np.ndarray, b: np.ndarray, valid: np.ndarray):
    gy, gx = np.gradient(b)
    r = a - b

    def solve(m):
        G = np.stack([gx[m], gy[m]], 1)
        return np.linalg.solve(G.T @ G, G.T @ r[m])

    per = []
    for r0 in range(0, a.shape[0] - 128 + 1, 128):
        for c0 in range(0, a.shape[1] - 128 + 1, 128):
            m = np.zeros_like(valid)
            m[r0:r0 + 128, c0:c0 + 128] = True
            m &= valid
            if m.sum() > 0.9 * 128 * 128:
                per.append(solve(m))
    return solve(valid), np.array(per)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lines", type=int, default=10_000)
    ap.add_argument("--resampling", default="bilinear", choices=("nearest", "bilinear", "cubic"))
    ap.add_argument("--keep", default=None, help="keep the project in this folder")
    ap.add_argument("--pipeline", type=int, nargs="?", const=2, default=0,
                    help="also time N strips pipelined (default 2)")
    ap.add_argument("--repeat", type=int, default=1,
                    help="run the routes this many times, alternating, and keep each one's smallest CPU seconds "
                         "(with that run's wall time): on a shared machine the load moves between routes")
    ap.add_argument("--gdal-writer", action="store_true",
                    help="also time the pipelined strips with [rectify.geotiff] writer = \"gdal\" (GDAL's COG driver "
                         "compressing, the route before scangeo's own COG writer)")
    ap.add_argument("--compress", default="deflate", choices=("deflate", "zstd", "lzw", "none"),
                    help="compression of the orthoimage (default: deflate, the default of [rectify.geotiff])")
    args = ap.parse_args()

    from scangeo.io.project import Project
    from scangeo.rectify.core_geometry import CoreStripGeometry
    from scangeo.rectify.gdal_route import corner_geolocation, warp_with_geolocation
    from scangeo.rectify.options import RectifyOptions
    from scangeo.rectify.strip import rectify_strip

    tmp = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="scangeo-bench-rectify-"))
    root = tmp / "project"
    t = time.perf_counter()
    if not (root / "project.toml").exists():
        make_project(root, args.lines)
    print(f"set-up: simulated project and 11-band image in {time.perf_counter() - t:.1f} s ({root})")
    project = Project.load(root)
    image_path = root / "images" / "01.tif"
    geometry = CoreStripGeometry(project.geometry("01"), project.dtm)
    from scangeo.rectify.geotiff import GeoTiffProfile

    options = RectifyOptions(resolution=2.5, resampling=args.resampling, geotiff=GeoTiffProfile(compress=args.compress))
    # warm-up (numba compilation or cache loading of the kernels, GDAL drivers), not timed: the
    # first 200 m of the strip's grid
    from scangeo.rectify.strip_run import strip_grid

    full = strip_grid(geometry, options)
    xmin, ymin, xmax, ymax = full.bounds
    rectify_strip(geometry, image_path, tmp / "warm-up.tif", options.replace(bounds=(xmin, ymax - 200.0, xmax, ymax)))
    geometry.image_to_ground(np.array([0.0]), np.array([0.0]))

    out = tmp / "ortho.tif"
    best: dict[str, tuple[float, float]] = {}

    def keep(name: str, t: float, c: float) -> None:
        """The smallest CPU seconds of a route over the repetitions, with that run's wall time."""
        if name not in best or c < best[name][1]:
            best[name] = (t, c)

    rss_ours = rss_gdal = 0.0
    gdal = None
    for _ in range(args.repeat):
        gdal = None  # the previous repetition's warp out of the memory figures
        reset_peak_rss()
        t0, c0 = time.perf_counter(), cpu_seconds()
        result = rectify_strip(geometry, image_path, out, options)
        keep("ours", time.perf_counter() - t0, cpu_seconds() - c0)
        rss_ours = max(rss_ours, peak_rss_mb())
        if args.pipeline:
            from scangeo.rectify.strip import Finaliser

            t0, c0 = time.perf_counter(), cpu_seconds()
            with Finaliser() as finaliser:
                for i in range(args.pipeline):
                    rectify_strip(geometry, image_path, tmp / f"pipelined{i}.tif", options, finaliser=finaliser)
            keep("pipe", (time.perf_counter() - t0) / args.pipeline, (cpu_seconds() - c0) / args.pipeline)
            if args.gdal_writer:
                by_gdal = options.replace(geotiff=GeoTiffProfile(compress=args.compress, writer="gdal"))
                t0, c0 = time.perf_counter(), cpu_seconds()
                with Finaliser() as finaliser:
                    for i in range(args.pipeline):
                        rectify_strip(geometry, image_path, tmp / f"pipelined-gdal{i}.tif", by_gdal,
                                      finaliser=finaliser)
                keep("pipe-gdal", (time.perf_counter() - t0) / args.pipeline, (cpu_seconds() - c0) / args.pipeline)
        grid = result.grid
        t0, c0 = time.perf_counter(), cpu_seconds()
        x, y = corner_geolocation(geometry)
        keep("igm", time.perf_counter() - t0, cpu_seconds() - c0)
        with rasterio.open(image_path) as src:
            image = src.read()
        reset_peak_rss()
        t0, c0 = time.perf_counter(), cpu_seconds()
        gdal = warp_with_geolocation(image, x, y, grid, args.resampling, nodata=0, threads=2)
        keep("gdal", time.perf_counter() - t0, cpu_seconds() - c0)
        rss_gdal = max(rss_gdal, peak_rss_mb())
        del x, y, image
    (t_ours, c_ours), (t_igm, c_igm), (t_gdal, c_gdal) = best["ours"], best["igm"], best["gdal"]
    t_pipe, c_pipe = best.get("pipe", (None, None))
    mpx = grid.width * grid.height * 11 / 1e6

    with rasterio.open(out) as d:
        ours = d.read(1).astype(float)
    g = gdal[0].astype(float)
    valid = (ours != 0) & (g != 0)
    mean, per = lk_shift(g, ours, valid)
    s = result.stats
    print(f"\nstrip 716 x {args.lines} x 11 uint16 -> grid {grid.width} x {grid.height} at 2.5 m "
          f"({mpx:.1f} Mpx-bands), {args.resampling}, {args.compress}, overviews {options.geotiff.overviews}; "
          f"load average {os.getloadavg()[0]:.1f}; best of {args.repeat} (smallest CPU seconds per route)")
    print(f"{'route':<44}{'wall s':>9}{'cpu s':>8}{'cores':>7}{'Mpx-bands/s':>13}{'peak RSS MB':>13}")
    print(f"{'scangeo rectify_strip (to the final COG)':<44}{t_ours:>9.2f}{c_ours:>8.2f}{c_ours / t_ours:>7.2f}"
          f"{mpx / t_ours:>13.1f}{rss_ours:>13.0f}")
    if t_pipe is not None:
        label = f"scangeo, {args.pipeline} strips pipelined, per strip"
        print(f"{label:<44}{t_pipe:>9.2f}{c_pipe:>8.2f}{c_pipe / t_pipe:>7.2f}{mpx / t_pipe:>13.1f}")
        if "pipe-gdal" in best:
            t_pg, c_pg = best["pipe-gdal"]
            label = "  same, GDAL's COG driver writing"
            print(f"{label:<44}{t_pg:>9.2f}{c_pg:>8.2f}{c_pg / t_pg:>7.2f}{mpx / t_pg:>13.1f}")
    print(f"{'GDAL geolocation warp (in memory)':<44}{t_gdal:>9.2f}{c_gdal:>8.2f}{c_gdal / t_gdal:>7.2f}"
          f"{mpx / t_gdal:>13.1f}{rss_gdal:>13.0f}")
    print(f"{'  + its input: IGM of the pixel corners':<44}{t_igm:>9.2f}{c_igm:>8.2f}{c_igm / t_igm:>7.2f}")
    print(f"ratio scangeo / GDAL throughput: {t_gdal / t_ours:.1f}x (with the IGM: {(t_gdal + t_igm) / t_ours:.1f}x)")
    if t_pipe is not None:
        print(f"ratio pipelined scangeo / GDAL throughput: {t_gdal / t_pipe:.1f}x (with the IGM: "
              f"{(t_gdal + t_igm) / t_pipe:.1f}x)")
        # CPU seconds do not depend on what else runs on the machine: the figure to compare under load
        print(f"ratio in CPU seconds, pipelined scangeo / GDAL: {c_gdal / c_pipe:.1f}x (with the IGM: "
              f"{(c_gdal + c_igm) / c_pipe:.1f}x)")
    print(f"scangeo inverse map (refine): {s.exact_points / 1e6:.2f} M bracketed solutions for "
          f"{grid.width * grid.height / 1e6:.2f} M cells ({s.exact_cells} cells by the fallback), "
          f"{s.newton_evaluations / max(s.refined_cells, 1):.2f} Newton evaluations per refined cell, validated max "
          f"error {s.max_error_px:.1e} px; {result.valid_cells} valid, {result.hidden_cells} hidden cells; tile "
          f"{result.tile_size}")
    print(f"GDAL minus scangeo (band 1): mean shift {mean.round(4)} px (x, y), 128-cell windows rms "
          f"{np.sqrt((per ** 2).mean(0)).round(4)} px, max |shift| {np.abs(per).max():.3f} px over {len(per)} windows")
    if not args.keep:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
