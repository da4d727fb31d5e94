"""Which matcher for tie points: area-based (NCC + least-squares matching) or OpenCV SIFT features.

Both run on the same rectified overlap chips of simulated blocks (the ``small`` preset cut to 300
lines: the procedural scene, and the real orthophoto ../shared/data/ortho/autzen.jpg as texture),
and both carry their matches back into the raw images the same way. Their tie measurements are
compared with the truth (scangeo.truth.matches): the true ground point of the master measurement
seen through the true orientation of the other strip.

* NCC + LSM: ``scangeo.match`` as it is (Shi-Tomasi corners, correlation peak, least-squares).
* SIFT: keypoints in both chips (8-bit, contrast-stretched), ratio test 0.8 and mutual check,
  matches farther than the search radius from the prediction dropped, the same local affine RANSAC.

Run: ``python tests/benchmarks/match_methods.py [FOLDER]`` (simulates into FOLDER, default a temp dir).
"""
from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

from scangeo.io.project import Project
from scangeo.match import MatchOptions, match_project
from scangeo.match.consistency import local_affine_inliers
from scangeo.match.overlaps import find_overlaps
from scangeo.match.strips import ChipGrid, MatchStrip
from scangeo.match.tasks import margin_cells
from scangeo.sensors.kernels import MULTIPLE
from scangeo.truth.matches import match_errors
from scangeo.truth.true_error import Truth

TEXTURE = Path(__file__).resolve().parents[3] / "shared" / "data" / "ortho" / "autzen.jpg"


def simulate_blocks(folder: Path) -> dict[str, Path]:
    from scangeo.simulate.block import simulate
    from scangeo.simulate.config import load_preset

    blocks = {"procedural": folder / "procedural"}
    if TEXTURE.exists():
        blocks["orthophoto"] = folder / "orthophoto"
    for name, root in blocks.items():
        if not (root / "project.toml").exists():
            simulate(root, load_preset("small", {"flight": {"lines": 300}, "terrain": {"margin_m": 500.0}}),
                     texture=str(TEXTURE) if name == "orthophoto" else None)
    return blocks


def _u8(image: np.ndarray) -> np.ndarray:
    finite = np.isfinite(image)
    lo, hi = np.percentile(image[finite], [1, 99])
    return np.clip(np.where(finite, (image - lo) / max(hi - lo, 1e-6) * 255, 0), 0, 255).astype(np.uint8)


def sift_errors(root: Path, options: MatchOptions) -> tuple[int, float, float]:
    """(matches kept, rms error px, share within 1 px) of SIFT ties on the overlap chips."""
    project = Project.load(root)
    strips = {s.id: MatchStrip(project, "DG", s.id, options) for s in project.strips}
    res = 2.6
    overlaps, _ = find_overlaps(strips, res, options.per_overlap, options.per_cell, margin_cells(options))
    sift = cv2.SIFT_create()
    truth = Truth.load(project)
    assert truth is not None
    errors, kept = [], 0
    for o in overlaps:
        a, b = strips[o.a], strips[o.b]
        src, dst, raw_a, raw_b = [], [], [], []
        for cell in o.cells:
            grid = ChipGrid.around(cell.xmin, cell.ymin, cell.xmax, cell.ymax, res, margin_cells(options))
            H = a.heights(grid)
            ca, cb = a.chip(grid, H), b.chip(grid, H)
            ka, da = sift.detectAndCompute(_u8(ca.image), None)
            kb, db = sift.detectAndCompute(_u8(cb.image), None)
            if da is None or db is None or len(kb) < 2 or len(ka) < 2:
                continue
            bf = cv2.BFMatcher(cv2.NORM_L2)
            ab = bf.knnMatch(da, db, k=2)
            ba = {m.queryIdx: m.trainIdx for m, _ in (p for p in bf.knnMatch(db, da, k=2) if len(p) == 2)}
            for pair in ab:
                if len(pair) < 2:
                    continue
                m, n = pair
                if m.distance > 0.8 * n.distance or ba.get(m.trainIdx) != m.queryIdx:
                    continue
                pa, pb = np.array(ka[m.queryIdx].pt), np.array(kb[m.trainIdx].pt)
                inside = (cell.xmin <= grid.x0 + pa[0] * res < cell.xmax) and (
                    cell.ymin < grid.y0 - pa[1] * res <= cell.ymax)
                if np.hypot(*(pb - pa)) > options.search_px or not inside:
                    continue
                src.append(pa + [grid.x0 / res, -grid.y0 / res])
                dst.append(pb + [grid.x0 / res, -grid.y0 / res])
                raw_a.append(ca.raw_at(*pa))
                xb, yb = grid.to_map(*pb)
                ln, px = b.image_of(np.array([xb]), np.array([yb]))
                raw_b.append((ln[0], px[0]))
        if not src:
            continue
        inlier, _ = local_affine_inliers(np.array(src), np.array(dst), options.ransac_px, options.neighbours)
        for i in np.flatnonzero(inlier):
            p_P, st = truth.geometries[o.a].image_to_ground(np.array([raw_a[i][0]]), np.array([raw_a[i][1]]),
                                                           truth.terrain)
            if st[0] != 0:
                continue
            ln, px, st = truth.geometries[o.b].ground_to_image(p_P)
            if (st[0] & ~MULTIPLE) == 0:
                errors.append([raw_b[i][0] - ln[0], raw_b[i][1] - px[0]])
        kept += int(inlier.sum())
    e = np.array(errors).reshape(-1, 2)
    return kept, float(np.sqrt(np.mean(e**2))), float(np.mean(np.hypot(*e.T) <= 1.0))


def main(folder: Path) -> None:
    options = MatchOptions()
    print("measured under load from other helpers unless stated otherwise")
    print(f"{'scene':12s} {'method':10s} {'points':>6s} {'rms px':>7s} {'<=1 px':>7s} {'seconds':>8s}")
    for name, root in simulate_blocks(folder).items():
        t = time.perf_counter()
        r = match_project(root, options=options)
        dt = time.perf_counter() - t
        e = match_errors(root)
        print(f"{name:12s} {'NCC+LSM':10s} {r.report['summary']['tie_points']:6d} {e.tie_rms():7.3f} "
              f"{e.share_within(1.0):7.3f} {dt:8.1f}")
        t = time.perf_counter()
        n, rms, share = sift_errors(root, options)
        print(f"{name:12s} {'SIFT':10s} {n:6d} {rms:7.3f} {share:7.3f} {time.perf_counter() - t:8.1f}")


if __name__ == "__main__":
    if len(sys.argv) > 1:
        main(Path(sys.argv[1]))
    else:
        with tempfile.TemporaryDirectory() as tmp:
            main(Path(tmp))
