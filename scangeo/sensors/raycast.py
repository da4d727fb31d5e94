"""Ray casting on a DTM (numba): the first intersection of rays with a bilinear height field.

Rays live in the project frame; the DTM in the map CRS. Along each ray the map coordinates come
from a local polynomial (``scangeo.localmap``), interpolated quadratically in the ray parameter
while marching (sub-millimetre over a ray's length) and evaluated exactly while refining. The march
steps at most ``step`` (map units, default a quarter DTM cell) horizontally, so a ridge is not
skipped; the first sign change of ``H(ray) - DTM`` is refined by the Illinois method to 1e-6 m.
"""
from __future__ import annotations

import math

import numba as nb
import numpy as np

from scangeo.localmap import poly_eval_point
from scangeo.sensors.kernels import BEHIND, LEAVES_DTM, NO_CONVERGENCE, NODATA, OK, UPWARD


@nb.njit(cache=True)
def dtm_sample(values, inv, x, y):
    """Bilinear DTM height at a map point: (value, code) with code 0 ok, 1 outside, 2 nodata."""
    col = inv[0] * x + inv[1] * y + inv[2] - 0.5
    row = inv[3] * x + inv[4] * y + inv[5] - 0.5
    rows, cols = values.shape
    if not (col >= 0 and col <= cols - 1 and row >= 0 and row <= rows - 1):
        return np.nan, 1
    c0 = min(int(col), cols - 2)
    r0 = min(int(row), rows - 2)
    fc = col - c0
    fr = row - r0
    v00 = values[r0, c0]
    v01 = values[r0, c0 + 1]
    v10 = values[r0 + 1, c0]
    v11 = values[r0 + 1, c0 + 1]
    top = v00 + fc * (v01 - v00)
    bottom = v10 + fc * (v11 - v10)
    v = top + fr * (bottom - top)
    if math.isnan(v):
        return np.nan, 2
    return v, 0


@nb.njit(inline="always", cache=True)
def _quad(P3, s):
    """(x, y, H) at parameter s in [0, 1] of the quadratic through the rows of P3 (s = 0, 0.5, 1)."""
    w0 = 2 * (s - 0.5) * (s - 1.0)
    w1 = -4 * s * (s - 1.0)
    w2 = 2 * s * (s - 0.5)
    return (w0 * P3[0, 0] + w1 * P3[1, 0] + w2 * P3[2, 0], w0 * P3[0, 1] + w1 * P3[1, 1] + w2 * P3[2, 1],
            w0 * P3[0, 2] + w1 * P3[1, 2] + w2 * P3[2, 2])


@nb.njit(inline="always", cache=True)
def _block_max(bmax, inv, block, x, y):
    """Highest terrain within one block of the map point (x, y) (+inf outside, near nodata)."""
    col = inv[0] * x + inv[1] * y + inv[2] - 0.5
    row = inv[3] * x + inv[4] * y + inv[5] - 0.5
    if col < 0 or row < 0:
        return np.inf
    bc = int(col) // block
    br = int(row) // block
    if br >= bmax.shape[0] or bc >= bmax.shape[1]:
        return np.inf
    return bmax[br, bc]


@nb.njit(cache=True)
def _exact_f(o, d, lam, coef, exps, centre, scale, values, inv, buf, work):
    poly_eval_point(coef, exps, centre, scale, o[0] + lam * d[0], o[1] + lam * d[1], o[2] + lam * d[2], buf, work)
    v, code = dtm_sample(values, inv, buf[0], buf[1])
    return buf[2] - v, code


@nb.njit(parallel=True, cache=True)
def ray_cast_kernel(origins, dirs, coef, exps, centre, scale, values, inv, h_min, h_max, step,
                    bmax, block, block_extent, out_p, out_status):
    n = origins.shape[0]
    n_chunks = min(n, 512)
    chunk = (n + n_chunks - 1) // n_chunks
    for c in nb.prange(n_chunks):
        buf = np.empty(3)
        work = np.empty(3 * (exps.max() + 1))
        P3 = np.empty((3, 3))
        for q in range(c * chunk, min(n, (c + 1) * chunk)):
            _cast_one(q, origins[q], dirs[q], coef, exps, centre, scale, values, inv, h_min, h_max, step,
                      bmax, block, block_extent, out_p, out_status, buf, work, P3)


@nb.njit(cache=True)
def _cast_one(q, o, d, coef, exps, centre, scale, values, inv, h_min, h_max, step, bmax, block, block_extent,
              out_p, out_status, buf, work, P3):
    for k in range(3):
        out_p[q, k] = np.nan
    if not (np.isfinite(o[0]) and np.isfinite(d[0])):
        out_status[q] = NO_CONVERGENCE
        return
    poly_eval_point(coef, exps, centre, scale, o[0], o[1], o[2], buf, work)
    H0 = buf[2]
    poly_eval_point(coef, exps, centre, scale, o[0] + 100 * d[0], o[1] + 100 * d[1], o[2] + 100 * d[2], buf, work)
    dH = (buf[2] - H0) / 100.0
    if dH > -1e-9:
        out_status[q] = UPWARD
        return
    la = max(0.0, (H0 - h_max - 20.0) / (-dH))
    lb = (H0 - h_min + 20.0) / (-dH) * 1.01 + 1.0
    if lb <= la:
        out_status[q] = BEHIND
        return
    # quadratic model of (x, y, H) along the ray, from three exact evaluations
    lm = 0.5 * (la + lb)
    for i, lam in enumerate((la, lm, lb)):
        poly_eval_point(coef, exps, centre, scale, o[0] + lam * d[0], o[1] + lam * d[1], o[2] + lam * d[2], buf, work)
        for k in range(3):
            P3[i, k] = buf[k]
    horiz = math.hypot(P3[2, 0] - P3[0, 0], P3[2, 1] - P3[0, 1])
    nsteps = max(1, min(200000, int(math.ceil(horiz / step))))
    dl = (lb - la) / nsteps
    h = lb - la
    status = LEAVES_DTM
    seen_valid = False
    f_prev = np.nan
    l_prev = la
    # samples per skip segment: a segment spans at most one block horizontally
    per_step = horiz / nsteps
    skip = max(1, int(block_extent / per_step)) if per_step > 0 else nsteps + 1
    i = -1
    while i < nsteps:
        i += 1
        lam = la + i * dl
        s = (lam - la) / h  # 0..1
        x, y, H = _quad(P3, s)
        if seen_valid and f_prev > 0 and i + skip <= nsteps:
            # the whole next segment lies above the highest terrain near here: jump over it
            bm = _block_max(bmax, inv, block, x, y)
            s2 = (la + (i + skip) * dl - la) / h
            x2, y2, H2 = _quad(P3, s2)
            if H2 > bm:
                i += skip - 1
                l_prev = la + i * dl
                continue
        v, code = dtm_sample(values, inv, x, y)
        if code == 2 and H > h_max:
            # above the highest terrain over a nodata hole: cannot meet the ground there
            l_prev = lam
            continue
        if code != 0:
            if seen_valid:
                status = LEAVES_DTM if code == 1 else NODATA
                break
            if code == 2:
                status = NODATA
            f_prev = np.nan
            l_prev = lam
            continue
        f = H - v
        if not seen_valid:
            seen_valid = True
            if f <= 0:
                if i == 0 and la == 0.0:
                    status = BEHIND  # the ray starts below the terrain
                    break
                # entered the DTM below its surface: a crossing outside the DTM, not ours
                status = LEAVES_DTM
                break
        elif f <= 0:
            # refine in [l_prev, lam] with the exact conversion (Illinois)
            a, b = l_prev, lam
            fa, ca = _exact_f(o, d, a, coef, exps, centre, scale, values, inv, buf, work)
            fb, cb = _exact_f(o, d, b, coef, exps, centre, scale, values, inv, buf, work)
            if ca != 0 or cb != 0 or fa < 0 or fb > 0:
                # the quadratic model misplaced the crossing by a hair: bisect on exact values
                fa, fb = max(fa, 1e-12) if ca == 0 else 1e-12, min(fb, -1e-12) if cb == 0 else -1e-12
            side = 0
            lam_r = b
            for _ in range(100):
                lam_r = (a * fb - b * fa) / (fb - fa)
                fr, cr = _exact_f(o, d, lam_r, coef, exps, centre, scale, values, inv, buf, work)
                if cr != 0:
                    lam_r = 0.5 * (a + b)
                    fr, cr = _exact_f(o, d, lam_r, coef, exps, centre, scale, values, inv, buf, work)
                if abs(fr) < 1e-7 or (b - a) < 1e-9 * (1.0 + lam_r):
                    break
                if fr > 0:
                    a, fa = lam_r, fr
                    if side == 1:
                        fb *= 0.5
                    side = 1
                else:
                    b, fb = lam_r, fr
                    if side == -1:
                        fa *= 0.5
                    side = -1
            for k in range(3):
                out_p[q, k] = o[k] + lam_r * d[k]
            status = OK
            break
        f_prev = f
        l_prev = lam
    out_status[q] = status
