"""The geometry of one strip: sensor model + orientation spline + mounting + line timing.

``StripGeometry`` answers image -> ground (rays intersected with the DTM) and ground -> image
(the time at which a ground point lies in the scan plane, then the pixel), vectorised, with a
status code per point whose text is ``STATUS[code]``; the bit ``MULTIPLE`` marks points seen more
than once (pitch-induced over-scanning; the first time is returned, and ``nearest_sighting`` the
sighting nearest a measured image position).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numba as nb
import numpy as np

from scangeo.dtm import DTM
from scangeo.rotation import small_rotation
from scangeo.sensors import kernels as K
from scangeo.sensors.ground_to_image_kernels import (
    whiskbroom_ground_to_image,
    whiskbroom_ground_to_image_near,
    whiskbroom_tables,
)
from scangeo.sensors.models import SensorModel
from scangeo.sensors.raycast import ray_cast_kernel
from scangeo.sensors.sightings import nearest_sighting
from scangeo.threading_layer import choose_threading_layer
from scangeo.timing import LineTiming
from scangeo.trajectory.spline import OrientationSpline

STATUS = {
    K.OK: "",
    K.NOT_SEEN: "not seen by the strip",
    K.OUTSIDE_SWATH: "outside the swath",
    K.BEHIND: "behind the sensor or below the terrain",
    K.NO_CONVERGENCE: "no convergence",
    K.LEAVES_DTM: "the ray leaves the DTM",
    K.NODATA: "the DTM has no data there",
    K.UPWARD: "the ray does not point downwards",
}
MULTIPLE = K.MULTIPLE


def status_text(codes: np.ndarray) -> list[str]:
    """Human-readable reasons for status codes (with the over-scanning flag)."""
    out = []
    for c in np.asarray(codes, dtype=int):
        text = STATUS.get(int(c) & ~MULTIPLE, f"status {c}")
        if c & MULTIPLE:
            text = (text + "; " if text else "") + "seen more than once (over-scanning), first kept"
        out.append(text)
    return out


@dataclass(frozen=True)
class Mounting:
    """Sensor mounting: lever arm (body frame, m), boresight angles (rad), time offset (s).

    ``R_BS = Rz(b[2]) Ry(b[1]) Rx(b[0])``; sensor pose ``p_S = p_nav + R_PB l_B``,
    ``R_PS = R_PB R_BS``; the navigation time of sensor time t is ``t + time_offset``.
    """

    lever_arm_B: np.ndarray = field(default_factory=lambda: np.zeros(3))
    boresight: np.ndarray = field(default_factory=lambda: np.zeros(3))
    time_offset: float = 0.0

    @property
    def R_BS(self) -> np.ndarray:
        return small_rotation(np.asarray(self.boresight, float))


@nb.njit(parallel=True, cache=True)
def _poses(times, t0, dt, coef, lever, R_BS, toff, R, p, dR, dp):
    for i in nb.prange(times.shape[0]):
        K.spline_pose(times[i], t0, dt, coef, lever, R_BS, toff, R[i], p[i], dR[i], dp[i])


class StripGeometry:
    """Geometry of one strip.

    Parameters
    ----------
    sensor : Whiskbroom or Pushbroom.
    spline : orientation spline of the navigation reference point (project frame).
    timing : line timing.
    n_lines : lines in the image.
    mounting : lever arm, boresight, time offset.
    """

    def __init__(self, sensor: SensorModel, spline: OrientationSpline, timing: LineTiming, n_lines: int,
                 mounting: Mounting | None = None, strip_id: str = "") -> None:
        self.sensor = sensor
        self.spline = spline
        self.timing = timing
        self.n_lines = int(n_lines)
        self.mounting = mounting or Mounting()
        self.strip_id = strip_id

    def release_tables(self) -> None:
        """Free the ground -> image tables (sensor poses at line-spaced epochs and the interpolation
        tables, about 5 MB per 7,000-line strip); the next ``ground_to_image`` rebuilds them (tens
        of milliseconds). For callers that hold many strips and use a few at a time."""
        for name in ("_coarse", "_whiskbroom_tables"):
            self.__dict__.pop(name, None)

    # --- poses ----------------------------------------------------------------------------------
    def _mount_args(self) -> tuple[float, float, np.ndarray, np.ndarray, np.ndarray, float]:
        m = self.mounting
        return (self.spline.t0, self.spline.spacing, np.ascontiguousarray(self.spline.coef),
                np.asarray(m.lever_arm_B, float), np.ascontiguousarray(m.R_BS), float(m.time_offset))

    def pose(self, t: np.ndarray, derivatives: bool = False):
        """Sensor pose at sensor times t: p_S (n, 3) m and R_PS (n, 3, 3); with derivatives also
        their time derivatives."""
        t = np.ascontiguousarray(np.atleast_1d(np.asarray(t, dtype=float)))
        n = len(t)
        R, dR = np.empty((n, 3, 3)), np.empty((n, 3, 3))
        p, dp = np.empty((n, 3)), np.empty((n, 3))
        choose_threading_layer()
        _poses(t, *self._mount_args(), R, p, dR, dp)
        return (p, R, dp, dR) if derivatives else (p, R)

    def time_of(self, line, pixel) -> np.ndarray:
        """Sensor time (s) at which (line, pixel) was recorded."""
        return self.timing.time_of_line(line) + self.sensor.time_offset(pixel)

    def rays(self, line, pixel) -> tuple[np.ndarray, np.ndarray]:
        """Ray origins p_S (n, 3) and unit directions (n, 3) in the project frame."""
        line = np.atleast_1d(np.asarray(line, dtype=float))
        pixel = np.atleast_1d(np.asarray(pixel, dtype=float))
        line, pixel = (np.ascontiguousarray(a.ravel()) for a in np.broadcast_arrays(line, pixel))
        kind, sp, table = self.sensor.kernel_params()
        o = np.empty((len(line), 3))
        d = np.empty((len(line), 3))
        choose_threading_layer()
        K.rays_kernel(line, pixel, *self._mount_args(), kind, sp, np.ascontiguousarray(table, dtype=float),
                      *self._timing_args(), o, d)
        return o, d

    def measured_line_residuals(self, p_P: np.ndarray, line, pixel) -> tuple[np.ndarray, np.ndarray]:
        """Residuals (model - measured) of measurements (line, pixel) of project-frame points (n, 3) when
        the measured line fixes the time (``[sensor] measurement_time = "line"``).

        At the measured line's time: the pixel of the direction to the point, and the along-track
        misfit ``g = v_x / v_z - tan(along(pixel))`` in lines: divided by ``d(v_x / v_z)/dt`` of the
        navigation point's motion alone (not the attitude's rates, which jitter) times the line rate.
        The adjustment's image observations with ``measured_time`` compute the same.

        Returns
        -------
        dline : (n,) lines along track; dpixel : (n,) pixels across track.
        """
        p_P = np.atleast_2d(np.asarray(p_P, dtype=float))
        line = np.atleast_1d(np.asarray(line, dtype=float))
        pixel = np.atleast_1d(np.asarray(pixel, dtype=float))
        t = self.time_of(line, pixel)
        p_S, R = self.pose(t)
        v = np.einsum("nji,nj->ni", R, p_P - p_S)
        velocity = self.spline.evaluate(t + self.mounting.time_offset, derivative=1)[:, :3]  # navigation point
        vdot = np.einsum("nji,nj->ni", R, -velocity)
        model_pixel = self.sensor.pixel_of(v)
        g = v[:, 0] / v[:, 2] - np.tan(self.sensor.along_angle(model_pixel))
        g_motion = vdot[:, 0] / v[:, 2] - v[:, 0] * vdot[:, 2] / v[:, 2] ** 2
        h = 1e-4
        rate = (self.timing.line_of_time(t + h) - self.timing.line_of_time(t - h)) / (2 * h)
        return -g / g_motion * rate, model_pixel - pixel

    def _timing_args(self) -> tuple[float, float, np.ndarray]:
        ltable = self.timing.table if self.timing.table is not None else np.zeros(0)
        return float(self.timing.first_line_time), float(self.timing.line_rate), np.asarray(ltable, float)

    # --- image -> ground ------------------------------------------------------------------------
    def image_to_ground(self, line, pixel, dtm: DTM, step: float | None = None):
        """Ground points (n, 3) in P seen by (line, pixel) on the DTM, and status codes.

        The first intersection along each ray; NaN with a status where there is none.
        """
        o, d = self.rays(line, pixel)
        return cast_rays(o, d, dtm, step)

    # --- ground -> image ------------------------------------------------------------------------
    @cached_property
    def _coarse(self):
        rate = self.timing.mean_rate
        half_scan = abs(float(self.sensor.time_offset(np.array([0.0]))[0]))
        # a pushbroom's pixels look along track at different angles: the centre pixel's scan line
        # (used for bracketing) passes a point seen by another pixel earlier or later
        pix = np.arange(self.sensor.pixels, dtype=float)
        along = np.tan(self.sensor.along_angle(pix))
        spread = float(np.abs(along - along[len(along) // 2]).max())
        t_mid = 0.5 * (self.spline.t0 + self.spline.t_end)
        v = self.spline.evaluate(np.array([t_mid]), 1)[0, :3]
        speed = max(float(np.hypot(v[0], v[1])), 1.0)
        margin = 2.0 / rate + spread * 10000.0 / speed  # up to 10 km below the sensor
        t_first = float(self.timing.time_of_line(np.array([-0.5]))[0]) - half_scan - margin
        t_last = float(self.timing.time_of_line(np.array([self.n_lines - 0.5]))[0]) + half_scan + margin
        n = max(3, int(np.ceil((t_last - t_first) * rate)) + 1)
        times = np.linspace(t_first, t_last, n)
        p, R, dp, dR = self.pose(times, derivatives=True)
        return times, R, p, dR, dp

    def overscan_window(self, p_P: np.ndarray) -> int:
        """Coarse intervals to search around a solution for further ones (pitch-induced over-scanning).

        The scan line's ground position along track, ``s(t)``, is followed for the swath's edges and
        centre at the lowest and highest of the given points. Where ``s`` runs backwards, a ground
        point can be crossed several times; the longest span from the first time ``s`` reached the
        low point of such a backward run to the end of the run's recovery bounds the distance
        between a point's crossings. 0 when ``s`` never runs backwards.
        """
        times, R, p, dR, dp = self._coarse
        z = p_P[:, 2][np.isfinite(p_P[:, 2])]
        if z.size == 0 or len(times) < 3:
            return 0
        u = p[-1, :2] - p[0, :2]
        u = u / max(np.linalg.norm(u), 1e-9)
        looks = self.sensor.look_S(np.array([0.0, (self.sensor.pixels - 1) / 2, self.sensor.pixels - 1.0]))
        window = 0
        for look in looks:
            vec = np.einsum("nij,j->ni", R, look)
            for z_ground in (z.min(), z.max()):
                rho = (p[:, 2] - z_ground) / np.maximum(-vec[:, 2], 1e-3)
                s = (p[:, :2] + rho[:, None] * vec[:, :2]) @ u
                runmax = np.maximum.accumulate(s)
                behind = s < runmax
                if not behind.any():
                    continue
                # contiguous runs where s is below its running maximum
                edges = np.diff(np.concatenate([[0], behind.astype(np.int8), [0]]))
                starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
                for a, b in zip(starts, ends):
                    first = int(np.searchsorted(runmax, s[a:b].min()))
                    window = max(window, int(b) - first)
        return window + 3 if window else 0

    @cached_property
    def _whiskbroom_tables(self):
        """Interpolation tables of ``ground_to_image_kernels`` (epochs aligned with the knots)."""
        times = self._coarse[0]
        t, tab, err = whiskbroom_tables(lambda tt: self.pose(tt, derivatives=True), self.spline.t0,
                                        self.spline.spacing, float(self.mounting.time_offset),
                                        self.timing.mean_rate, float(times[0]), float(times[-1]))
        g = np.ascontiguousarray(tab[:, 0])
        return t, tab, g, err, np.ascontiguousarray(g[:, :3]), np.ascontiguousarray(g[:, 3])

    def ground_to_image(self, p_P: np.ndarray, tol_line: float = 1e-6):
        """(line, pixel) that saw project-frame points (n, 3), and status codes.

        Whiskbroom: the scan-plane condition and the look direction interpolated between
        knot-aligned epochs, to ``tol_line`` by a per-point bound, exact Newton on time where the bound
        is larger (``ground_to_image_kernels``). Pushbroom: bracketing on a line-spaced grid of
        sensor poses (warm-started from the previous point), then safeguarded Newton on time to
        ``tol_line`` lines.
        """
        p_P = np.ascontiguousarray(np.atleast_2d(np.asarray(p_P, dtype=float)))
        n = len(p_P)
        kind, sp, table = self.sensor.kernel_params()
        if kind == 0:
            return self._whiskbroom_ground_to_image(p_P, sp, tol_line)[:3]
        times, R, p, _, _ = self._coarse
        tan_c = float(np.tan(self.sensor.along_angle(np.array([0.5 * (self.sensor.pixels - 1)]))[0]))
        cA = np.ascontiguousarray(R[:, :, 0] - tan_c * R[:, :, 2])
        cC = np.einsum("ki,ki->k", cA, p)
        line = np.empty(n)
        pixel = np.empty(n)
        status = np.empty(n, dtype=np.int64)
        window = self.overscan_window(p_P)
        choose_threading_layer()
        K.ground_to_image_kernel(
            p_P, *self._mount_args(), kind, sp, np.ascontiguousarray(table, dtype=float),
            *self._timing_args(), float(self.n_lines), times, cA, cC, window,
            tol_line / self.timing.mean_rate, max(1, min(n, 256)), line, pixel, status,
        )
        return line, pixel, status

    def nearest_sighting(self, p_P: np.ndarray, line, pixel):
        """(line, pixel, status) of project-frame points (n, 3): of a point seen more than once
        (over-scanning, status bit ``MULTIPLE``), the sighting nearest the image position ``(line,
        pixel)`` it was measured at, not the first in time; of the others ``ground_to_image``'s.

        The residual of a measurement, or the error of an orientation at an image position, is that
        of the sighting standing for it (:mod:`scangeo.sensors.sightings`): the check-point
        residuals of an adjustment and the true error of a simulation both take it.

        Parameters
        ----------
        p_P : (n, 3) float array
            Ground points, m, project frame.
        line, pixel : (n,) float arrays
            Where each was measured (or sampled) in this strip's image, lines and pixels.

        Returns
        -------
        line, pixel : (n,) float arrays
            The sighting's image position, lines and pixels (NaN where the point is not seen).
        status : (n,) int array
            ``ground_to_image``'s codes, ``MULTIPLE`` kept where the point is seen more than once.
        """
        p_P = np.atleast_2d(np.asarray(p_P, dtype=float))
        line = np.broadcast_to(np.asarray(line, dtype=float), (len(p_P),))
        pixel = np.broadcast_to(np.asarray(pixel, dtype=float), (len(p_P),))
        return nearest_sighting(self, p_P, line, pixel)

    def _whiskbroom_ground_to_image(self, p_P: np.ndarray, sp: np.ndarray, tol_line: float):
        """line, pixel, status and the exact-solution flag per point (whiskbroom)."""
        n = len(p_P)
        times, tab, gtab, err, cA, cC = self._whiskbroom_tables
        line, pixel = np.empty(n), np.empty(n)
        status, exact = np.empty(n, dtype=np.int64), np.empty(n, dtype=np.uint8)
        choose_threading_layer()
        whiskbroom_ground_to_image(
            p_P, times, tab, gtab, err, cA, cC, self.overscan_window(p_P), *self._mount_args(), sp,
            *self._timing_args(), float(self.n_lines), float(tol_line), tol_line / self.timing.mean_rate,
            max(1, min(n, 256)), line, pixel, status, exact,
        )
        return line, pixel, status, exact

    def ground_to_image_near(self, p_P: np.ndarray, line0: np.ndarray, pixel0: np.ndarray,
                             tol_line: float = 1e-4, max_step_lines: float = 64.0, max_iter: int = 8):
        """(line, pixel, status, evaluations) of project-frame points (n, 3) by Newton on time from
        guesses ``line0, pixel0`` (e.g. interpolated from exact solutions nearby), no bracketing.

        Only for strips without over-scanning (``overscan_window == 0``), where a point has one
        solution; there the result equals ``ground_to_image``'s. Whiskbroom: the interpolated
        conditions of ``ground_to_image`` from the guess's coarse interval (``evaluations`` and
        ``max_iter`` count the intervals looked at). Points whose iteration does not
        converge within ``max_iter`` condition evaluations, or steps farther than
        ``max_step_lines``, get status NO_CONVERGENCE (solve them with ``ground_to_image``).
        Points outside the swath or beyond the strip's ends keep their (line, pixel) with the
        status saying so.
        """
        p_P = np.ascontiguousarray(np.atleast_2d(np.asarray(p_P, dtype=float)))
        n = len(p_P)
        kind, sp, table = self.sensor.kernel_params()
        line = np.empty(n)
        pixel = np.empty(n)
        status = np.empty(n, dtype=np.int64)
        steps = np.empty(n, dtype=np.int64)
        rate = self.timing.mean_rate
        if kind == 0:
            times, tab, _, err, cA, cC = self._whiskbroom_tables
            gl = np.ascontiguousarray(line0, dtype=float).ravel()
            gp = np.ascontiguousarray(pixel0, dtype=float).ravel()
            choose_threading_layer()
            whiskbroom_ground_to_image_near(
                p_P, gl, gp, times, tab, err, cA, cC, *self._mount_args(), sp, *self._timing_args(),
                float(self.n_lines), float(tol_line), tol_line / rate, max_step_lines / rate, int(max_iter),
                max(1, min(n, 256)), line, pixel, status, steps,
            )
            return line, pixel, status, steps
        choose_threading_layer()
        K.refine_kernel(
            p_P, np.ascontiguousarray(line0, dtype=float).ravel(), np.ascontiguousarray(pixel0, dtype=float).ravel(),
            *self._mount_args(), kind, sp, np.ascontiguousarray(table, dtype=float), *self._timing_args(),
            float(self.n_lines), tol_line / rate, max_step_lines / rate, int(max_iter), max(1, min(n, 256)),
            line, pixel, status, steps,
        )
        return line, pixel, status, steps

    def footprint_box(self, dtm: DTM, margin: float = 200.0) -> np.ndarray:
        """(3, 2) project-frame box holding the strip's rays down to the DTM's lowest point."""
        lines = np.linspace(0, self.n_lines - 1, 9)
        pix = np.array([0.0, self.sensor.pixels - 1.0])
        L, J = np.meshgrid(lines, pix)
        o, d = self.rays(L.ravel(), J.ravel())
        return rays_box(o, d, dtm, margin)


@nb.njit(cache=True)
def _ray_extent(o, d, z_low):
    """Min/max over rays of their origins and their points at height z_low (approximately)."""
    lo = np.full(3, np.inf)
    hi = np.full(3, -np.inf)
    z_top = -np.inf
    for q in range(o.shape[0]):
        if not (np.isfinite(o[q, 0]) and np.isfinite(o[q, 1]) and np.isfinite(o[q, 2])
                and np.isfinite(d[q, 0]) and d[q, 2] < -1e-6):
            continue
        lam = (o[q, 2] - z_low) / (-d[q, 2]) * 1.05
        for k in range(3):
            a = o[q, k]
            b = o[q, k] + lam * d[q, k]
            lo[k] = min(lo[k], min(a, b))
            hi[k] = max(hi[k], max(a, b))
        z_top = max(z_top, o[q, 2])
    return lo, hi, z_top


def rays_box(o: np.ndarray, d: np.ndarray, dtm: DTM, margin: float = 200.0) -> np.ndarray:
    """(3, 2) box in P (rounded out to 1 km) holding rays from their origins down to the DTM's low."""
    z_low = dtm.h_min - 300.0
    lo, hi, z_top = _ray_extent(np.ascontiguousarray(o, float), np.ascontiguousarray(d, float), z_low)
    lo = np.floor((lo - margin) / 1000.0) * 1000.0
    hi = np.ceil((hi + margin) / 1000.0) * 1000.0
    lo[2] = np.floor((z_low - 200.0) / 100.0) * 100.0
    hi[2] = np.ceil((z_top + margin) / 100.0) * 100.0
    return np.column_stack([lo, hi])


def cast_rays(o: np.ndarray, d: np.ndarray, dtm: DTM, step: float | None = None):
    """First intersections (n, 3) of rays (origins, unit directions in P) with the DTM, and status."""
    o = np.ascontiguousarray(o, dtype=float)
    d = np.ascontiguousarray(d, dtype=float)
    n = len(o)
    out = np.empty((n, 3))
    status = np.empty(n, dtype=np.int64)
    box = rays_box(o, d, dtm)
    if not np.isfinite(box).all():
        return np.full((n, 3), np.nan), np.full(n, K.NO_CONVERGENCE, dtype=np.int64)
    local = dtm.local_map(box)
    inv = ~dtm.grid.transform
    inv_arr = np.array([inv.a, inv.b, inv.c, inv.d, inv.e, inv.f])
    block = 8
    choose_threading_layer()
    ray_cast_kernel(o, d, local.coef, local.exps, local.centre, local.scale,
                    np.ascontiguousarray(dtm.grid.values), inv_arr, dtm.h_min, dtm.h_max,
                    step if step is not None else 0.25 * dtm.cell_size(), dtm.block_max(block), block,
                    block * dtm.cell_size(), out, status)
    return out, status
