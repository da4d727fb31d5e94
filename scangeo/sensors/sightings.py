"""The sighting of a ground point nearest an image position, where the over-scanning mirror sees it
more than once (:meth:`scangeo.sensors.strip.StripGeometry.nearest_sighting`).

A rotating mirror's scan lines overlap at the swath's edges when the pitch rate (or the heading rate)
runs against the flight: a ground point there is seen by two or three scans, in the true orientation
as in an adjusted one. ``ground_to_image`` keeps the first sighting in time, which can be scans away
from where the point was measured (vienna2000 seed 37: 20 lines at one edge sample of 780). A
residual or an error at a measured image position is that of the sighting standing for the
measurement: the one nearest it. The true error of a simulated project (:mod:`scangeo.truth`) and
the check-point residuals of an adjustment (:mod:`scangeo.adjustment.results`) both take it.
"""
from __future__ import annotations

from typing import Protocol

import numpy as np

from scangeo.sensors.kernels import MULTIPLE, OK, OUTSIDE_SWATH
from scangeo.sensors.models import SensorModel


class StripGeometry(Protocol):
    """What the search needs of :class:`scangeo.sensors.strip.StripGeometry` (which calls it)."""

    sensor: SensorModel
    n_lines: int

    def pose(self, t: np.ndarray, derivatives: bool = False): ...

    def time_of(self, line, pixel) -> np.ndarray: ...

    def ground_to_image(self, p_P: np.ndarray, tol_line: float = 1e-6): ...

#: lines searched either side of a sample for its own sighting, and the step of that search (lines)
SIGHTING_WINDOW, SIGHTING_STEP = 64, 0.25


def _scan_condition(geometry: StripGeometry, p_P: np.ndarray, line: np.ndarray, pixel: np.ndarray):
    """The along-track condition ``g = v_x / v_z - tan(along(pixel))`` of points ``p_P`` (n, 3) at lines
    ``line`` (n, k), with the pixel their direction gives there (two passes: a whiskbroom pixel's time
    depends on the pixel); returns (g, pixel), both (n, k)."""
    n, k = line.shape
    P = np.repeat(p_P, k, axis=0)
    px = np.repeat(pixel, k) if np.ndim(pixel) == 1 else pixel.ravel()
    for _ in range(2):
        p_S, R = geometry.pose(geometry.time_of(line.ravel(), px))
        v = np.einsum("nji,nj->ni", R, P - p_S)
        px = geometry.sensor.pixel_of(v)
    g = v[:, 0] / v[:, 2] - np.tan(geometry.sensor.along_angle(px))
    return g.reshape(n, k), px.reshape(n, k)


def _nearest_root(geometry: StripGeometry, P: np.ndarray, px0: np.ndarray, centre: np.ndarray, half: float,
                  step: float) -> np.ndarray:
    """The line of the sighting of each point ``P`` nearest to ``centre`` within ``half`` lines of it (NaN
    where none): the sign changes of the scan-plane condition over lines ``step`` apart, refined by
    bisection, and the tangent sightings (the scan line turns back just there: a local minimum of ``|g|``
    that reaches zero), refined by golden section."""
    grid = centre[:, None] + np.arange(-half, half + step / 2, step)[None, :]

    def cond(at):
        return _scan_condition(geometry, P, at[:, None], px0)[0][:, 0]

    g, _ = _scan_condition(geometry, P, grid, px0)
    ok = np.isfinite(g)
    dist = np.abs(grid - centre[:, None])
    rows = np.arange(len(P))
    change = ok[:, :-1] & ok[:, 1:] & (np.sign(g[:, :-1]) != np.sign(g[:, 1:]))
    k = np.argmin(np.where(change, np.minimum(dist[:, :-1], dist[:, 1:]), np.inf), axis=1)
    lo, hi, g_lo = grid[rows, k], grid[rows, k + 1], g[rows, k]
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        g_m = cond(mid)
        left = np.sign(g_m) == np.sign(g_lo)
        lo, g_lo, hi = np.where(left, mid, lo), np.where(left, g_m, g_lo), np.where(left, hi, mid)
    root = np.where(change.any(axis=1), 0.5 * (lo + hi), np.nan)
    a = np.abs(np.where(ok, g, np.inf))
    is_min = np.zeros_like(ok)
    is_min[:, 1:-1] = (a[:, 1:-1] <= a[:, :-2]) & (a[:, 1:-1] <= a[:, 2:]) & ok[:, 1:-1]
    k = np.clip(np.argmin(np.where(is_min, dist, np.inf), axis=1), 1, grid.shape[1] - 2)
    lo, hi = grid[rows, k - 1], grid[rows, k + 1]
    for _ in range(60):
        c, d = hi - 0.618034 * (hi - lo), lo + 0.618034 * (hi - lo)
        keep_left = np.abs(cond(c)) < np.abs(cond(d))
        lo, hi = np.where(keep_left, lo, c), np.where(keep_left, d, hi)
    touch = 0.5 * (lo + hi)
    touch = np.where(is_min.any(axis=1) & (np.abs(cond(touch)) < 1e-9), touch, np.nan)
    return np.where(np.isnan(root) | (np.abs(touch - centre) < np.abs(root - centre)), touch, root)


def nearest_sighting(geometry: StripGeometry, p_P: np.ndarray, line: np.ndarray, pixel: np.ndarray):
    """(line, pixel, status) of project-frame points ``p_P`` (n, 3) in ``geometry``: of a point seen more
    than once, the sighting nearest to the image position ``(line, pixel)`` it was measured or sampled at
    (module docstring); of the others, ``ground_to_image``'s.

    For the points ``ground_to_image`` flags as seen more than once (``MULTIPLE``), every sighting
    within :data:`SIGHTING_WINDOW` lines of ``line`` is found (the sign changes of the scan-plane
    condition over lines :data:`SIGHTING_STEP` apart, refined by bisection, and the tangent ones where
    the scan line turns back, local minima of ``|g|`` that reach zero) and the nearest kept, ``MULTIPLE``
    still set. One just outside the swath keeps that status.
    """
    l_m, p_m, status = geometry.ground_to_image(p_P)
    again = np.flatnonzero((status & MULTIPLE) != 0)
    if not again.size:
        return l_m, p_m, status
    best = np.full(len(again), np.nan)
    for half, step in ((SIGHTING_WINDOW, SIGHTING_STEP), (1.0, SIGHTING_STEP / 32)):  # then finely near the sample
        m = _nearest_root(geometry, p_P[again], pixel[again], line[again], half, step)
        best = np.where(np.isnan(best) | (np.abs(m - line[again]) < np.abs(best - line[again])), m, best)
    found = np.isfinite(best)
    pts, m = again[found], best[found]
    px = _scan_condition(geometry, p_P[pts], m[:, None], pixel[pts])[1][:, 0]
    inside = (px >= -0.5) & (px <= geometry.sensor.pixels - 0.5) & (m >= -0.5) & (m <= geometry.n_lines - 0.5)
    l_m[pts], p_m[pts] = m, px
    status[pts] = np.where(inside, OK, OUTSIDE_SWATH) | MULTIPLE
    return l_m, p_m, status


__all__ = ["SIGHTING_STEP", "SIGHTING_WINDOW", "nearest_sighting"]
