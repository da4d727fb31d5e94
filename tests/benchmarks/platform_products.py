"""Benchmark: what a platform's products cost: the co-registration layer, the flight line's VRT, and the coarser
sensor rectified on the finest sensor's grid.

Run: python tests/benchmarks/platform_products.py [--preset pushbroom_pair_quick] [--strip swir-02] [--repeat 3]

Set-up (not timed): the preset simulated without its rendered images' truth orthoimage, adjusted with SE and
both boresights calibrated (``coregistration.json`` written), each strip rectified once (numba's kernels
loaded). Then, side by side in this process, best of ``--repeat`` (wall and CPU seconds of every thread of
this process: the COG writer's threads count):

1. the strip (``--strip``, the coarser sensor's) on the platform's grid (the finest sensor's nadir pixel)
   without its co-registration layer (the baseline) and with it (``rectify_strip(..., coregistration=...)``);
2. the same strip on its own sensor's nadir pixel (what a one-sensor run would choose): the cost of the
   platform's one grid, with the cells of each;
3. writing the flight line's VRT (``write_stack_vrt``) and reading it whole.
"""
from __future__ import annotations

import argparse
import os
import shutil
import tempfile
import time
import warnings
from pathlib import Path

import rasterio

from scangeo.io.project import Project
from scangeo.orientation.file import load_orientation
from scangeo.rectify.batch import rectify_project
from scangeo.rectify.core_geometry import CoreStripGeometry
from scangeo.rectify.coregistration_layer import CoregistrationGrid, read_coregistration
from scangeo.rectify.geometry import nadir_ground_pixel
from scangeo.rectify.options import RectifyOptions
from scangeo.rectify.output_grid import nice_resolution
from scangeo.rectify.platform_products import COREGISTRATION_FILE, finest_resolution
from scangeo.rectify.stack_vrt import StackMember, write_stack_vrt
from scangeo.rectify.strip import rectify_strip
from scangeo.workflow import adjust, simulate_project

warnings.simplefilter("ignore")
VARIANTS = '[variants.SE_B]\nstrategy = "SE"\nattitude_degree = -1\ncalibrate = ["boresight"]\n'


def timed(job, repeat: int) -> tuple[float, float]:
    """Best wall and CPU seconds of ``job()`` over ``repeat`` runs."""
    best = (float("inf"), float("inf"))
    for _ in range(repeat):
        w, c = time.perf_counter(), time.process_time()
        job()
        best = min(best, (time.perf_counter() - w, time.process_time() - c))
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--preset", default="pushbroom_pair_quick")
    parser.add_argument("--strip", default="swir-02")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    work = Path(tempfile.mkdtemp(prefix="platform-products-"))
    try:
        root = work / "p"
        simulate_project(root, args.preset)
        (root / "variants.toml").write_text(VARIANTS)
        adjust(root, "SE_B")
        warm = rectify_project(root, "SE_B")  # the kernels compiled and loaded; the orthoimages for the VRT
        project = Project.load(root)
        source = load_orientation(project, "SE_B")
        sid = args.strip
        geometry = CoreStripGeometry(source.geometry(sid), project.dtm)
        entry = read_coregistration(root / "results" / "SE_B" / COREGISTRATION_FILE)[sid]
        grid = CoregistrationGrid.from_entry(entry, geometry.lines, geometry.pixels, sid)
        image = project.strip(sid).image
        fine, sensor = finest_resolution(project, source)
        own = nice_resolution(nadir_ground_pixel(geometry))
        out = work / "o"
        out.mkdir()
        print(f"load average {os.getloadavg()[0]:.1f}; {args.preset}, strip {sid} ({geometry.lines} lines x "
              f"{geometry.pixels} pixels); platform grid {fine:g} m ({sensor}), the strip's own nadir pixel {own:g} m; "
              f"best of {args.repeat}")
        rows = []
        for name, res, co in (("platform grid, no layer (baseline)", fine, None),
                              ("platform grid, co-registration layer", fine, grid),
                              ("own nadir pixel, no layer", own, None)):
            cells = []

            def job(res=res, co=co, cells=cells):
                r = rectify_strip(geometry, image, out / f"{sid}.tif", RectifyOptions(resolution=res),
                                  coregistration=co)
                cells.append(r.grid.width * r.grid.height)
            rows.append((name, *timed(job, args.repeat), cells[-1]))
        base = rows[0]
        print(f"{'':38s} {'wall s':>8s} {'CPU s':>8s} {'cells':>10s} {'CPU / baseline':>15s}")
        for name, wall, cpu, cells in rows:
            print(f"{name:38s} {wall:8.2f} {cpu:8.2f} {cells:10d} {cpu / base[2]:15.2f}")
        line = project.strip(sid).flight_line
        members = [StackMember(warm.folder / f"{s}.tif", project.strip(s).sensor, s)
                   for s in project.flight_lines[line].strips]

        def stack():
            path = write_stack_vrt(out / f"{line}.vrt", members)
            with rasterio.open(path) as src:
                src.read()
        wall, cpu = timed(stack, args.repeat)
        with rasterio.open(out / f"{line}.vrt") as src:
            shape = (src.count, src.height, src.width)
        print(f"VRT of flight line {line} written and read whole ({shape[0]} bands x {shape[1]} x {shape[2]}): "
              f"{wall:.2f} s wall, {cpu:.2f} CPU s")
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
