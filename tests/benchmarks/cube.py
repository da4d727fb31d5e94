"""Benchmark: rectify an imaging spectrometer's cube of the real size from an ENVI file (HySpex VNIR-1800:
1800 px x 182 bands x 4,000-13,000 lines of float32, 5-17 GB), beside the rectify benchmark's strip.

Run: python tests/benchmarks/cube.py [--lines 4000] [--pixels 1800] [--bands 182] [--interleave bsq bil]
[--resolution 0.6] [--baseline-lines 10000] [--pipeline 2] [--keep DIR]

Set-up (not timed): a simulated pushbroom project (the ``pushbroom`` preset made a HySpex VNIR-1800:
1800 px over 33.8 deg, 25 lines/s, 700 m above ground at 40 m/s: 0.23 m across, 1.6 m along track; one
strip, no points' images), its cube written as ENVI BSQ and/or BIL (raw float32 and a .hdr) by a
streaming writer (a chunk of lines at a time, through ``scangeo.atomic``), and the rectify benchmark's
strip (``tests/benchmarks/rectify.py``: a Daedalus strip 716 x N x 11 uint16 as a GeoTIFF, 2.5 m).

Then, side by side in this process: each route rectified ``--pipeline`` times in a row through a
``Finaliser`` (as ``scangeo rectify`` does for several strips: the COG of one strip is written while
the next is computed), with the default options but the resolution (the cube's grid at 0.6 m: about
one cell per input pixel). Figures per strip: wall and CPU seconds (every thread), cores busy, input
Mpixel-bands/s (lines x pixels x bands / wall s) and output Mcell-bands/s, peak resident memory of
this process during the route (VmHWM, reset before each route through /proc/self/clear_refs: it
includes the interpreter and libraries), and the ratio of the cube's throughput to the strip's. The
files are removed at the end unless ``--keep``; the cube needs lines x 1800 x 182 x 4 bytes per
interleave (5.2 GB at 4,000 lines) and its output about as much.
"""
from __future__ import annotations

import argparse
import os
import shutil
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

warnings.simplefilter("ignore")
sys.path.insert(0, str(Path(__file__).resolve().parent))

from rectify import cpu_seconds, make_project, peak_rss_mb, reset_peak_rss  # noqa: E402  (the strip benchmark)


def make_cube_project(root: Path, lines: int, pixels: int) -> None:
    """A one-strip pushbroom project of a HySpex-VNIR-1800-like camera, without images."""
    from scangeo.simulate.block import simulate
    from scangeo.simulate.config import load_preset

    over = {
        "sensor": {"pixels": pixels, "fov_deg": 33.8, "along_deg": 0.0376, "smile_deg": 0.0, "across_cubic_deg": 0.0,
                   "across_offset_error_deg": 0.0, "across_scale_error": 0.0, "along_offset_error_deg": 0.0},
        "flight": {"strips": 1, "lines": lines, "height_above_ground_m": 700.0, "ground_speed_mps": 40.0},
        "terrain": {"resolution_m": 2.5, "dtm_resolution_m": 2.5, "margin_m": 300.0},
        "points": {"check_per_strip": 5, "tie_per_overlap": 0, "height_per_strip": 0, "control_per_band_per_strip": 2},
        "output": {"images": False, "truth_ortho": False},
    }
    simulate(root, load_preset("pushbroom", over))


def spatial_pattern(lines: int, pixels: int) -> np.ndarray:
    """The synthetic cube's spatial structure (lines, pixels) float32: smooth hills and a fine texture."""
    li = np.arange(lines, dtype=np.float32)[:, None]
    pi = np.arange(pixels, dtype=np.float32)[None, :]
    return (1000.0 + 400.0 * np.sin(li * 0.013) * np.cos(pi * 0.009) + 150.0 * np.sin(li * 0.31 + pi * 0.17)
            ).astype(np.float32)


def band_of(base: np.ndarray, band: int, bands: int) -> np.ndarray:
    """Band ``band`` of the cube on the lines of ``base``: the pattern times a spectrum, plus an offset."""
    return base * np.float32(0.4 + 0.6 * band / bands) + np.float32(3.0 * band)


def write_envi(path: Path, lines: int, pixels: int, bands: int, interleave: str, chunk: int = 64,
               noise: float = 0.0) -> None:
    """An ENVI cube (raw little-endian float32 + ``.hdr``) written a band (BSQ) or a chunk of lines
    (BIL) at a time: memory is the spatial pattern (lines x pixels) and one such piece, whatever the
    number of bands. ``noise``: a relative Gaussian sensor noise on every value (seeded; 0: none)."""
    from scangeo.atomic import atomic_path, write_text

    base = spatial_pattern(lines, pixels)
    rng = np.random.default_rng(43)

    def noisy(values: np.ndarray) -> np.ndarray:
        if not noise:
            return values
        return (values * (1.0 + noise * rng.standard_normal(values.shape, dtype=np.float32))).astype(np.float32)

    with atomic_path(path) as tmp, open(tmp, "wb") as f:
        if interleave == "bsq":
            for b in range(bands):
                f.write(noisy(band_of(base, b, bands)).tobytes())
        elif interleave == "bil":
            for l0 in range(0, lines, chunk):
                part = base[l0:l0 + chunk]
                block = np.stack([band_of(part, b, bands) for b in range(bands)], axis=1)
                f.write(noisy(block).tobytes())  # (lines, bands, pixels): line-interleaved
        else:
            raise ValueError(interleave)
    names = ",\n ".join(f"band {b + 1}" for b in range(bands))
    write_text(path.with_suffix(".hdr"), "ENVI\n" f"samples = {pixels}\nlines = {lines}\nbands = {bands}\n"
               "header offset = 0\nfile type = ENVI Standard\ndata type = 4\n"
               f"interleave = {interleave}\nbyte order = 0\nband names = {{\n {names}}}\n")


def run_route(name: str, geometry, image: Path, out_dir: Path, options, n: int) -> dict:
    """``n`` strips through one Finaliser; per strip wall, CPU, peak RSS."""
    from scangeo.rectify.strip import Finaliser, rectify_strip

    reset_peak_rss()
    t0, c0 = time.perf_counter(), cpu_seconds()
    with Finaliser() as finaliser:
        results = [rectify_strip(geometry, image, out_dir / f"{name}{i}.tif", options, finaliser=finaliser)
                   for i in range(n)]
    wall, cpu = (time.perf_counter() - t0) / n, (cpu_seconds() - c0) / n
    for r in results:
        r.wait()
    grid = results[0].grid
    return {"wall": wall, "cpu": cpu, "rss": peak_rss_mb(), "cells": grid.width * grid.height,
            "size": (grid.width, grid.height), "out_bytes": (out_dir / f"{name}0.tif").stat().st_size}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lines", type=int, default=4000)
    ap.add_argument("--pixels", type=int, default=1800)
    ap.add_argument("--bands", type=int, default=182)
    ap.add_argument("--interleave", nargs="+", default=["bsq", "bil"], choices=("bsq", "bil"))
    ap.add_argument("--resolution", type=float, default=0.6, help="the cube's output grid, m")
    ap.add_argument("--baseline-lines", type=int, default=10_000, help="lines of the rectify benchmark's strip "
                    "(0: skip it)")
    ap.add_argument("--pipeline", type=int, default=2, help="strips per route through one Finaliser")
    ap.add_argument("--keep", default=None, help="keep (and reuse) the projects and cubes in this folder")
    args = ap.parse_args()

    from scangeo.io.project import Project
    from scangeo.rectify.core_geometry import CoreStripGeometry
    from scangeo.rectify.options import RectifyOptions

    tmp = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="scangeo-bench-cube-"))
    out_dir = tmp / "out"
    out_dir.mkdir(parents=True, exist_ok=True)
    t = time.perf_counter()
    cube_root = tmp / f"cube{args.lines}x{args.pixels}"
    if not (cube_root / "project.toml").exists():
        make_cube_project(cube_root, args.lines, args.pixels)
    cubes = {}
    for il in args.interleave:
        path = cube_root / "images" / f"cube{args.bands}_{il}.{il}"  # each its own .hdr
        path.parent.mkdir(exist_ok=True)
        if not path.exists():
            write_envi(path, args.lines, args.pixels, args.bands, il)
        cubes[il] = path
    strip_root = tmp / f"strip{args.baseline_lines}"
    if args.baseline_lines and not (strip_root / "project.toml").exists():
        make_project(strip_root, args.baseline_lines)
    print(f"set-up in {time.perf_counter() - t:.1f} s ({tmp}); OPENBLAS_CORETYPE={os.environ.get('OPENBLAS_CORETYPE')}")

    routes = []
    if args.baseline_lines:
        project = Project.load(strip_root)
        g = CoreStripGeometry(project.geometry("01"), project.dtm)
        routes.append(("strip", f"Daedalus strip 716 x {args.baseline_lines} x 11 uint16 GeoTIFF, 2.5 m", g,
                       strip_root / "images" / "01.tif", RectifyOptions(resolution=2.5), 716 * args.baseline_lines * 11,
                       11))
    project = Project.load(cube_root)
    g = CoreStripGeometry(project.geometry("01"), project.dtm)
    for il, path in cubes.items():
        routes.append((il, f"cube {args.pixels} x {args.lines} x {args.bands} float32 ENVI {il.upper()}, "
                       f"{args.resolution:g} m", g, path, RectifyOptions(resolution=args.resolution),
                       args.pixels * args.lines * args.bands, args.bands))
    # warm-up: numba kernels compiled or loaded, GDAL drivers (not timed)
    from scangeo.rectify.strip import rectify_strip
    from scangeo.rectify.strip_run import strip_grid

    for _, _, g, image, options, _, _ in routes[-1:]:
        xmin, ymin, xmax, ymax = strip_grid(g, options).bounds
        rectify_strip(g, image, out_dir / "warm-up.tif", options.replace(bounds=(xmin, ymax - 30.0, xmax, ymax)))
    results = {}
    for name, label, g, image, options, pixel_bands, bands in routes:
        r = run_route(name, g, image, out_dir, options, args.pipeline)
        r.update(label=label, pixel_bands=pixel_bands, bands=bands)
        results[name] = r
        for f in out_dir.glob(f"{name}*.tif"):
            f.unlink()
    print(f"\nload average {os.getloadavg()[0]:.1f} (after); {args.pipeline} strips per route through a Finaliser, "
          "figures per strip")
    print(f"{'route':<58}{'wall s':>8}{'cpu s':>8}{'cores':>7}{'in Mpx-bands/s':>16}{'out Mcell-bands/s':>19}"
          f"{'peak RSS MB':>13}")
    for r in results.values():
        print(f"{r['label']:<58}{r['wall']:>8.1f}{r['cpu']:>8.1f}{r['cpu'] / r['wall']:>7.2f}"
              f"{r['pixel_bands'] / r['wall'] / 1e6:>16.1f}{r['cells'] * r['bands'] / r['wall'] / 1e6:>19.1f}"
              f"{r['rss']:>13.0f}")
    for name, r in results.items():
        print(f"{name}: grid {r['size'][0]} x {r['size'][1]} cells, output {r['out_bytes'] / 2**20:.0f} MiB")
    if "strip" in results:
        base = results["strip"]
        b_in, b_out = base["pixel_bands"] / base["wall"], base["cells"] * base["bands"] / base["wall"]
        for name, r in results.items():
            if name != "strip":
                r_in, r_out = r["pixel_bands"] / r["wall"], r["cells"] * r["bands"] / r["wall"]
                cpu_ratio = (base["cpu"] / base["pixel_bands"]) / (r["cpu"] / r["pixel_bands"])
                print(f"ratio {name} / strip: input px-bands/s {r_in / b_in:.2f}x, output cell-bands/s "
                      f"{r_out / b_out:.2f}x, CPU seconds per input px-band {cpu_ratio:.2f}x less")
    if not args.keep:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
