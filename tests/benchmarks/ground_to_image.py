"""Benchmark: ground -> image and image -> ground throughput.

Run: python tests/benchmarks/ground_to_image.py [--points 10000000] [--lines 10000] [--repeat 2]
[--no-image-to-ground]

* ground -> image: N ground points against one 10,000-line Daedalus strip (716 px), tolerance
  1e-4 line, compiled kernel (numba, all cores) side by side with two baselines in the same process:
  the previous scangeo kernel (bracketed Newton on time, frozen at commit 3a331b5 by
  ``previous_ground_to_image.py``), alternated with the current one ``--repeat`` times on the same
  points, and "numpy + scipy CubicSpline, vectorised Newton on time" on a 1M-point subset.
* image -> ground: every pixel of a 716 x 10,000 strip over the real SRTM DTM (../shared/data).
"""
from __future__ import annotations

import argparse
import os
import resource
import sys
import time
from pathlib import Path

import numpy as np
from previous_ground_to_image import previous_ground_to_image, previous_kernels
from scipy.interpolate import CubicSpline

from scangeo.dtm import DTM
from scangeo.frames import MapFrame, ProjectFrame
from scangeo.rotation import R_ENU_NED, rph_to_matrix
from scangeo.sensors import StripGeometry, Whiskbroom
from scangeo.timing import LineTiming
from scangeo.trajectory import OrientationSpline

SHARED = Path(__file__).resolve().parents[3] / "shared" / "data"


def turbulent_strip(n_lines: int, z: float = 2300.0) -> StripGeometry:
    """A north-bound 67 m/s line with roll/pitch/heading turbulence (sums of sinusoids)."""
    rng = np.random.default_rng(1)
    duration = n_lines / 25.0 + 4.0
    t = np.arange(0.0, duration, 0.02)
    def turb(amp_deg, periods):
        return sum(
            np.radians(amp_deg) * rng.uniform(0.3, 1) * np.sin(2 * np.pi * t / p + rng.uniform(0, 6)) for p in periods
        )

    values = np.column_stack(
        [
            5 * np.sin(t / 30),
            -duration * 67 / 2 + 67 * t,
            z + 3 * np.sin(t / 7),
            turb(1.5, (3.1, 7.3, 17.0)),
            turb(0.6, (4.3, 11.0)),
            np.radians(0.5) + turb(0.4, (9.0, 23.0)),
        ]
    )
    spline = OrientationSpline.fit(t, values, 0.2)
    return StripGeometry(Whiskbroom(), spline, LineTiming(2.0, 25.0), n_lines)


def numpy_ground_to_image(strip: StripGeometry, P: np.ndarray, tol_line: float = 1e-4):
    """Baseline: vectorised Newton on time with scipy CubicSpline (no bracketing, no over-scan)."""
    times = np.arange(strip.spline.t0, strip.spline.t_end, 0.04)
    cs = CubicSpline(times, strip.spline.evaluate(times))
    dcs = cs.derivative()
    # start: the time at which the aircraft passes the point's along-track coordinate
    y_track = cs(times)[:, 1]
    t = np.interp(P[:, 1], y_track, times)
    for _ in range(8):
        v, w = cs(t), dcs(t)
        R, dR = _rot_and_dot(v, w)
        d = P - v[:, :3]
        f = np.einsum("ni,ni->n", R[:, :, 0], d)
        df = np.einsum("ni,ni->n", dR[:, :, 0], d) - np.einsum("ni,ni->n", R[:, :, 0], w[:, :3])
        step = f / df
        t = t - step
        if np.abs(step).max() * 25.0 < tol_line:
            break
    v = cs(t)
    R, _ = _rot_and_dot(v, dcs(t))
    vS = np.einsum("nji,nj->ni", R, P - v[:, :3])
    pixel = strip.sensor.pixel_of(vS)
    line = strip.timing.line_of_time(t - strip.sensor.time_offset(pixel))
    return line, pixel


def _rot_and_dot(v, w, eps=1e-6):
    R = R_ENU_NED @ rph_to_matrix(v[:, 3], v[:, 4], v[:, 5])
    R2 = R_ENU_NED @ rph_to_matrix(v[:, 3] + eps * w[:, 3], v[:, 4] + eps * w[:, 4], v[:, 5] + eps * w[:, 5])
    return R, (R2 - R) / eps


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--points", type=int, default=10_000_000)
    ap.add_argument("--lines", type=int, default=10_000)
    ap.add_argument("--repeat", type=int, default=2, help="alternations of current and previous kernel")
    ap.add_argument("--no-image-to-ground", action="store_true")
    args = ap.parse_args()
    import numba

    from scangeo.threading_layer import choose_threading_layer

    choose_threading_layer()  # before get_num_threads below starts numba's threading layer
    print(f"cores: {os.cpu_count()}, numba threads: {numba.get_num_threads()}, threading layer "
          f"{numba.config.THREADING_LAYER}, OPENBLAS_CORETYPE={os.environ.get('OPENBLAS_CORETYPE', '-')}, "
          f"load average {os.getloadavg()[0]:.1f}")
    strip = turbulent_strip(args.lines)
    rng = np.random.default_rng(0)
    # ground points inside the footprint: random (line, pixel), at random heights along the ray
    lines = rng.uniform(0, args.lines - 1, args.points)
    pixels = rng.uniform(0, 715, args.points)
    o, d = strip.rays(lines, pixels)
    lam = (o[:, 2] - rng.uniform(0, 300, args.points)) / -d[:, 2]
    P = o + lam[:, None] * d
    del o, d, lam
    order = np.argsort(lines)  # a rectification grid arrives roughly in along-track order
    P_sorted = np.ascontiguousarray(P[order])
    previous = previous_kernels()
    routes = {"scangeo": lambda pts: strip.ground_to_image(pts, tol_line=1e-4)}
    if previous is None:
        print("previous kernel: git history not available, baseline skipped")
    else:
        routes["previous kernel"] = lambda pts: previous_ground_to_image(previous, strip, pts, tol_line=1e-4)
    for route in routes.values():
        route(P_sorted[:1000])  # compile / load the cache
    best: dict[tuple[str, str], float] = {}
    for label, pts, ref in (("along-track order", P_sorted, lines[order]), ("random order", P, lines)):
        for rep in range(args.repeat):
            for name, route in routes.items():
                t0 = time.perf_counter()
                line, pixel, status = route(pts)
                dt = time.perf_counter() - t0
                err = np.nanmax(np.abs(line - ref))
                rate = len(pts) / dt
                best[name, label] = max(best.get((name, label), 0.0), rate)
                print(f"{name} ground->image, {label} (run {rep + 1}, load {os.getloadavg()[0]:.1f}): "
                      f"{rate / 1e6:.2f} M points/s ({dt:.2f} s for {len(pts) / 1e6:.1f} M; "
                      f"max |line error| {err:.1e}; status ok {np.mean(status == 0) * 100:.2f} %)", flush=True)
        if "previous kernel" in routes:
            print(f"ratio scangeo / previous kernel, {label}, best runs: "
                  f"{best['scangeo', label] / best['previous kernel', label]:.2f}x")
    exact = strip._whiskbroom_ground_to_image(P_sorted, strip.sensor.kernel_params()[1], 1e-4)[3]
    print(f"points solved exactly (interpolation bound above the tolerance): {int(exact.sum())} of {len(exact)}")
    rate_ours = best["scangeo", "along-track order"]
    n_base = min(1_000_000, args.points)
    t0 = time.perf_counter()
    bl, bp = numpy_ground_to_image(strip, P[:n_base])
    dt = time.perf_counter() - t0
    rate_base = n_base / dt
    print(f"baseline numpy + scipy CubicSpline ({n_base / 1e6:.0f} M points): {rate_base / 1e6:.2f} M points/s; "
          f"max |line difference| to scangeo {np.nanmax(np.abs(bl - lines[:n_base])):.1e}")
    print(f"ratio scangeo / numpy baseline: {rate_ours / rate_base:.1f}x")
    if args.no_image_to_ground:
        print(f"peak memory (max RSS): {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MB")
        return

    hgt = SHARED / "dtm" / "N44E005.hgt"
    if not hgt.exists():
        print("image->ground: ../shared/data/dtm/N44E005.hgt not found, skipped")
        return
    probe = MapFrame("EPSG:32631", ProjectFrame(0, 0, 0))
    x, y = probe.geodetic_to_map_2d(np.radians([44.174]), np.radians([5.278]))
    mf = MapFrame.centred_on("EPSG:32631", float(x[0]), float(y[0]), 0.0)
    dtm = DTM.open(hgt, mf)
    strip = turbulent_strip(args.lines, z=4000.0)  # 1,250-4,000 m above the terrain
    L = np.repeat(np.arange(args.lines, dtype=float), 716)
    J = np.tile(np.arange(716, dtype=float), args.lines)
    strip.image_to_ground(L[:716], J[:716], dtm)
    t0 = time.perf_counter()
    g, status = strip.image_to_ground(L, J, dtm)
    dt = time.perf_counter() - t0
    print(
        f"scangeo image->ground, every pixel of 716 x {args.lines} over SRTM (heights {dtm.h_min:.0f}-"
        f"{dtm.h_max:.0f} m, 4000 m flight): {dt:.2f} s ({len(L) / dt / 1e6:.2f} M rays/s), "
        f"ok {np.mean(status == 0) * 100:.2f} %"
    )
    print(f"peak memory (max RSS): {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MB")


if __name__ == "__main__":
    sys.exit(main())
