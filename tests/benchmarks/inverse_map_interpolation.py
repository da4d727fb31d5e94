"""How far plain interpolation of exact ground -> image solutions is from the exact map.

Run: python tests/benchmarks/inverse_map_interpolation.py [--lines 10000] [--keep DIR]

The benchmark strip of tests/benchmarks/rectify.py (a simulated `small`-preset Daedalus strip with
its turbulence over the true terrain, 2.5 m grid; ``--keep`` shares its folder) is solved exactly
at every cell by the bracketed ground -> image; then (line, pixel) is interpolated bilinearly from
the exact solutions at every S-th cell along both grid axes and compared with the exact map at every
cell. Prints, per S, the largest error (max of |d line|, |d pixel|), its 99.9th and 99th
percentiles and the share of cells above the 0.05 px tolerance. This is why the refined inverse map
solves every cell (docs/rectify.md).
"""
from __future__ import annotations

import argparse
import tempfile
import warnings
from pathlib import Path

import numpy as np

warnings.simplefilter("ignore")


def bilinear_from_every(a: np.ndarray, S: int) -> tuple[np.ndarray, np.ndarray]:
    """(interpolated, exact) on the part of ``a`` covered by whole S-cell steps."""
    R, C = (a.shape[0] - 1) // S * S + 1, (a.shape[1] - 1) // S * S + 1
    exact = a[:R, :C]
    nodes = exact[::S, ::S]
    r, c = np.arange(R) / S, np.arange(C) / S
    i = np.minimum(np.floor(r).astype(int), nodes.shape[0] - 2)
    j = np.minimum(np.floor(c).astype(int), nodes.shape[1] - 2)
    fr, fc = (r - i)[:, None], (c - j)[None, :]
    top = nodes[i][:, j] * (1 - fc) + nodes[i][:, j + 1] * fc
    bottom = nodes[i + 1][:, j] * (1 - fc) + nodes[i + 1][:, j + 1] * fc
    return top * (1 - fr) + bottom * fr, exact


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lines", type=int, default=10_000)
    ap.add_argument("--keep", default=None, help="project folder of tests/benchmarks/rectify.py to reuse")
    args = ap.parse_args()

    import sys

    sys.path.insert(0, str(Path(__file__).parent))
    from rectify import make_project

    from scangeo.io.project import Project
    from scangeo.rectify.core_geometry import CoreStripGeometry
    from scangeo.rectify.options import RectifyOptions
    from scangeo.rectify.strip_run import strip_grid

    tmp = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="scangeo-bench-interp-"))
    root = tmp / "project"
    if not (root / "project.toml").exists():
        make_project(root, args.lines)
    project = Project.load(root)
    g = CoreStripGeometry(project.geometry("01"), project.dtm)
    grid = strip_grid(g, RectifyOptions(resolution=2.5))
    x, y = grid.x_of_col(np.arange(grid.width)), grid.y_of_row(np.arange(grid.height))
    H = g.height_on_lattice(x, y)
    X, Y = np.meshgrid(x, y)
    line, pixel = (a.reshape(X.shape) for a in g.ground_to_image(X.ravel(), Y.ravel(), H.ravel()))
    print(f"strip 716 x {args.lines}, grid {grid.width} x {grid.height} at 2.5 m, "
          f"{np.isfinite(line).sum()} cells seen, exact by the bracketed ground -> image")
    print(f"{'every S-th cell':<18}{'max px':>9}{'p99.9':>9}{'p99':>9}{'> 0.05 px':>11}")
    for S in (2, 4, 8):
        (il, el), (ip, ep) = bilinear_from_every(line, S), bilinear_from_every(pixel, S)
        err = np.maximum(np.abs(il - el), np.abs(ip - ep))
        err = err[np.isfinite(err)]
        print(f"{S:<18}{err.max():>9.3f}{np.percentile(err, 99.9):>9.3f}{np.percentile(err, 99):>9.3f}"
              f"{100 * (err > 0.05).mean():>10.2f}%")


if __name__ == "__main__":
    main()
