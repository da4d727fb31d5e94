"""An independent reference for the imported HySpex lines: direct georeferencing in the map grid.

Written apart from scangeo's geometry on purpose (numpy and scipy only, nothing of scangeo): the
map grid (UTM) as a local Cartesian frame, navarr's positions and heights, PARGE's attitude arrays
in its own conventions (roll positive with the left wing down, heading from grid north), the look
angles of sensarr, and three boresight angles ``R_BS = Rz(c) Ry(b) Rx(a)`` fitted by least squares
to control GCPs. Each GCP's ray is cast at its measured line (that line's navigation record) and
pixel onto the horizontal plane at the GCP's height; the ground residual is turned into lines and
pixels by the local ground displacement of one line and one pixel.
"""
from __future__ import annotations

import numpy as np
import scipy.io
from scipy.optimize import least_squares

_ENU_NED = np.array([[0.0, 1, 0], [1, 0, 0], [0, 0, -1]])


def _rot(axis: int, a: np.ndarray) -> np.ndarray:
    a = np.asarray(a, float)
    c, s = np.cos(a), np.sin(a)
    R = np.zeros(a.shape + (3, 3))
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    R[..., axis, axis] = 1
    R[..., i, i] = c
    R[..., j, j] = c
    R[..., i, j] = -s
    R[..., j, i] = s
    return R


class GridLine:
    """One PARGE line in the map grid."""

    def __init__(self, path) -> None:
        d = scipy.io.readsav(str(path), python_dict=True)
        self.roll, self.pitch, self.head = (d[k][:, 0] for k in ("rollarr", "pitcharr", "headarr"))
        self.nav = d["navarr"]
        s = d["sensarr"]
        self.index, self.vx, self.vy = s[:, 0], s[:, 1], s[:, 2]
        self.gcp = d["gcparr"]

    def ground(self, line: np.ndarray, pixel: np.ndarray, z: np.ndarray, bs) -> np.ndarray:
        """Map (E, N) where the rays of (line, pixel) meet the planes at heights z."""
        k = np.arange(len(self.roll))
        r, p, h = (np.interp(line, k, a) for a in (self.roll, self.pitch, self.head))
        pos = np.column_stack([np.interp(line, k, self.nav[:, c]) for c in range(3)])
        ax, ay = np.interp(pixel, self.index, self.vx), np.interp(pixel, self.index, self.vy)
        d_S = np.stack([np.tan(ay), -np.tan(ax), np.ones_like(ax)], -1)
        R_BS = _rot(2, bs[2]) @ _rot(1, bs[1]) @ _rot(0, bs[0])
        R_NB = _rot(2, h) @ _rot(1, p) @ _rot(0, -r)
        d_M = np.einsum("ij,njk,kl,nl->ni", _ENU_NED, R_NB, R_BS, d_S)
        lam = (z - pos[:, 2]) / d_M[:, 2]
        return pos[:, :2] + lam[:, None] * d_M[:, :2]

    def residuals(self, rows: np.ndarray, bs) -> np.ndarray:
        """(n, 2) residuals (lines, pixels) of GCP rows under boresight bs (rad)."""
        g = self.gcp[rows]
        pix, line, xy, z = g[:, 0], g[:, 1], g[:, 2:4], g[:, 4]
        at = self.ground(line, pix, z, bs)
        d_line = self.ground(line + 1, pix, z, bs) - at
        d_pix = self.ground(line, pix + 1, z, bs) - at
        J = np.stack([d_line, d_pix], -1)                      # ground per (line, pixel)
        return np.linalg.solve(J, (at - xy)[..., None])[..., 0]

    def fit(self, rows: np.ndarray) -> np.ndarray:
        return least_squares(lambda b: self.residuals(rows, b).ravel(), np.zeros(3), x_scale=1e-3).x


def alternate_split(gcp: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """PARGE's used GCPs sorted by line, alternately control and check (rows of gcparr)."""
    used = np.flatnonzero(gcp[:, 5] > 0.5)
    used = used[np.argsort(gcp[used, 1], kind="stable")]
    return used[0::2], used[1::2]


def reference_check_rms(path) -> tuple[tuple[float, float], np.ndarray]:
    """Check-point rms (lines, pixels) of the three-angle fit on the alternate split, and the angles (rad)."""
    line = GridLine(path)
    control, check = alternate_split(line.gcp)
    bs = line.fit(control)
    res = line.residuals(check, bs)
    rms = np.sqrt(np.mean(res**2, axis=0))
    return (float(rms[0]), float(rms[1])), bs
