"""Compiled ground -> image for whiskbroom scanners by interpolated scan-plane conditions (numba).

For a whiskbroom the three quantities that decide where a ground point ``P`` is imaged are linear in
``P`` at any sensor time t: the scan-plane condition ``g(t) = R_PS[:,0](t) . (P - p_S(t))`` (zero when
``P`` is in the scan plane), and the sensor-frame coordinates ``vy, vz`` of ``P`` (its look angle
``atan2(vy, vz)`` gives the pixel). Each is ``a(t) . P - c(t)``. ``whiskbroom_tables`` evaluates the
full model (orientation spline, lever arm, boresight, time offset) for the rows ``a, c`` and their
time derivatives at coarse epochs aligned with the spline's knots (at least one per image line), so
that between two epochs every row is a smooth function (no knot inside) and its cubic Hermite
interpolant is accurate to about 1e-9 lines for airborne dynamics. The kernel brackets the
crossing on the coarse epochs (warm-started from the previous point, or from the strip-wide linear
guess), solves the Hermite cubic of ``g`` for the time, and interpolates ``vy, vz`` there: no spline
evaluation and no trigonometric function other than the look angle's ``atan2`` per point.

The interpolation error of each interval is measured when the tables are built (the exact rows at
the interval's middle against the interpolant, where a Hermite error is largest) and bounded per
point by ``err[k, 0] * range + err[k, 1]`` metres; a point whose bound, converted to lines and pixels,
exceeds ``tol_line`` (or whose cubic is not monotonic in the interval, or does not converge) is
solved exactly by safeguarded Newton on time with the spline pose, by ``kernels.ground_to_image_kernel``'s
solver. Over-scanning strips (``window > 0``) search their crossings
as that kernel does; every crossing is solved as above. Per-pixel timing: the line is the time of
the solution minus the pixel's time offset within the scan.
"""
from __future__ import annotations

import math

import numba as nb
import numpy as np

from scangeo.sensors.kernels import (
    BEHIND,
    MAX_CROSSINGS,
    MULTIPLE,
    NO_CONVERGENCE,
    NOT_SEEN,
    OK,
    OUTSIDE_SWATH,
    _find_crossings,
    _solve_in,
    _view_yz,
    line_to_time,
    time_to_line,
)

#: rows of the table: g, dg/dt, vy, dvy/dt, vz, dvz/dt; each (a0, a1, a2, c) for a . P - c
N_ROWS = 6
#: safety factor on the interval error measured at the middle (Hermite errors peak there)
ERROR_SAFETY = 2.0


def _rows(p, R, dp, dR):
    """(n, 6, 4) rows a . P - c of g, vy, vz (sensor axes 0, 1, 2) and their time derivatives."""
    tab = np.empty((len(p), N_ROWS, 4))
    for c in range(3):
        a, da = R[:, :, c], dR[:, :, c]
        tab[:, 2 * c, :3] = a
        tab[:, 2 * c, 3] = np.einsum("ki,ki->k", a, p)
        tab[:, 2 * c + 1, :3] = da
        tab[:, 2 * c + 1, 3] = np.einsum("ki,ki->k", da, p) + np.einsum("ki,ki->k", a, dp)
    return tab


def whiskbroom_tables(pose, spline_t0: float, spacing: float, time_offset: float, rate: float,
                      t_first: float, t_last: float):
    """Coarse epochs, rows and per-interval error coefficients for ``whiskbroom_ground_to_image``.

    ``pose(times)`` returns the exact ``p, R, dp, dR`` (e.g. ``StripGeometry.pose(t, derivatives=True)``);
    the epochs (sensor time) divide every knot interval of the spline (navigation time
    ``spline_t0 + i * spacing``, sensor time minus ``time_offset``) into ``ceil(spacing * rate)``
    parts, and cover ``[t_first, t_last]``. Returns ``times (M,), tab (M, 6, 4), err (M - 1, 2)``.
    """
    parts = max(1, int(math.ceil(spacing * rate - 1e-9)))
    step = spacing / parts
    base = spline_t0 - time_offset
    i0 = math.floor((t_first - base) / step)
    i1 = math.ceil((t_last - base) / step)
    times = base + np.arange(i0, max(i1, i0 + 2) + 1) * step
    p, R, dp, dR = pose(times)
    tab = _rows(p, R, dp, dR)
    mid = 0.5 * (times[:-1] + times[1:])
    p_m, R_m, dp_m, dR_m = pose(mid)
    exact = _rows(p_m, R_m, dp_m, dR_m)
    h = np.diff(times)[:, None, None]
    # Hermite interpolant at s = 1/2 of the value rows (0, 2, 4) from values and derivatives
    vals, ders = tab[:, 0::2], tab[:, 1::2]
    interp = 0.5 * (vals[:-1] + vals[1:]) + h / 8.0 * (ders[:-1] - ders[1:])
    e = interp - exact[:, 0::2]
    ea = np.linalg.norm(e[:, :, :3], axis=2)  # (M-1, 3): per metre of range
    e0 = np.abs(np.einsum("kri,ki->kr", e[:, :, :3], p_m) - e[:, :, 3])
    # |P - p_m| <= range seen at the solution + the sensor's travel within the interval
    travel = np.linalg.norm(np.diff(p, axis=0), axis=1)
    err = np.column_stack([ea.max(axis=1), e0.max(axis=1) + ea.max(axis=1) * travel]) * ERROR_SAFETY
    return times, tab, err


@nb.njit(inline="always", cache=True)
def _row(tab, k, r, X, Y, Z):
    return tab[k, r, 0] * X + tab[k, r, 1] * Y + tab[k, r, 2] * Z - tab[k, r, 3]


@nb.njit(inline="always", cache=True)
def _g(gtab, k, X, Y, Z):
    return gtab[k, 0] * X + gtab[k, 1] * Y + gtab[k, 2] * Z - gtab[k, 3]


@nb.njit(inline="always", cache=True)
def _bracket(gtab, M, k_start, X, Y, Z):
    """Interval lo with g(lo) >= 0 > g(lo + 1), galloping from k_start then bisecting
    (g(0) >= 0 > g(M - 1) must hold)."""
    k = min(max(k_start, 0), M - 2)
    if _g(gtab, k, X, Y, Z) >= 0:
        lo = k
        step = 1
        hi = min(M - 1, lo + step)
        while _g(gtab, hi, X, Y, Z) >= 0:
            lo = hi
            step *= 2
            hi = min(M - 1, lo + step)
    else:
        hi = k
        step = 1
        lo = max(0, hi - step)
        while _g(gtab, lo, X, Y, Z) < 0:
            hi = lo
            step *= 2
            lo = max(0, hi - step)
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if _g(gtab, mid, X, Y, Z) >= 0:
            lo = mid
        else:
            hi = mid
    return lo


@nb.njit(inline="always", cache=True)
def _hermite_root(ga, gb, ma, mb):
    """(s, dH/ds there, converged) for the root in [0, 1] of the cubic Hermite interpolant of g
    (values ga, gb of opposite signs, derivatives ma, mb per interval) by Newton from the secant;
    not converged when the cubic is not monotonic (g may cross zero more than once in the interval)."""
    s = ga / (ga - gb)
    slope = 0.0
    if not _monotonic(ga, gb, ma, mb):
        return s, slope, False
    for _ in range(8):
        s2 = s * s
        s3 = s2 * s
        hv = (2 * s3 - 3 * s2 + 1) * ga + (s3 - 2 * s2 + s) * ma + (3 * s2 - 2 * s3) * gb + (s3 - s2) * mb
        slope = (6 * s2 - 6 * s) * (ga - gb) + (3 * s2 - 4 * s + 1) * ma + (3 * s2 - 2 * s) * mb
        if slope == 0.0:
            break
        step = hv / slope
        s -= step
        if not (0.0 <= s <= 1.0):
            break
        if abs(step) < 1e-9:
            return s, slope, True
    return s, slope, False


@nb.njit(inline="always", cache=True)
def _hermite_view(tab, k, s, h, X, Y, Z):
    """vy, vz at s in interval k by their cubic Hermite interpolants."""
    s2 = s * s
    s3 = s2 * s
    h00 = 2 * s3 - 3 * s2 + 1
    h10 = (s3 - 2 * s2 + s) * h
    h01 = 3 * s2 - 2 * s3
    h11 = (s3 - s2) * h
    vy = (h00 * _row(tab, k, 2, X, Y, Z) + h10 * _row(tab, k, 3, X, Y, Z)
          + h01 * _row(tab, k + 1, 2, X, Y, Z) + h11 * _row(tab, k + 1, 3, X, Y, Z))
    vz = (h00 * _row(tab, k, 4, X, Y, Z) + h10 * _row(tab, k, 5, X, Y, Z)
          + h01 * _row(tab, k + 1, 4, X, Y, Z) + h11 * _row(tab, k + 1, 5, X, Y, Z))
    return vy, vz


@nb.njit(inline="always", cache=True)
def _monotonic(ga, gb, ma, mb):
    """True if the cubic Hermite interpolant (values ga, gb of opposite signs, derivatives ma, mb per
    interval) is strictly monotonic on [0, 1]: its derivative, a quadratic, keeps the sign of gb - ga."""
    if ga < gb:
        ga, gb, ma, mb = -ga, -gb, -ma, -mb
    if not (ma < 0 and mb < 0):
        return False
    d = ga - gb
    qa = 6 * d + 3 * (ma + mb)
    qb = -6 * d - 4 * ma - 2 * mb
    if qa < 0:
        sv = -qb / (2 * qa)
        if 0 < sv < 1 and ma - qb * qb / (4 * qa) >= 0:
            return False
    return True


@nb.njit(inline="always", cache=True)
def _solve_interval(points, q, k, ga, gb, times, tab, err, cA, cC, t0, dt, coef, lever, R_BS, toff, tol_line, tol_t,
                    ifov, R, p, dR, dp):
    """(t, vy, vz, exact) of point q crossing the scan plane in interval k (g values ga, gb): by the
    interpolants when their error bound is within ``tol_line`` pixels and ``tol_t`` seconds, else by
    safeguarded Newton on the spline (``exact`` True); t NaN if that fails."""
    X, Y, Z = points[q, 0], points[q, 1], points[q, 2]
    h = times[k + 1] - times[k]
    s, slope, converged = _hermite_root(ga, gb, _row(tab, k, 1, X, Y, Z) * h, _row(tab, k + 1, 1, X, Y, Z) * h)
    if converged:
        vy, vz = _hermite_view(tab, k, s, h, X, Y, Z)
        rng = math.sqrt(vy * vy + vz * vz)
        bound = err[k, 0] * rng + err[k, 1]  # metres in g, vy, vz
        # in time (through the condition's rate of change) and in pixels (through the range)
        if vz > 0 and bound * h <= tol_t * abs(slope) and bound <= tol_line * ifov * rng:
            return times[k] + s * h, vy, vz, False
    t, t_ev = _solve_in(k, points[q], 0.0, 0.0, times, cA, cC, t0, dt, coef, lever, R_BS, toff, tol_t, R, p, dR, dp)
    if np.isnan(t):
        return t, np.nan, np.nan, True
    vy, vz = _view_yz(points[q], R, p, dR, dp, t - t_ev)
    return t, vy, vz, True


@nb.njit(parallel=True, cache=True)
def whiskbroom_ground_to_image(points, times, tab, gtab, err, cA, cC, window, t0, dt, coef, lever, R_BS, toff,
                               sp, lt0, lrate, ltable, n_lines, tol_line, tol_t, n_chunks,
                               out_line, out_pixel, out_status, out_exact):
    """(line, pixel, status) of ground points (n, 3) in the project frame seen by a whiskbroom.

    ``times, tab, err`` from ``whiskbroom_tables``; ``gtab``: a contiguous copy of the g rows
    ``tab[:, 0]`` (M, 4) for the bracketing (compact: it stays in cache for points in random order),
    ``cA, cC``: its columns :3 and 3 for the over-scanning search and the exact solver; ``window`` as in
    ``kernels.ground_to_image_kernel`` (0: one crossing per point). ``tol_line``: largest
    interpolation error accepted, in pixels and (as ``tol_t`` seconds) in lines; ``tol_t`` is also
    the last Newton step of an exact solution. ``out_exact[q]`` is 1 where the exact solution was needed.
    """
    n = points.shape[0]
    M = times.shape[0]
    chunk = (n + n_chunks - 1) // n_chunks
    npix = sp[sp.shape[0] - 1]
    pp, ifov, direction, theta0, dt_pix = sp[0], sp[1], sp[2], sp[3], sp[4]
    for c in nb.prange(n_chunks):
        R = np.empty((3, 3))
        dR = np.empty((3, 3))
        p = np.empty(3)
        dp = np.empty(3)
        crossings = np.empty(MAX_CROSSINGS, dtype=np.int64)
        k_warm = -1000000
        for q in range(c * chunk, min(n, (c + 1) * chunk)):
            X = points[q, 0]
            Y = points[q, 1]
            Z = points[q, 2]
            out_line[q] = np.nan
            out_pixel[q] = np.nan
            out_status[q] = NOT_SEEN
            out_exact[q] = 0
            if not (math.isfinite(X) and math.isfinite(Y) and math.isfinite(Z)):
                continue
            flag = 0
            if window == 0:
                g0 = _g(gtab, 0, X, Y, Z)
                gM = _g(gtab, M - 1, X, Y, Z)
                if not (g0 >= 0 and gM < 0):
                    continue
                # start at the previous point's interval when near, else at the strip-wide linear guess
                k_lin = int(g0 / (g0 - gM) * (M - 1))
                start = k_warm if abs(k_lin - k_warm) <= 32 else k_lin
                crossings[0] = _bracket(gtab, M, start, X, Y, Z)
                count = 1
            else:
                count, sightings = _find_crossings(points[q], cA, cC, max(k_warm, 0), window, crossings)
                if sightings > 1:
                    flag = MULTIPLE
            if count > 0:
                k_warm = crossings[0]
            for ci in range(count):
                k = crossings[ci]
                ga = _row(tab, k, 0, X, Y, Z)
                gb = _row(tab, k + 1, 0, X, Y, Z)
                t, vy, vz, exact = _solve_interval(points, q, k, ga, gb, times, tab, err, cA, cC, t0, dt, coef, lever,
                                                   R_BS, toff, tol_line, tol_t, ifov, R, p, dR, dp)
                out_exact[q] = exact
                if np.isnan(t):
                    out_status[q] = NO_CONVERGENCE | flag
                    continue
                if vz <= 0:
                    out_status[q] = BEHIND | flag
                    continue
                pixel = pp + direction * (math.atan2(vy, vz) - theta0) / ifov
                line = time_to_line(t - (pixel - pp) * dt_pix, lt0, lrate, ltable)
                if pixel < -0.5 or pixel > npix - 0.5:
                    out_status[q] = OUTSIDE_SWATH | flag
                    continue
                if line < -0.5 or line > n_lines - 0.5:
                    out_status[q] = NOT_SEEN | flag
                    continue
                out_line[q] = line
                out_pixel[q] = pixel
                out_status[q] = OK | flag
                break


@nb.njit(parallel=True, cache=True)
def whiskbroom_ground_to_image_near(points, guess_line, guess_pixel, times, tab, err, cA, cC, t0, dt, coef, lever, R_BS,
                                    toff, sp, lt0, lrate, ltable, n_lines, tol_line, tol_t, max_step_t, max_iter,
                                    n_chunks, out_line, out_pixel, out_status, out_steps):
    """``kernels.refine_kernel`` (ground -> image from a guess of (line, pixel), strips without
    over-scanning) by the interpolated conditions: the coarse interval is taken from the guess's time
    (the epochs are uniform) and moved by secant jumps (bisection when they leave the bracket found so
    far) to the one holding the sign change, each jump cut to ``max_step_t`` seconds, at most
    ``max_iter`` intervals looked at, else NO_CONVERGENCE; then as
    ``whiskbroom_ground_to_image`` (exact Newton where the bound exceeds the tolerance).
    ``out_steps``: condition evaluations (intervals looked at, plus 3 for an exact solution).
    Outside the swath or beyond the ends the (line, pixel) is kept with the status saying so, except
    for points that cross no scan plane within the epochs (far beyond the ends): NOT_SEEN, NaN.
    """
    n = points.shape[0]
    M = times.shape[0]
    step_e = times[1] - times[0]
    max_walk = int(max_step_t / step_e) + 1
    chunk = (n + n_chunks - 1) // n_chunks
    npix = sp[sp.shape[0] - 1]
    pp, ifov, direction, theta0, dt_pix = sp[0], sp[1], sp[2], sp[3], sp[4]
    for c in nb.prange(n_chunks):
        R = np.empty((3, 3))
        dR = np.empty((3, 3))
        p = np.empty(3)
        dp = np.empty(3)
        for q in range(c * chunk, min(n, (c + 1) * chunk)):
            X = points[q, 0]
            Y = points[q, 1]
            Z = points[q, 2]
            out_line[q] = np.nan
            out_pixel[q] = np.nan
            out_status[q] = NO_CONVERGENCE
            out_steps[q] = 0
            gl = guess_line[q]
            gp = guess_pixel[q]
            if not (math.isfinite(X) and math.isfinite(Y) and math.isfinite(Z) and math.isfinite(gl)
                    and math.isfinite(gp)):
                continue
            if not (_row(tab, 0, 0, X, Y, Z) >= 0 and _row(tab, M - 1, 0, X, Y, Z) < 0):
                out_status[q] = NOT_SEEN  # no crossing within the epochs: beyond the strip's ends
                continue
            gp = min(max(gp, -0.5), npix - 0.5)
            t_guess = line_to_time(gl, lt0, lrate, ltable) + (gp - pp) * dt_pix
            k = min(max(int(math.floor((t_guess - times[0]) / step_e)), 0), M - 2)
            # g(k_pos) >= 0 and g(k_neg) < 0 once seen: the crossing lies between
            k_pos, g_pos, k_neg, g_neg = -1, 0.0, -1, 0.0
            found = False
            side = 0
            for _ in range(max_iter):
                out_steps[q] += 1
                ga = _row(tab, k, 0, X, Y, Z)
                gb = _row(tab, k + 1, 0, X, Y, Z)
                if ga >= 0 and gb < 0:
                    found = True
                    break
                if ga < 0:
                    k_neg, g_neg = k, ga
                    if side == -1:
                        g_pos *= 0.5  # Illinois: the other side's value halved when one side repeats
                    side = -1
                else:
                    k_pos, g_pos = k + 1, gb
                    if side == 1:
                        g_neg *= 0.5
                    side = 1
                if k_pos >= 0 and k_neg >= 0:
                    if k_neg <= k_pos:
                        break  # g not monotonic: over-scanning
                    # linear interpolation between the two sides (regula falsi, Illinois)
                    k = int(math.floor(k_pos + g_pos / (g_pos - g_neg) * (k_neg - k_pos)))
                    k = min(max(k, k_pos), k_neg - 1)
                else:
                    # secant jump to where g's linear extension crosses zero (one interval at least),
                    # cut to max_step_t
                    dk = ga / (ga - gb) if ga != gb else 0.0
                    dk = min(max(dk, -max_walk), max_walk) if dk == dk else 0.0
                    k += min(-1, int(math.floor(dk))) if ga < 0 else max(1, int(math.floor(dk)))
                    k = min(max(k, 0), M - 2)
            if not found:
                continue
            t, vy, vz, exact = _solve_interval(points, q, k, ga, gb, times, tab, err, cA, cC, t0, dt, coef, lever,
                                               R_BS, toff, tol_line, tol_t, ifov, R, p, dR, dp)
            if exact:
                out_steps[q] += 3
            if np.isnan(t):
                continue
            if vz <= 0:
                out_status[q] = BEHIND
                continue
            pixel = pp + direction * (math.atan2(vy, vz) - theta0) / ifov
            line = time_to_line(t - (pixel - pp) * dt_pix, lt0, lrate, ltable)
            out_line[q] = line
            out_pixel[q] = pixel
            if pixel < -0.5 or pixel > npix - 0.5:
                out_status[q] = OUTSIDE_SWATH
            elif line < -0.5 or line > n_lines - 0.5:
                out_status[q] = NOT_SEEN
            else:
                out_status[q] = OK
