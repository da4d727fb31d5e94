"""Benchmark: scangeo lidar adjust on a simulated block of laser strips, against its targets.

Default: 9 parallel strips + 1 cross strip of ~2 million returns each (100 kHz, 1200 m at 60 m/s).
First the patch search of one strip in this process, its returns read once into memory and fed in
chunks of 1 M (LAS reading apart): the row buffer (pass 1) and the seeded pass 2, in returns per
CPU second, beside the grid cells of the earlier search (the named baseline) on the same returns (target:
>= 2 M returns/s/core). Then patch finding over all strips with ``--workers`` processes, and one
strip alone in this process (the serial baseline: ratio = strips x one-strip time / parallel time), the adjustment
(set-up of groups and priors, Gauss-Newton, data snooping, statistics), and the peak memory
(max RSS of this process and of the worker processes).

Run:  python tests/benchmarks/lidar_adjust.py [--strips 9] [--pulse-rate 100000] [--workers 2] [--dir DIR]
      [--search-only]
The simulated block is kept in DIR (default /tmp/scangeo-lidar-bench-...) and reused.
"""

from __future__ import annotations

import argparse
import json
import resource
import time
from pathlib import Path

import numpy as np

from scangeo.adjustment.variants import laser_variant
from scangeo.io.project import Project
from scangeo.lidar.adjust import LaserOptions, build, run
from scangeo.lidar.control import read_patch_ground
from scangeo.lidar.lasio import StripCloud, iter_returns
from scangeo.lidar.patches import find_strip_patches
from scangeo.lidar.rowbuffer import search_strip
from scangeo.lidar.search import _pass1, find_all
from scangeo.lidar.seeded import Seeds, fit_seeds
from scangeo.simulate.laser import LaserBlockConfig, simulate_laser


def main() -> None:
    import logging

    logging.getLogger("scangeo.lsq.solver").setLevel(logging.ERROR)
    ap = argparse.ArgumentParser()
    ap.add_argument("--strips", type=int, default=9, help="parallel strips (plus one cross strip)")
    ap.add_argument("--pulse-rate", type=float, default=100000.0)
    ap.add_argument("--length", type=float, default=1200.0)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--dir", type=Path, default=None)
    ap.add_argument("--search-only", action="store_true", help="only the patch search of one strip")
    a = ap.parse_args()
    cfg = LaserBlockConfig(
        strips=a.strips,
        strip_length=a.length,
        pulse_rate_hz=a.pulse_rate,
        strip_spacing=220.0,
        control_patches=12,
        check_patches=8,
    )
    root = a.dir or Path(f"/tmp/scangeo-lidar-bench-{a.strips}-{int(a.pulse_rate)}-{int(a.length)}")
    if not (root / "project.toml").exists():
        t = time.perf_counter()
        summary = simulate_laser(root, cfg)
        print(f"simulated {len(summary['truth']['strips'])} strips in {time.perf_counter() - t:.1f} s")
    truth = json.loads((root / "truth.json").read_text())["truth"]
    returns = sum(s["returns"] for s in truth["strips"].values())
    print(
        f"block: {len(truth['strips'])} strips, {returns / 1e6:.2f} M returns "
        f"({returns / len(truth['strips']) / 1e6:.2f} M per strip)"
    )
    project = Project.load(root)
    options = LaserOptions(workers=a.workers)
    popt, prior = options.patches, project.laser.range_sigma_m
    search_throughput(project, popt, prior)
    if a.search_only:
        return
    given = read_patch_ground(root / "ground.csv")
    t, c = time.perf_counter(), time.process_time()
    _pass1((project.strips[0], project.crs, popt, prior, given, options.patch_search))
    one, one_cpu = time.perf_counter() - t, time.process_time() - c
    t, kids = time.perf_counter(), resource.getrusage(resource.RUSAGE_CHILDREN)
    found = find_all(project, popt, prior, given, a.workers, method=options.patch_search)
    par = time.perf_counter() - t
    k2 = resource.getrusage(resource.RUSAGE_CHILDREN)
    par_cpu = (k2.ru_utime + k2.ru_stime) - (kids.ru_utime + kids.ru_stime)
    n = len(project.strips)
    print(f"patch finding CPU time: one strip {one_cpu:.1f} s; all strips (workers) {par_cpu:.1f} s "
          f"(wall time on a quiet machine with {a.workers} cores ~ {par_cpu / a.workers:.1f} s)")
    print(
        f"patch finding: one strip {one:.1f} s in this process; all {n} strips with {a.workers} workers {par:.1f} s "
        f"(serial estimate {n * one:.1f} s, ratio {n * one / par:.2f}); target < 60 s"
    )
    t, c = time.perf_counter(), time.process_time()
    block = build(project, options, laser_variant(), root / "ground.csv", found=found)
    setup = time.perf_counter() - t
    t = time.perf_counter()
    result = run(block)
    adj = time.perf_counter() - t
    print(f"adjustment CPU time (set-up + solution): {time.process_time() - c:.1f} s")
    acc = result.statistics.accounting
    print(
        f"adjustment: set-up {setup:.1f} s, solve + snooping + statistics {adj:.1f} s (total {setup + adj:.1f} s; "
        f"target < 30 s); {acc.observations} observations, {acc.unknowns} unknowns, "
        f"{len(result.rejections)} rejected, {result.full_solutions} full solutions, "
        f"sigma0 {result.statistics.sigma0:.3f}"
    )
    own = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024**2
    kids = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024**2
    print(f"peak memory: this process {own:.2f} GB, largest worker {kids:.2f} GB; target < 4 GB")


def search_throughput(project, popt, prior, chunk: int = 1_000_000) -> None:
    """Row buffer, seeded pass and grid cells on one strip's returns in memory: returns per CPU second."""
    strip = project.strips[0]
    t = time.process_time()
    parts = list(iter_returns(strip.las, strip.point_source_id, project.crs, chunk))
    read = time.process_time() - t
    n = sum(p[1].size for p in parts)
    print(f"one strip: {n / 1e6:.2f} M returns; LAS reading {n / read / 1e6:.2f} M returns/s (CPU)")
    search_strip(strip.id, iter(parts[:1]), popt, prior)  # numba's kernels loaded before timing
    t = time.process_time()
    found = search_strip(strip.id, iter(parts), popt, prior)
    pass1 = time.process_time() - t
    seeds = Seeds.of({strip.id: found})
    t = time.process_time()
    fits = fit_seeds(strip.id, iter(parts), seeds, seeds.inside(found.bounds), popt, prior, found.speed)
    pass2 = time.process_time() - t
    cloud = StripCloud(strip.id, np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts]))
    t = time.process_time()
    cells = find_strip_patches(cloud, popt, prior)
    grid = time.process_time() - t
    print(f"row buffer (pass 1): {n / pass1 / 1e6:.2f} M returns/s/core, {found.size} candidates "
          f"in {found.lines} lines")
    print(f"seeded pass 2 (own candidates as seeds): {n / pass2 / 1e6:.2f} M returns/s/core, {fits.seed.size} fitted")
    print(f"both passes: {n / (pass1 + pass2) / 1e6:.2f} M returns/s/core (target >= 2)")
    print(f"baseline, grid cells (the earlier patch search): {n / grid / 1e6:.2f} M returns/s/core, "
          f"{cells.cells.size} planar cells; "
          f"ratio rows (both passes) / grid {grid / (pass1 + pass2):.2f}")


if __name__ == "__main__":
    main()
