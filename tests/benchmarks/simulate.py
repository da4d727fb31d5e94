"""Benchmark: simulating blocks (scangeo.simulate), and where rendering a strip spends its time.

Figures: wall time of ``small`` (everything), of ``vienna2000`` without images (terrain, flight,
errors, points), and for 256 lines x 716 pixels of a vienna2000 strip the stages of rendering: ray
casting on the true terrain, project -> map conversion, scene evaluation (11 bands). The conversion
stage is measured both ways: pyproj (``MapFrame.project_to_map``, what the renderer uses) and the
local polynomial map of scangeo.localmap (the named baseline; it was slower here for these points).

Run:  python tests/benchmarks/simulate.py
"""
from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np

from scangeo.dtm import DTM
from scangeo.simulate.block import simulate
from scangeo.simulate.config import load_preset


def timed(fn, *args, **kwargs):
    t = time.perf_counter()
    out = fn(*args, **kwargs)
    return out, time.perf_counter() - t


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        _, t_small = timed(simulate, tmp / "small", load_preset("small"))
        print(f"small (2 x 600 lines, images + truth ortho):     {t_small:7.2f} s")
        config = load_preset("vienna2000", {"output": {"images": False, "truth_ortho": False}})
        block, t_geom = timed(simulate, tmp / "vienna", config)
        print(f"vienna2000 without images (3 x 7000 lines):      {t_geom:7.2f} s")

        strip = block.strips[1]
        true_dtm = DTM(block.terrain.true, block.map_frame)
        L, J = np.meshgrid(np.arange(3000, 3256, dtype=float), np.arange(716, dtype=float), indexing="ij")
        n = L.size
        strip.geometry.image_to_ground(L.ravel()[:1000], J.ravel()[:1000], true_dtm)  # compile / warm up
        (ground, status), t_cast = timed(strip.geometry.image_to_ground, L.ravel(), J.ravel(), true_dtm)
        local = true_dtm.local_map(strip.geometry.footprint_box(true_dtm))
        xyh, t_local = timed(local, ground)
        (x, y, _), t_pyproj = timed(block.map_frame.project_to_map, ground)
        _, t_scene = timed(block.scene.values, xyh[:, 0], xyh[:, 1])
        err = np.hypot(xyh[:, 0] - x, xyh[:, 1] - y).max()
        print(f"render stages for {n:,} pixels (M pixels/s):")
        print(f"  ray casting on the true terrain              {n / t_cast / 1e6:8.2f}")
        print(f"  P -> map, local polynomial (baseline)        {n / t_local / 1e6:8.2f}"
              f"   (max difference to pyproj {err * 1000:.3f} mm)")
        print(f"  P -> map, pyproj (used)                      {n / t_pyproj / 1e6:8.2f}"
              f"   speed-up pyproj/local {t_local / t_pyproj:5.1f}x")
        print(f"  scene evaluation, 11 bands (procedural)      {n / t_scene / 1e6:8.2f}")
        total = t_cast + min(t_local, t_pyproj) + t_scene
        print(f"  -> a 7000-line strip (pyproj conversion) would take about {7000 / 256 * total:6.1f} s")


if __name__ == "__main__":
    main()
