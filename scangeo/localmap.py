"""Fast local polynomial conversions between the project frame and the map CRS.

Ray casting and rectification convert millions of points between P and the map CRS. Inside a
block, the exact conversion (pyproj + geodesy) is a smooth function that a 3D polynomial in
normalised coordinates reproduces to well under a millimetre. ``LocalPolynomialMap.fit`` samples
the exact conversion on a grid over a box, fits polynomials of rising degree, and keeps the first
whose largest error on a second, offset grid is below the tolerance; ``max_error`` records it.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from itertools import product

import numba as nb
import numpy as np

from scangeo.errors import GeometryError


def _exponents(degree: int) -> np.ndarray:
    return np.array([e for e in product(range(degree + 1), repeat=3) if sum(e) <= degree], dtype=np.int64)


@nb.njit(cache=True)
def poly_eval_point(coef, exps, centre, scale, x, y, z, out, work):
    """Evaluate the 3-output polynomial at one point (writes ``out[0:3]``).

    ``work``: scratch of at least 3 * (degree + 1) floats (no allocation in inner loops).
    """
    u = (x - centre[0]) / scale[0]
    v = (y - centre[1]) / scale[1]
    w = (z - centre[2]) / scale[2]
    deg = work.shape[0] // 3 - 1
    pu = work[0:deg + 1]
    pv = work[deg + 1:2 * deg + 2]
    pw = work[2 * deg + 2:3 * deg + 3]
    pu[0] = 1.0
    pv[0] = 1.0
    pw[0] = 1.0
    for d in range(1, deg + 1):
        pu[d] = pu[d - 1] * u
        pv[d] = pv[d - 1] * v
        pw[d] = pw[d - 1] * w
    out[0] = 0.0
    out[1] = 0.0
    out[2] = 0.0
    for i in range(exps.shape[0]):
        m = pu[exps[i, 0]] * pv[exps[i, 1]] * pw[exps[i, 2]]
        out[0] += coef[i, 0] * m
        out[1] += coef[i, 1] * m
        out[2] += coef[i, 2] * m


@dataclass(frozen=True)
class LocalPolynomialMap:
    """A 3D -> 3D polynomial valid inside ``box`` ((3, 2) lower/upper bounds of the input).

    ``max_error``: the largest Euclidean error against the exact conversion found on the check grid.
    """

    coef: np.ndarray
    exps: np.ndarray
    centre: np.ndarray
    scale: np.ndarray
    box: np.ndarray
    max_error: float

    @classmethod
    def fit(cls, exact: Callable[[np.ndarray], np.ndarray], box, tolerance: float = 2e-4,
            max_degree: int = 7) -> LocalPolynomialMap:
        """Fit ``exact`` ((n, 3) -> (n, 3)) over ``box``; raise if no degree reaches ``tolerance``."""
        box = np.asarray(box, dtype=float)
        centre = box.mean(axis=1)
        scale = np.maximum((box[:, 1] - box[:, 0]) / 2.0, 1e-6)
        def grid(n_xy, n_z, offset):
            axes = [np.linspace(-1, 1, n) + (offset / n if n > 1 else 0) for n in (n_xy, n_xy, n_z)]
            axes = [np.clip(a, -1, 1) for a in axes]
            g = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
            return centre + g * scale
        train = grid(17, 7, 0.0)
        check = grid(14, 5, 0.5)
        y_train = exact(train)
        y_check = exact(check)
        best = None
        for degree in range(2, max_degree + 1):
            exps = _exponents(degree)
            A = _design((train - centre) / scale, exps)
            coef, *_ = np.linalg.lstsq(A, y_train, rcond=None)
            err = np.linalg.norm(_design((check - centre) / scale, exps) @ coef - y_check, axis=1).max()
            best = cls(coef, exps, centre, scale, box, float(err))
            if err < tolerance:
                return best
        assert best is not None  # max_degree >= 1: at least one fit was tried
        raise GeometryError(
            f"no polynomial up to degree {max_degree} reproduces the map conversion over the block to "
            f"{tolerance * 1000:.2f} mm (best {best.max_error * 1000:.2f} mm); the block is too large"
        )

    def __call__(self, pts: np.ndarray) -> np.ndarray:
        pts = np.asarray(pts, dtype=float)
        return (
            _design((pts.reshape(-1, 3) - self.centre) / self.scale, self.exps).__matmul__(self.coef).reshape(pts.shape)
        )


def _design(u: np.ndarray, exps: np.ndarray) -> np.ndarray:
    deg = int(exps.max())
    pw = [np.ones_like(u)]
    for _ in range(deg):
        pw.append(pw[-1] * u)
    stacked = np.stack(pw)  # (deg+1, n, 3)
    return stacked[exps[:, 0], :, 0].T * stacked[exps[:, 1], :, 1].T * stacked[exps[:, 2], :, 2].T
