"""The whiskbroom ground -> image kernel (interpolated conditions, both cores) against truth and
against the bracketed Newton kernel (``kernels.ground_to_image_kernel``) it replaces for whiskbrooms."""
from __future__ import annotations

import numba
import numpy as np
import pytest

from scangeo.sensors import StripGeometry, Whiskbroom
from scangeo.sensors import kernels as K
from scangeo.sensors.strip import Mounting
from scangeo.timing import LineTiming
from scangeo.trajectory import OrientationSpline


def _turbulent_strip(n_lines: int, spacing: float = 0.2, periods=(3.1, 7.3, 17.0), amp_deg=(1.5, 0.6, 0.45),
                     mounting: Mounting | None = None) -> StripGeometry:
    """A north-bound 67 m/s line, roll, pitch and heading turbulence of amplitudes ``amp_deg``."""
    rng = np.random.default_rng(1)
    duration = n_lines / 25.0 + 4.0
    t = np.arange(0.0, duration, min(0.02, spacing / 4))

    def turb(amp, ps):
        return sum(np.radians(amp) * rng.uniform(0.3, 1) * np.sin(2 * np.pi * t / p + rng.uniform(0, 6)) for p in ps)

    values = np.column_stack([
        5 * np.sin(t / 30), -duration * 67 / 2 + 67 * t, 2300 + 3 * np.sin(t / 7),
        turb(amp_deg[0], periods), turb(amp_deg[1], periods[:2]), np.radians(0.5) + turb(amp_deg[2], periods[1:]),
    ])
    return StripGeometry(Whiskbroom(), OrientationSpline.fit(t, values, spacing), LineTiming(2.0, 25.0), n_lines,
                         mounting)


def _points(strip: StripGeometry, n: int, seed: int = 0):
    """Ground points of known (line, pixel): random image positions taken to 0-300 m along their rays."""
    rng = np.random.default_rng(seed)
    lines = rng.uniform(0, strip.n_lines - 1, n)
    pixels = rng.uniform(0, strip.sensor.pixels - 1, n)
    o, d = strip.rays(lines, pixels)
    lam = (o[:, 2] - rng.uniform(0, 300, n)) / -d[:, 2]
    return o + lam[:, None] * d, lines, pixels


def _previous(strip: StripGeometry, P: np.ndarray, tol_line: float):
    """The bracketed Newton kernel on the strip's line-spaced coarse poses (as ground_to_image did)."""
    times, R, p, _, _ = strip._coarse
    kind, sp, table = strip.sensor.kernel_params()
    cA = np.ascontiguousarray(R[:, :, 0])
    n = len(P)
    line, pixel, status = np.empty(n), np.empty(n), np.empty(n, dtype=np.int64)
    K.ground_to_image_kernel(np.ascontiguousarray(P), *strip._mount_args(), kind, sp, table, *strip._timing_args(),
                             float(strip.n_lines), times, cA, np.einsum("ki,ki->k", cA, p), strip.overscan_window(P),
                             tol_line / strip.timing.mean_rate, 256, line, pixel, status)
    return line, pixel, status


@pytest.fixture(scope="module")
def strip():
    mounting = Mounting(np.array([0.4, -0.2, 0.9]), np.radians([0.3, -0.2, 0.5]), 0.012)
    return _turbulent_strip(3000, mounting=mounting)


@pytest.mark.parametrize("order", ["along-track", "random"])
def test_matches_truth_and_the_previous_kernel(strip, order):
    P, lines, pixels = _points(strip, 200_000)
    if order == "along-track":
        idx = np.argsort(lines)
        P, lines, pixels = np.ascontiguousarray(P[idx]), lines[idx], pixels[idx]
    line, pixel, status = strip.ground_to_image(P, tol_line=1e-4)
    assert (status == K.OK).all()
    assert np.abs(line - lines).max() <= 1e-4
    assert np.abs(pixel - pixels).max() <= 1e-4
    pl, pp, ps = _previous(strip, P, 1e-6)  # the previous kernel's own error is up to its tolerance
    assert (ps == status).all()
    assert np.abs(line - pl).max() <= 1e-5 and np.abs(pixel - pp).max() <= 1e-5
    # the default tolerance of 1e-6 lines is met too (by the per-point bound, or the exact solution
    # whose Newton iteration ends on a step in time, as before: its pixel error can reach 2e-6)
    line, pixel, status = strip.ground_to_image(P)
    assert np.abs(line - lines).max() <= 1e-6 and np.abs(pixel - pixels).max() <= 1e-5


def test_statuses_outside_the_image_equal_the_previous_kernel(strip):
    P, lines, pixels = _points(strip, 20_000, seed=3)
    rng = np.random.default_rng(4)
    # shifted across track beyond the swath, before and after the strip, NaNs
    P[:5000, 0] += rng.choice([-1, 1], 5000) * rng.uniform(1000, 3000, 5000)
    P[5000:7000, 1] -= rng.uniform(0, 500, 2000) + lines[5000:7000] * 2.7
    P[7000:9000, 1] += rng.uniform(0, 500, 2000) + (strip.n_lines - lines[7000:9000]) * 2.7
    P[9000:9010] = np.nan
    line, pixel, status = strip.ground_to_image(P, tol_line=1e-4)
    pl, pp, ps = _previous(strip, P, 1e-4)
    assert (status == ps).all()
    assert {K.OK, K.OUTSIDE_SWATH, K.NOT_SEEN} <= set(np.unique(status))
    ok = status == K.OK
    assert np.abs(line[ok] - pl[ok]).max() <= 1e-4 and np.isnan(line[~ok]).all()


def test_same_result_on_one_thread(strip):
    P, _, _ = _points(strip, 50_000, seed=5)
    two = strip.ground_to_image(P)
    n_threads = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        one = strip.ground_to_image(P)
    finally:
        numba.set_num_threads(n_threads)
    for a, b in zip(one, two):
        np.testing.assert_array_equal(a, b)


def test_fast_dynamics_fall_back_to_the_exact_solution():
    """Knots every 0.04 s, roll of 1 deg at 0.4-0.8 s periods (pitch and heading 0.02 deg: no
    over-scanning): the interpolated look direction errs by up to 6e-6 px, so the per-point bound
    sends points to the exact solution as the tolerance tightens; all stay within it."""
    strip = _turbulent_strip(600, spacing=0.04, periods=(0.4, 0.6, 0.8), amp_deg=(1.0, 0.02, 0.02))
    P, lines, pixels = _points(strip, 50_000, seed=6)
    sp = strip.sensor.kernel_params()[1]
    assert strip.overscan_window(P) == 0
    n_exact = {}
    for tol in (1e-3, 1e-5, 1e-6):
        line, pixel, status, exact = strip._whiskbroom_ground_to_image(P, sp, tol)
        assert (status == K.OK).all()
        assert np.abs(line - lines).max() <= tol and np.abs(pixel - pixels).max() <= max(tol, 1e-5)
        n_exact[tol] = int(exact.sum())
        if tol == 1e-3:  # interpolation alone: above 1e-6 px somewhere
            assert np.abs(pixel - pixels).max() > 1e-6
    assert n_exact[1e-3] < n_exact[1e-5] < n_exact[1e-6]


def test_near_from_guesses_matches_truth_and_the_newton_kernel(strip):
    """ground_to_image_near (the refined inverse map's call) from guesses up to 20 lines and pixels
    off: the interpolated kernel against truth, and against Newton on the spline (refine_kernel)."""
    P, lines, pixels = _points(strip, 100_000, seed=7)
    rng = np.random.default_rng(8)
    gl = lines + rng.uniform(-20, 20, len(P))
    gp = pixels + rng.uniform(-20, 20, len(P))
    line, pixel, status, steps = strip.ground_to_image_near(P, gl, gp, tol_line=1e-4)
    assert (status == K.OK).all() and steps.min() >= 1
    assert np.abs(line - lines).max() <= 1e-4 and np.abs(pixel - pixels).max() <= 1e-4
    kind, sp, table = strip.sensor.kernel_params()
    n = len(P)
    ln, px, st, ev = np.empty(n), np.empty(n), np.empty(n, dtype=np.int64), np.empty(n, dtype=np.int64)
    K.refine_kernel(P, gl, gp, *strip._mount_args(), kind, sp, table, *strip._timing_args(), float(strip.n_lines),
                    1e-4 / 25.0, 64 / 25.0, 8, 256, ln, px, st, ev)
    ok = st == K.OK
    assert ok.mean() > 0.99 and np.abs(line[ok] - ln[ok]).max() <= 1e-4
    # too far from the guess for max_iter jumps of at most max_step_lines: no convergence
    inner = np.flatnonzero(lines > 300)[:100]
    far = strip.ground_to_image_near(P[inner], lines[inner] - 200, pixels[inner], max_step_lines=10.0, max_iter=4)[2]
    assert (far == K.NO_CONVERGENCE).all()
