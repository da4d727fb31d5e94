"""Compiled kernels (numba) for the hot loops: spline pose, ground -> image, ray casting on a DTM.

The Python-facing API is ``scangeo.sensors.strip``; these functions take plain arrays:

* spline: ``t0, dt, coef (K, 6)``: uniform cubic B-spline of x, y, z, roll, pitch, heading (project
  frame, angles w.r.t. the project NED frame);
* mounting: ``lever (3,)`` body frame metres, ``R_BS (3, 3)``, ``time_offset`` seconds
  (navigation time = sensor time + time_offset);
* sensor: ``kind, sp (params), table (n, 2)`` from ``SensorModel.kernel_params()``;
* timing: ``lt0, lrate, ltable``: ``t0 + line / rate`` when ``ltable`` is empty, else the table.
"""
from __future__ import annotations

import math

import numba as nb
import numpy as np

# status codes (see scangeo.sensors.strip.STATUS)
OK = 0
NOT_SEEN = 1  # no time at which the point is in the scan plane (before/after the strip)
OUTSIDE_SWATH = 2
BEHIND = 3
NO_CONVERGENCE = 4
LEAVES_DTM = 5
NODATA = 6
UPWARD = 7
MULTIPLE = 16  # flag bit: several solutions (over-scanning); the first in time is returned



@nb.njit(inline="always", cache=True)
def _spline_component(coef, j, c, b0, b1, b2, b3, d0, d1, d2, d3):
    c0, c1, c2, c3 = coef[j, c], coef[j + 1, c], coef[j + 2, c], coef[j + 3, c]
    return b0 * c0 + b1 * c1 + b2 * c2 + b3 * c3, d0 * c0 + d1 * c1 + d2 * c2 + d3 * c3


@nb.njit(inline="always", cache=True)
def spline_pose(t, t0, dt, coef, lever, R_BS, time_offset, R, p, dR, dp):
    """R_PS (3,3), p_S (3,) and their time derivatives at sensor time t; writes into the outputs.

    No heap allocation: it runs in the innermost loops.
    """
    tn = t + time_offset
    K = coef.shape[0]
    s = (tn - t0) / dt
    j = int(math.floor(s))
    if j < 0:
        j = 0
    elif j > K - 4:
        j = K - 4
    u = s - j
    u2 = u * u
    u3 = u2 * u
    b0 = (1 - u) ** 3 / 6.0
    b1 = (3 * u3 - 6 * u2 + 4) / 6.0
    b2 = (-3 * u3 + 3 * u2 + 3 * u + 1) / 6.0
    b3 = u3 / 6.0
    d0 = -((1 - u) ** 2) / 2.0 / dt
    d1 = (3 * u2 - 4 * u) / 2.0 / dt
    d2 = (-3 * u2 + 2 * u + 1) / 2.0 / dt
    d3 = u2 / 2.0 / dt
    x, wx = _spline_component(coef, j, 0, b0, b1, b2, b3, d0, d1, d2, d3)
    y, wy = _spline_component(coef, j, 1, b0, b1, b2, b3, d0, d1, d2, d3)
    z, wz = _spline_component(coef, j, 2, b0, b1, b2, b3, d0, d1, d2, d3)
    r, wr = _spline_component(coef, j, 3, b0, b1, b2, b3, d0, d1, d2, d3)
    pi_, wp = _spline_component(coef, j, 4, b0, b1, b2, b3, d0, d1, d2, d3)
    h, wh = _spline_component(coef, j, 5, b0, b1, b2, b3, d0, d1, d2, d3)
    cr, sr = math.cos(r), math.sin(r)
    cp, spp = math.cos(pi_), math.sin(pi_)
    ch, sh = math.cos(h), math.sin(h)
    # A = Rz(h) Ry(p) Rx(r) (body -> project NED)
    a00 = ch * cp
    a01 = ch * spp * sr - sh * cr
    a02 = ch * spp * cr + sh * sr
    a10 = sh * cp
    a11 = sh * spp * sr + ch * cr
    a12 = sh * spp * cr - ch * sr
    a20 = -spp
    a21 = cp * sr
    a22 = cp * cr
    # dA/dt = (A Kx) wr + (Rz dRy Rx) wp + (Kz A) wh
    e00 = -ch * spp * wp - a10 * wh
    e01 = a02 * wr + ch * cp * sr * wp - a11 * wh
    e02 = -a01 * wr + ch * cp * cr * wp - a12 * wh
    e10 = -sh * spp * wp + a00 * wh
    e11 = a12 * wr + sh * cp * sr * wp + a01 * wh
    e12 = -a11 * wr + sh * cp * cr * wp + a02 * wh
    e20 = -cp * wp
    e21 = a22 * wr - spp * sr * wp
    e22 = -a21 * wr - spp * cr * wp
    # R_PB = E A with E = [[0,1,0],[1,0,0],[0,0,-1]]: rows (A1, A0, -A2)
    l0, l1, l2 = lever[0], lever[1], lever[2]
    p[0] = x + a10 * l0 + a11 * l1 + a12 * l2
    p[1] = y + a00 * l0 + a01 * l1 + a02 * l2
    p[2] = z - (a20 * l0 + a21 * l1 + a22 * l2)
    dp[0] = wx + e10 * l0 + e11 * l1 + e12 * l2
    dp[1] = wy + e00 * l0 + e01 * l1 + e02 * l2
    dp[2] = wz - (e20 * l0 + e21 * l1 + e22 * l2)
    for k in range(3):
        b0k, b1k, b2k = R_BS[0, k], R_BS[1, k], R_BS[2, k]
        R[0, k] = a10 * b0k + a11 * b1k + a12 * b2k
        R[1, k] = a00 * b0k + a01 * b1k + a02 * b2k
        R[2, k] = -(a20 * b0k + a21 * b1k + a22 * b2k)
        dR[0, k] = e10 * b0k + e11 * b1k + e12 * b2k
        dR[1, k] = e00 * b0k + e01 * b1k + e02 * b2k
        dR[2, k] = -(e20 * b0k + e21 * b1k + e22 * b2k)


@nb.njit(cache=True)
def sensor_pixel(kind, sp, table, vy, vz):
    """Fractional pixel of a sensor-frame direction (vy, vz) (its across-track angle)."""
    if kind == 0:
        theta = math.atan2(vy, vz)
        return sp[0] + sp[2] * (theta - sp[3]) / sp[1]
    tx = vy / vz
    if kind == 2:
        pp, pitch, f, k1, k2, y0 = sp[0], sp[1], sp[2], sp[3], sp[4], sp[5]
        # the calibration inverted: nominal tangent of the calibrated one (sp[6:10], Pushbroom.kernel_params)
        tc, scale, off = sp[6], sp[7], sp[8]
        xu = (tc + (tx - off - tc) / (1.0 + scale)) * f
        xd = xu
        for _ in range(30):
            r2 = xd * xd + y0 * y0
            g = xd * (1 + k1 * r2 + k2 * r2 * r2) - xu
            dg = 1 + k1 * (r2 + 2 * xd * xd) + k2 * (r2 * r2 + 4 * xd * xd * r2)
            step = g / dg
            xd -= step
            if abs(step) < 1e-15:
                break
        return xd / pitch + pp
    # table: monotonic tan(across) in column 1
    n = table.shape[0]
    inc = table[n - 1, 1] > table[0, 1]
    lo = 0
    hi = n - 1
    if (inc and tx <= table[0, 1]) or ((not inc) and tx >= table[0, 1]):
        lo, hi = 0, 1
    elif (inc and tx >= table[n - 1, 1]) or ((not inc) and tx <= table[n - 1, 1]):
        lo, hi = n - 2, n - 1
    else:
        while hi - lo > 1:
            mid = (lo + hi) // 2
            if (table[mid, 1] <= tx) == inc:
                lo = mid
            else:
                hi = mid
    return lo + (tx - table[lo, 1]) / (table[hi, 1] - table[lo, 1])


@nb.njit(cache=True)
def sensor_along_tan(kind, sp, table, pixel):
    """tan of the along-track look angle of a pixel (0 for a whiskbroom)."""
    if kind == 0:
        return 0.0
    if kind == 2:
        return sp[5] / sp[2] + sp[9]
    n = table.shape[0]
    j = int(math.floor(pixel))
    if j < 0:
        j = 0
    elif j > n - 2:
        j = n - 2
    f = pixel - j
    return table[j, 0] + f * (table[j + 1, 0] - table[j, 0])


@nb.njit(cache=True)
def sensor_look(kind, sp, table, pixel, out):
    """Unit look direction of a (fractional) pixel in the sensor frame."""
    if kind == 0:
        theta = sp[2] * (pixel - sp[0]) * sp[1] + sp[3]
        out[0] = 0.0
        out[1] = math.sin(theta)
        out[2] = math.cos(theta)
        return
    if kind == 2:
        pp, pitch, f, k1, k2, y0 = sp[0], sp[1], sp[2], sp[3], sp[4], sp[5]
        xd = (pixel - pp) * pitch
        r2 = xd * xd + y0 * y0
        a = y0 / f + sp[9]
        b = xd * (1 + k1 * r2 + k2 * r2 * r2) / f
        b = b + sp[8] + sp[7] * (b - sp[6])
    else:
        n = table.shape[0]
        j = int(math.floor(pixel))
        if j < 0:
            j = 0
        elif j > n - 2:
            j = n - 2
        fr = pixel - j
        a = table[j, 0] + fr * (table[j + 1, 0] - table[j, 0])
        b = table[j, 1] + fr * (table[j + 1, 1] - table[j, 1])
    norm = math.sqrt(a * a + b * b + 1.0)
    out[0] = a / norm
    out[1] = b / norm
    out[2] = 1.0 / norm


@nb.njit(cache=True)
def time_to_line(t, lt0, lrate, ltable):
    n = ltable.shape[0]
    if n == 0:
        return (t - lt0) * lrate
    if t <= ltable[0]:
        return (t - ltable[0]) / (ltable[1] - ltable[0])
    if t >= ltable[n - 1]:
        return (n - 1) + (t - ltable[n - 1]) / (ltable[n - 1] - ltable[n - 2])
    lo, hi = 0, n - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if ltable[mid] <= t:
            lo = mid
        else:
            hi = mid
    return lo + (t - ltable[lo]) / (ltable[hi] - ltable[lo])


@nb.njit(cache=True)
def line_to_time(line, lt0, lrate, ltable):
    n = ltable.shape[0]
    if n == 0:
        return lt0 + line / lrate
    if line <= 0:
        return ltable[0] + line * (ltable[1] - ltable[0])
    if line >= n - 1:
        return ltable[n - 1] + (line - (n - 1)) * (ltable[n - 1] - ltable[n - 2])
    j = int(line)
    return ltable[j] + (line - j) * (ltable[j + 1] - ltable[j])


@nb.njit(parallel=True, cache=True)
def rays_kernel(lines, pixels, t0, dt, coef, lever, R_BS, toff, kind, sp, table, lt0, lrate, ltable,
                out_o, out_d):
    """Ray origins p_S and unit directions R_PS look_S (project frame) of (line, pixel) pairs."""
    n = lines.shape[0]
    n_chunks = min(n, 512)
    chunk = (n + n_chunks - 1) // n_chunks
    for c in nb.prange(n_chunks):
        R, dR, p, dp = _pose_buffers()
        look = np.empty(3)
        for q in range(c * chunk, min(n, (c + 1) * chunk)):
            pix = pixels[q]
            t = line_to_time(lines[q], lt0, lrate, ltable)
            if kind == 0:
                t += (pix - sp[0]) * sp[4]
            spline_pose(t, t0, dt, coef, lever, R_BS, toff, R, p, dR, dp)
            sensor_look(kind, sp, table, pix, look)
            for i in range(3):
                out_o[q, i] = p[i]
                out_d[q, i] = R[i, 0] * look[0] + R[i, 1] * look[1] + R[i, 2] * look[2]


@nb.njit(inline="always", cache=True)
def _condition(t, P, tan_a, t0, dt, coef, lever, R_BS, toff, R, p, dR, dp):
    """f(t) = (R_PS[:,0] - tan_a R_PS[:,2]) . (P - p_S) and df/dt."""
    spline_pose(t, t0, dt, coef, lever, R_BS, toff, R, p, dR, dp)
    f = 0.0
    df = 0.0
    for i in range(3):
        d = P[i] - p[i]
        gi = R[i, 0] - tan_a * R[i, 2]
        dgi = dR[i, 0] - tan_a * dR[i, 2]
        f += gi * d
        df += dgi * d - gi * dp[i]
    return f, df


@nb.njit(inline="always", cache=True)
def _coarse_g(k, P, cA, cC):
    """The scan-plane condition at coarse epoch k: ``A_k . P - C_k`` with
    ``A_k = R_PS[:,0] - tan_c R_PS[:,2]`` and ``C_k = A_k . p_S`` precomputed (tan_c: centre pixel)."""
    return cA[k, 0] * P[0] + cA[k, 1] * P[1] + cA[k, 2] * P[2] - cC[k]


MAX_CROSSINGS = 8


@nb.njit(cache=True)
def _sign_change(k, P, cA, cC):
    ga = _coarse_g(k, P, cA, cC)
    gb = _coarse_g(k + 1, P, cA, cC)
    return (ga >= 0 and gb < 0) or (ga < 0 and gb >= 0)


@nb.njit(cache=True)
def _grazes(k, P, cA, cC):
    """True if the parabola through samples k-1, k, k+1 crosses zero twice between them while the
    samples themselves keep one sign."""
    gm = _coarse_g(k - 1, P, cA, cC)
    g0 = _coarse_g(k, P, cA, cC)
    gp = _coarse_g(k + 1, P, cA, cC)
    if (gm >= 0) != (g0 >= 0) or (gp >= 0) != (g0 >= 0):
        return False
    curv = gp - 2 * g0 + gm
    if curv == 0:
        return False
    x_v = -(gp - gm) / (2 * curv)  # vertex, in sample units around k
    if abs(x_v) >= 1:
        return False
    g_v = g0 - (gp - gm) ** 2 / (8 * curv)
    return (g_v >= 0) != (g0 >= 0)


@nb.njit(cache=True)
def _find_crossings(P, cA, cC, k_warm, window, out):
    """Coarse intervals where the scan-plane condition changes sign, in time order (at most
    MAX_CROSSINGS); returns their count and the number of sightings including double crossings
    between coarse samples (grazing). With ``window == 0`` the strip is monotonic (one crossing,
    found by galloping from ``k_warm`` and bisection); otherwise all crossings within ``window``
    intervals of a first one are collected."""
    M = cA.shape[0]
    g0 = _coarse_g(0, P, cA, cC)
    gM = _coarse_g(M - 1, P, cA, cC)
    k0 = -1
    if g0 >= 0 and gM < 0:
        k = min(max(k_warm, 0), M - 2)
        if _coarse_g(k, P, cA, cC) >= 0:
            lo = k
            step = 1
            hi = min(M - 1, lo + step)
            while _coarse_g(hi, P, cA, cC) >= 0:
                lo = hi
                step *= 2
                hi = min(M - 1, lo + step)
        else:
            hi = k
            step = 1
            lo = max(0, hi - step)
            while _coarse_g(lo, P, cA, cC) < 0:
                hi = lo
                step *= 2
                lo = max(0, hi - step)
        while hi - lo > 1:
            mid = (lo + hi) // 2
            if _coarse_g(mid, P, cA, cC) >= 0:
                lo = mid
            else:
                hi = mid
        k0 = lo
    elif window > 0:
        for kk in range(M - 1):
            if _sign_change(kk, P, cA, cC):
                k0 = kk
                break
    if k0 < 0:
        return 0, 0
    if window == 0:
        out[0] = k0
        return 1, 1
    count = 0
    grazing = 0
    for kk in range(max(0, k0 - window), min(M - 1, k0 + window + 1)):
        if _sign_change(kk, P, cA, cC):
            out[count] = kk
            count += 1
            if count == MAX_CROSSINGS:
                break
        elif kk > 0 and _grazes(kk, P, cA, cC):
            grazing += 2
    # a double crossing between coarse samples (the scan plane turning near the point) is counted
    # for the over-scanning flag; its times are not solved
    return count, count + grazing


@nb.njit(cache=True)
def _solve_in(k, P, tan_a, tan_c, ctimes, cA, cC, t0, dt, coef, lever, R_BS, toff, tol_t, R, p, dR, dp):
    """Safeguarded Newton for the time in coarse interval k (either sign change); NaN if none.

    Returns the time and the epoch at which R, p, dR, dp were last evaluated (within tol_t of it)."""
    M = ctimes.shape[0]
    a = ctimes[k]
    b = ctimes[k + 1]
    if tan_a == tan_c:
        fa = _coarse_g(k, P, cA, cC)  # the coarse poses are the spline's poses
        fb = _coarse_g(k + 1, P, cA, cC)
    else:
        fa, _ = _condition(a, P, tan_a, t0, dt, coef, lever, R_BS, toff, R, p, dR, dp)
        fb, _ = _condition(b, P, tan_a, t0, dt, coef, lever, R_BS, toff, R, p, dR, dp)
    if (fa >= 0) == (fb >= 0):
        # the pixel's own along-track angle moved the crossing away from the centre pixel's:
        # search the neighbouring intervals, nearest first, for the crossing of this condition
        found = False
        for w in range(1, 257):
            for kk in (k - w, k + w):
                if kk < 0 or kk > M - 2:
                    continue
                a = ctimes[kk]
                b = ctimes[kk + 1]
                fa, _ = _condition(a, P, tan_a, t0, dt, coef, lever, R_BS, toff, R, p, dR, dp)
                fb, _ = _condition(b, P, tan_a, t0, dt, coef, lever, R_BS, toff, R, p, dR, dp)
                if (fa >= 0) != (fb >= 0):
                    found = True
                    break
            if found or (k - w < 0 and k + w > M - 2):
                break
        if not found:
            return np.nan, np.nan
    sa = fa >= 0
    t = a - fa * (b - a) / (fb - fa)
    for _ in range(60):
        f, df = _condition(t, P, tan_a, t0, dt, coef, lever, R_BS, toff, R, p, dR, dp)
        if (f >= 0) == sa:
            a = t
        else:
            b = t
        tn = t - f / df if df != 0 else 0.5 * (a + b)
        lo, hi = (a, b) if a < b else (b, a)
        if not (lo < tn < hi):
            tn = 0.5 * (a + b)
        if abs(tn - t) < tol_t:
            return tn, t  # the pose buffers hold the pose at t
        t = tn
    return np.nan, np.nan


@nb.njit(inline="always", cache=True)
def _pose_buffers():
    """Work arrays of ``spline_pose``: R, dR (3, 3), p, dp (3,)."""
    return np.empty((3, 3)), np.empty((3, 3)), np.empty(3), np.empty(3)


@nb.njit(inline="always", cache=True)
def _view_yz(P, R, p, dR, dp, h):
    """Sensor-frame y, z of the point P seen from the pose (R, p) moved by h seconds to first order."""
    vy = 0.0
    vz = 0.0
    for i in range(3):
        d = P[i] - (p[i] + h * dp[i])
        vy += (R[i, 1] + h * dR[i, 1]) * d
        vz += (R[i, 2] + h * dR[i, 2]) * d
    return vy, vz


@nb.njit(parallel=True, cache=True)
def ground_to_image_kernel(points, t0, dt, coef, lever, R_BS, toff, kind, sp, table,
                           lt0, lrate, ltable, n_lines, ctimes, cA, cC, window, tol_t, n_chunks,
                           out_line, out_pixel, out_status):
    """Solve (line, pixel) for ground points (n, 3) in the project frame, in parallel chunks.

    ``ctimes, cA, cC``: coarse sensor times and the condition's coefficients there for the centre
    pixel's along-track angle (bracketing, see ``_coarse_g``); ``window``: number
    of coarse intervals searched around a solution for further solutions (0 = strip monotonic).
    The first solution in time that lies inside the image is returned; MULTIPLE flags points with
    several.
    """
    n = points.shape[0]
    chunk = (n + n_chunks - 1) // n_chunks
    npix = sp[sp.shape[0] - 1] if kind != 1 else sp[0]
    for c in nb.prange(n_chunks):
        R, dR, p, dp = _pose_buffers()
        crossings = np.empty(MAX_CROSSINGS, dtype=np.int64)
        k_warm = cA.shape[0] // 2
        for q in range(c * chunk, min(n, (c + 1) * chunk)):
            P = points[q]
            out_line[q] = np.nan
            out_pixel[q] = np.nan
            out_status[q] = NOT_SEEN
            if not (np.isfinite(P[0]) and np.isfinite(P[1]) and np.isfinite(P[2])):
                continue
            tan_c = sensor_along_tan(kind, sp, table, 0.5 * (npix - 1))
            count, sightings = _find_crossings(P, cA, cC, k_warm, window, crossings)
            flag = MULTIPLE if sightings > 1 else 0
            if count > 0:
                k_warm = crossings[0]
            for ci in range(count):
                k = crossings[ci]
                tan_a = tan_c
                status = OK
                pixel = np.nan
                t = np.nan
                x_prev = 0.0
                h_prev = 0.0
                for outer in range(30):  # pushbroom: iterate the along-track angle of the pixel
                    t, t_ev = _solve_in(k, P, tan_a, tan_c, ctimes, cA, cC, t0, dt, coef, lever, R_BS, toff,
                                        tol_t, R, p, dR, dp)
                    if np.isnan(t):
                        status = NO_CONVERGENCE
                        break
                    # the pose at t from the last evaluation, to first order (|t - t_ev| < tol_t)
                    vy, vz = _view_yz(P, R, p, dR, dp, t - t_ev)
                    if vz <= 0:
                        status = BEHIND
                        break
                    pixel = sensor_pixel(kind, sp, table, vy, vz)
                    if kind == 0:
                        break
                    # fixed point tan_a = along(pixel(tan_a)), by secant steps on its residual
                    h_res = sensor_along_tan(kind, sp, table, pixel) - tan_a
                    if abs(h_res) < 1e-13:
                        break
                    if outer == 0 or h_res == h_prev:
                        x_new = tan_a + h_res
                    else:
                        x_new = tan_a - h_res * (tan_a - x_prev) / (h_res - h_prev)
                    x_prev = tan_a
                    h_prev = h_res
                    tan_a = x_new
                if status != OK:
                    out_status[q] = status | flag
                    continue
                t_line = t - (pixel - sp[0]) * sp[4] if kind == 0 else t
                line = time_to_line(t_line, lt0, lrate, ltable)
                if pixel < -0.5 or pixel > npix - 0.5:
                    out_status[q] = OUTSIDE_SWATH | flag
                    continue
                if line < -0.5 or line > n_lines - 0.5:
                    out_status[q] = NOT_SEEN | flag
                    continue
                out_line[q] = line
                out_pixel[q] = pixel
                out_status[q] = flag
                break


@nb.njit(parallel=True, cache=True)
def refine_kernel(points, guess_line, guess_pixel, t0, dt, coef, lever, R_BS, toff, kind, sp, table,
                  lt0, lrate, ltable, n_lines, tol_t, max_step_t, max_iter, n_chunks,
                  out_line, out_pixel, out_status, out_steps):
    """Ground -> image by Newton on time from a guess of (line, pixel) per point, no bracketing.

    For strips whose scan plane sweeps the ground monotonically (no over-scanning) the scan-plane
    condition has one root per point, so Newton started near it converges to the same solution
    as the bracketed ``ground_to_image_kernel``, quadratically and without its search. A point
    whose iteration takes a step longer than ``max_step_t`` seconds, or has not converged after
    ``max_iter`` evaluations, gets NO_CONVERGENCE: the caller solves it with the bracketed
    kernel. ``out_steps`` holds each point's evaluations. For pushbroom look-angle tables (whose
    along-track angle varies with the pixel) the condition at time t uses the angle of the pixel
    the point falls on at t, and its derivative includes that angle's change, so the iteration
    stays quadratic.
    """
    n = points.shape[0]
    chunk = (n + n_chunks - 1) // n_chunks
    npix = sp[sp.shape[0] - 1] if kind != 1 else sp[0]
    for c in nb.prange(n_chunks):
        R, dR, p, dp = _pose_buffers()
        for q in range(c * chunk, min(n, (c + 1) * chunk)):
            P = points[q]
            out_line[q] = np.nan
            out_pixel[q] = np.nan
            out_status[q] = NO_CONVERGENCE
            out_steps[q] = 0
            gl = guess_line[q]
            gp = guess_pixel[q]
            if not (np.isfinite(P[0]) and np.isfinite(P[1]) and np.isfinite(P[2]) and np.isfinite(gl)
                    and np.isfinite(gp)):
                continue
            gp = min(max(gp, -0.5), npix - 0.5)
            t = line_to_time(gl, lt0, lrate, ltable)
            if kind == 0:
                t += (gp - sp[0]) * sp[4]
            done = False
            h = 0.0
            eps = 1e-6
            for it in range(max_iter):
                spline_pose(t, t0, dt, coef, lever, R_BS, toff, R, p, dR, dp)
                out_steps[q] = it + 1
                vx = 0.0
                vy = 0.0
                vz = 0.0
                dvx = 0.0
                dvy = 0.0
                dvz = 0.0
                for i in range(3):
                    d = P[i] - p[i]
                    vx += R[i, 0] * d
                    vy += R[i, 1] * d
                    vz += R[i, 2] * d
                    dvx += dR[i, 0] * d - R[i, 0] * dp[i]
                    dvy += dR[i, 1] * d - R[i, 1] * dp[i]
                    dvz += dR[i, 2] * d - R[i, 2] * dp[i]
                if not vz > 0:
                    break
                # the scan-plane condition of the pixel the point falls on at time t:
                # f = vx - tan_a(pixel(vy / vz)) vz, with the derivative of tan_a through the pixel
                tan_a = 0.0
                dtan = 0.0
                if kind != 0:
                    tx = vy / vz
                    tan_a = sensor_along_tan(kind, sp, table, sensor_pixel(kind, sp, table, tx, 1.0))
                    if kind == 1:
                        up = sensor_along_tan(kind, sp, table, sensor_pixel(kind, sp, table, tx + eps, 1.0))
                        dn = sensor_along_tan(kind, sp, table, sensor_pixel(kind, sp, table, tx - eps, 1.0))
                        dtan = (up - dn) / (2 * eps) * (dvy * vz - vy * dvz) / (vz * vz)
                f = vx - tan_a * vz
                df = dvx - tan_a * dvz - dtan * vz
                if df == 0.0 or not np.isfinite(f):
                    break
                h = -f / df
                if abs(h) > max_step_t:
                    break
                if abs(h) < tol_t:
                    done = True
                    break
                t += h
            if not done:
                continue
            # the pose at t + h to first order (|h| < tol_t), as in ground_to_image_kernel
            vy, vz = _view_yz(P, R, p, dR, dp, h)
            t += h
            if vz <= 0:
                out_status[q] = BEHIND
                continue
            pixel = sensor_pixel(kind, sp, table, vy, vz)
            t_line = t - (pixel - sp[0]) * sp[4] if kind == 0 else t
            line = time_to_line(t_line, lt0, lrate, ltable)
            if pixel < -0.5 or pixel > npix - 0.5:
                out_status[q] = OUTSIDE_SWATH
                out_line[q] = line
                out_pixel[q] = pixel
                continue
            if line < -0.5 or line > n_lines - 0.5:
                out_status[q] = NOT_SEEN
                out_line[q] = line
                out_pixel[q] = pixel
                continue
            out_line[q] = line
            out_pixel[q] = pixel
            out_status[q] = OK
