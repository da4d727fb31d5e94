"""Image measurements of ground points in a line-scanner strip (whiskbroom or pushbroom).

For a measurement (line, pixel) of ground point ``P`` the model finds the sensor time ``t`` at which
``P`` lies in the scan plane, ``g(v_S) = 0`` for ``v_S = R_PS(t)^T (P - p_S(t))`` (Newton from the
observed time, to 1e-10 s), then the pixel from the across-track direction of ``v_S`` and the line
from ``t`` minus the pixel's time offset. The sensor's terms (``g``, the pixel, the time offset and
their derivatives) are in ``scangeo.adjustment.scanplane``: ``g = v_x / v_z`` for a whiskbroom,
``g = v_x / v_z - tan(along(pixel))`` for a pushbroom (the along-track look angle of the pixel that
sees the point). Residuals are ``model - observed`` in lines (along track) and pixels (across
track), whitened by the measurement's sigma (pixels).

Pose: ``p_S = p(t_nav) + R_PB l_B``, ``R_PS = R_PB R_BS``, ``R_PB = R_ENU_NED Rz(h) Ry(p) Rx(r)`` with
``(x, y, z, r, p, h)(t_nav)`` the spline of the strip's flight line at navigation time
``t_nav = t + time_offset``.

Analytic Jacobian by the implicit function theorem: ``g(v(t, x)) = 0`` gives
``dt/dx = -(dg/dv dv/dx) / (dg/dv dv/dt)``; then ``dv/dx + dv/dt dt/dx`` into the pixel and the line.
Unknowns: ``Knots(flight_line)`` (the 4 coefficients of the segment at ``t_nav``), ``Ground(point)``,
and the strip's sensor's ``Boresight(sensor)``, ``LeverArm(sensor)``, ``TimeOffset(sensor)``, for a
whiskbroom ``ScanIndex(sensor)`` and ``ScanScale(sensor)`` (they move the pixel only, not the scan
plane), for a pushbroom ``AcrossOffset(sensor)``, ``AcrossScale(sensor)`` and ``AlongOffset(sensor)``
(they move the pixel and, through the along-track look angle of the pixel and the along-track offset,
the scan plane: ``dt/dx`` gets their direct ``dg/dx``).
"""
from __future__ import annotations

import numpy as np

from scangeo.adjustment.keys import Boresight, Ground, Knots, LeverArm, TimeOffset
from scangeo.adjustment.scanplane import scan_plane
from scangeo.errors import AdjustmentError
from scangeo.lsq.observations import Linearisation, ObservationGroup
from scangeo.lsq.parameters import JacobianPart
from scangeo.rotation import R_ENU_NED, rph_to_matrix_with_derivatives
from scangeo.sensors.models import Pushbroom, Whiskbroom
from scangeo.timing import LineTiming
from scangeo.trajectory.spline import OrientationSpline, bspline_basis


def mounting_keys(sensor: str = "") -> tuple[Boresight, LeverArm, TimeOffset]:
    """The mounting's calibration keys of a sensor (its own calibration's come from ``scanplane``)."""
    return Boresight(sensor), LeverArm(sensor), TimeOffset(sensor)


def _T(R: np.ndarray) -> np.ndarray:
    return np.swapaxes(R, -1, -2)


class ImageObservations(ObservationGroup):
    """Measurements (line, pixel) of ground points in one line-scanner strip.

    Parameters
    ----------
    strip : strip id.
    sensor : the whiskbroom or pushbroom model (its geometry; a whiskbroom's index and scale errors
        come from the unknowns).
    spline : the spline of the strip's flight line (layout only: t0, spacing, number of coefficients).
    timing : the strip's line timing.
    points : (n,) ids of the measured points; line, pixel : (n,) measurements; sigma_px : (n,).
    measured_time : the measured line fixes the time (``[sensor] measurement_time = "line"``): the
        pose is that of the measured line's time, the pixel comes from the direction there, and the
        along-track residual is the scan-plane condition at that time in lines, ``-g / k`` with ``k``
        the change of ``g`` per line from the platform's motion alone. For navigation sampled once per
        line with attitude jitter between lines (a real pushbroom's), where solving for the time
        would carry an along-track misfit into the across-track residual through the jitter. ``k``
        is fixed at the first values the group sees (the start orientation), so the residual is
        linear in ``g`` and its Jacobian exact.
    flight_line : the flight line whose spline the strip follows (``Knots(flight_line)``; default the
        strip's own).
    sensor_id : the id of the sensor whose mounting and calibration unknowns the strip uses (``""``: the
        one sensor of a one-sensor project).
    """

    def __init__(self, strip: str, sensor: Whiskbroom | Pushbroom, spline: OrientationSpline, timing: LineTiming,
                 points, line, pixel, sigma_px, name: str | None = None, measured_time: bool = False,
                 flight_line: str | None = None, sensor_id: str = "") -> None:
        if not isinstance(sensor, (Whiskbroom, Pushbroom)):
            raise AdjustmentError(f"strip {strip}: image observations need a whiskbroom or pushbroom sensor, "
                                  f"not {type(sensor).__name__}")
        self.name = name or f"image {strip}"
        self.strip = strip
        self.sensor = sensor
        self.plane = scan_plane(sensor, sensor_id)
        self.sensor_id = sensor_id
        self.bore_key, self.lever_key, self.toff_key = mounting_keys(sensor_id)
        self.t0, self.spacing, self.n_coef = spline.t0, spline.spacing, spline.n_coef
        self.timing = timing
        self.points = np.asarray(points, dtype=object)
        self.line = np.asarray(line, float)
        self.pixel = np.asarray(pixel, float)
        n = self.points.size
        self.sigma = np.repeat(np.asarray(sigma_px, float) * np.ones(n), 2)
        self._describe(np.repeat(self.points, 2), np.tile(["line", "pixel"], n), np.tile(["line", "px"], n),
                       np.repeat(np.arange(n), 2))
        self._ground = [Ground(str(p)) for p in self.points]
        self.flight_line = strip if flight_line is None else flight_line
        self.knots = Knots(self.flight_line)
        self.t_obs = timing.time_of_line(self.line) + sensor.time_offset(self.pixel)
        self.measured_time = measured_time
        self._lines_per_g: np.ndarray | None = None

    def keys(self):
        return [self.knots, *dict.fromkeys(self._ground), self.bore_key, self.lever_key, self.toff_key,
                *self.plane.calibration_keys]

    # -- model ----------------------------------------------------------------------------------
    def _pose(self, values, t: np.ndarray, P: np.ndarray):
        coef = np.asarray(values[self.knots], float).reshape(-1, 6)
        bore = np.asarray(values[self.bore_key], float)
        lever = np.asarray(values[self.lever_key], float)
        toff = float(values[self.toff_key][0])
        s = (t + toff - self.t0) / self.spacing
        j = np.clip(np.floor(s), 0, self.n_coef - 4).astype(np.intp)
        u = s - j
        B = bspline_basis(u)
        Bd = bspline_basis(u, 1) / self.spacing
        c = coef[j[:, None] + np.arange(4)]                      # (n, 4, 6)
        sv = np.einsum("nk,nkc->nc", B, c)
        sd = np.einsum("nk,nkc->nc", Bd, c)
        R_NB, dR_NB = rph_to_matrix_with_derivatives(sv[:, 3], sv[:, 4], sv[:, 5])
        R_PB = R_ENU_NED @ R_NB
        dR_PB = R_ENU_NED @ dR_NB                                # (n, 3 angles, 3, 3)
        R_BS, dR_BS = rph_to_matrix_with_derivatives(bore[0], bore[1], bore[2])
        R_PS = R_PB @ R_BS
        e = P - (sv[:, :3] + R_PB @ lever)
        v = np.einsum("nji,nj->ni", R_PS, e)
        dv_ds = np.empty((t.size, 3, 6))
        dv_ds[:, :, :3] = -_T(R_PS)
        for a in range(3):
            dR_PS = dR_PB[:, a] @ R_BS
            dv_ds[:, :, 3 + a] = np.einsum("nji,nj->ni", dR_PS, e) - np.einsum("nji,nj->ni", R_PS, dR_PB[:, a] @ lever)
        dv_dt = np.einsum("nic,nc->ni", dv_ds, sd)
        dv_dt_motion = np.einsum("nic,nc->ni", dv_ds[:, :, :3], sd[:, :3])   # the platform's motion alone
        return dict(v=v, dv_ds=dv_ds, dv_dt=dv_dt, dv_dt_motion=dv_dt_motion, B=B, j=j, R_PS=R_PS, R_PB=R_PB,
                    R_BS=R_BS, dR_BS=dR_BS, e=e)

    def _line_rate(self, t_line: np.ndarray) -> np.ndarray:
        """Lines per second at sensor times ``t_line`` (the timing's local rate)."""
        h = 1e-4
        return (self.timing.line_of_time(t_line + h) - self.timing.line_of_time(t_line - h)) / (2 * h)

    def _lines_per_condition(self, values, f) -> np.ndarray:
        """``1 / k``: lines per unit of the scan-plane condition, from the platform's motion at the measured
        lines' times (``d(v_x / v_z)/dt``, as ``StripGeometry.measured_line_residuals``); fixed at the
        first values seen (the class docstring)."""
        if self._lines_per_g is None:
            v, vdot = f["v"], f["dv_dt_motion"]
            g_motion = vdot[:, 0] / v[:, 2] - v[:, 0] * vdot[:, 2] / v[:, 2] ** 2   # d(v_x / v_z) / dt
            self._lines_per_g = self._line_rate(self.t_obs) / g_motion
        return self._lines_per_g

    def _solve_time(self, values, P: np.ndarray):
        t = self.t_obs.copy()
        for _ in range(12 if not self.measured_time else 0):
            f = self._pose(values, t, P)
            g, dg_dv = self.plane.condition(f["v"], values)
            g_t = np.einsum("ni,ni->n", dg_dv, f["dv_dt"])
            step = g / g_t
            t = t - step
            if np.all(np.abs(step) < 1e-10):
                break
        f = self._pose(values, t, P)
        bad = ~np.isfinite(t) | (f["v"][:, 2] <= 0)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise AdjustmentError(f"strip {self.strip}: point {self.points[i]} is not seen by the strip's "
                                  f"orientation (measured at line {self.line[i]:.1f}, pixel {self.pixel[i]:.1f})")
        return t, f

    def predict(self, values) -> tuple[np.ndarray, np.ndarray]:
        """Model line and pixel of every measurement's ground point."""
        P = np.array([values[g] for g in self._ground], float).reshape(-1, 3)
        t, f = self._solve_time(values, P)
        pixel, *_ = self.plane.pixel(f["v"], values)
        if self.measured_time:
            g, _ = self.plane.condition(f["v"], values)
            return self.line - g * self._lines_per_condition(values, f), pixel
        line = self.timing.line_of_time(t - self.plane.time_offset(pixel))
        return line, pixel

    def residuals(self, values) -> np.ndarray:
        line, pixel = self.predict(values)
        return np.column_stack([line - self.line, pixel - self.pixel]).ravel() / self.sigma

    def linearise(self, values) -> Linearisation:
        n = self.points.size
        P = np.array([values[g] for g in self._ground], float).reshape(-1, 3)
        t, f = self._solve_time(values, P)
        v = f["v"]
        pixel, dpix_dv, direct = self.plane.pixel(v, values)
        g, dg_dv, dg_direct = self.plane.condition_with_calibration(v, values)
        dt_pix = self.plane.dt_pixel
        if self.measured_time:
            per_g = self._lines_per_condition(values, f)
            line = self.line - g * per_g
        else:
            t_line = t - self.plane.time_offset(pixel)
            line = self.timing.line_of_time(t_line)
            rate = self._line_rate(t_line)
            g_t = np.einsum("ni,ni->n", dg_dv, f["dv_dt"])

        def chain(dv_dx: np.ndarray, dpix_direct: np.ndarray | None = None, dg_direct: np.ndarray | None = None):
            """(n, 3, m) direct derivatives of v -> (dline, dpixel) (n, m). ``dpix_direct``, ``dg_direct``:
            derivatives of the pixel and of the scan-plane condition that do not go through v (the
            sensor's calibration: a whiskbroom's scan errors move the pixel only, a pushbroom's also
            the condition, and so t). With the measured time the time does not move: the line
            follows ``g``, the pixel ``v``."""
            dg = np.einsum("ni,nim->nm", dg_dv, dv_dx)
            if dg_direct is not None:
                dg = dg + dg_direct
            if self.measured_time:
                dpix = np.einsum("ni,nim->nm", dpix_dv, dv_dx)
                if dpix_direct is not None:
                    dpix = dpix + dpix_direct
                return -per_g[:, None] * dg, dpix
            dt_dx = -dg / g_t[:, None]
            total = dv_dx + f["dv_dt"][:, :, None] * dt_dx[:, None, :]
            dpix = np.einsum("ni,nim->nm", dpix_dv, total)
            if dpix_direct is not None:
                dpix = dpix + dpix_direct
            dline = rate[:, None] * (dt_dx - dt_pix * dpix)
            return dline, dpix

        sig = self.sigma.reshape(n, 2)
        parts = []
        rows2 = np.arange(2 * n).reshape(n, 2)

        def add(keys, dline, dpix, cols, block=None):
            vals = np.stack([dline, dpix], 1) / sig[:, :, None]          # (n, 2, m)
            r = np.broadcast_to(rows2[:, :, None], vals.shape)
            cols_a = np.asarray(cols)
            c = np.broadcast_to(cols_a[:, None, :] if cols_a.ndim == 2 else cols_a[None, None, :], vals.shape)
            b = None if block is None else np.broadcast_to(np.asarray(block)[:, None, None], vals.shape)
            parts.append(JacobianPart(keys, r.ravel(), c.ravel(), vals.ravel(), None if b is None else b.ravel()))

        # knots: d/d coef[j+i, c] = d/ds_c * B_i
        dl_ds, dp_ds = chain(f["dv_ds"])
        B = f["B"]
        add(
            [self.knots],
            (B[:, :, None] * dl_ds[:, None, :]).reshape(n, 24),
            (B[:, :, None] * dp_ds[:, None, :]).reshape(n, 24),
            ((f["j"][:, None] + np.arange(4))[:, :, None] * 6 + np.arange(6)).reshape(n, 24),
        )
        # ground point
        dl, dp = chain(_T(f["R_PS"]))
        add(self._ground, dl, dp, np.arange(3), np.arange(n))
        # boresight, lever arm, time offset
        dv_db = np.stack([np.einsum("nji,nj->ni", f["R_PB"] @ f["dR_BS"][b], f["e"]) for b in range(3)], -1)
        dl, dp = chain(dv_db)
        add([self.bore_key], dl, dp, np.arange(3))
        dl, dp = chain(np.broadcast_to(-_T(f["R_BS"]), (n, 3, 3)))
        add([self.lever_key], dl, dp, np.arange(3))
        dl, dp = chain(f["dv_dt"][:, :, None])
        add([self.toff_key], dl, dp, np.arange(1))
        # the sensor's own calibration (whiskbroom index and scale error, pushbroom offsets and scale):
        # the pixel directly, and for a pushbroom the scan-plane condition too
        for key, dpix_dkey in direct.items():
            dl, dp = chain(np.zeros((n, 3, dpix_dkey.shape[1])), dpix_dkey, dg_direct.get(key))
            add([key], dl, dp, np.arange(dpix_dkey.shape[1]))
        r = np.column_stack([line - self.line, pixel - self.pixel]).ravel() / self.sigma
        return Linearisation(r, parts)
