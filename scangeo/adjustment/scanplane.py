"""The sensor's part of an image measurement: scan-plane condition and pixel, with derivatives.

For a ground point seen at sensor time ``t`` in the direction ``v = R_PS(t)^T (P - p_S(t))`` (sensor
frame S: x along track, y right, z down) a line scanner's model needs

* the **scan-plane condition** ``g(v) = 0`` that fixes ``t``, with ``dg/dv``;
* the **pixel** from the across-track direction, with ``dpixel/dv`` and its direct derivatives with
  respect to the sensor's own calibration unknowns;
* the pixel's **time offset** after the line's time (its derivative ``dt_pixel`` per pixel);
* the direct derivatives of the condition with respect to the sensor's calibration unknowns
  (``condition_with_calibration``; none for a whiskbroom, whose scan errors leave the scan plane).

Whiskbroom (rotating mirror): ``g = v_x / v_z`` (the mirror's plane), pixel from the scan angle
``theta = atan2(v_y, v_z)``: ``pixel = j_c + s (theta - index) / (step (1 + scale))``; unknowns
``ScanIndex()``, ``ScanScale()``; ``dt_pixel = step / (2 pi line_rate)``.

Pushbroom: pixel from ``tan(across) = v_y / v_z`` (inverse of the pinhole's radial distortion, or
of the table, linear in the tangents between pixel centres), and the along-track look angle of
*that* pixel: ``g = v_x / v_z - tan(along(pixel(v)))`` (docs/conventions.md: ``x_S = tan(along) z_S``).
A pinhole's along-track angle is constant (``line_offset / f``); a table's varies from pixel to pixel
(smile), so ``g`` depends on ``v_y`` through the pixel. No per-pixel time offset. Its own calibration
unknowns ``AcrossOffset()``, ``AcrossScale()`` (the pixel, and through the smile the condition) and
``AlongOffset()`` (the condition: the scan plane, and so the time); boresight, lever arm and time
offset are the mounting's.
"""
from __future__ import annotations

import numpy as np

from scangeo.adjustment.keys import AcrossOffset, AcrossScale, AlongOffset, ScanIndex, ScanScale
from scangeo.lsq.keys import Key
from scangeo.sensors.models import Pushbroom, Whiskbroom


def _tan_derivative(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``v_y / v_z`` and its gradient with respect to ``v`` (n, 3)."""
    vy, vz = v[:, 1], v[:, 2]
    grad = np.column_stack([np.zeros_like(vz), 1 / vz, -vy / vz**2])
    return vy / vz, grad


def _along_condition(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``v_x / v_z`` and its gradient (n, 3)."""
    vx, vz = v[:, 0], v[:, 2]
    return vx / vz, np.column_stack([1 / vz, np.zeros_like(vz), -vx / vz**2])


class WhiskbroomPlane:
    """Scan-plane terms of a rotating-mirror scanner (index and scale error from the unknowns of the
    sensor ``sensor_id``)."""

    def __init__(self, sensor: Whiskbroom, sensor_id: str = "") -> None:
        self.sensor = sensor
        self.dt_pixel = sensor.dt_pixel
        self.index_key, self.scale_key = ScanIndex(sensor_id), ScanScale(sensor_id)
        self.calibration_keys: tuple[Key, ...] = (self.index_key, self.scale_key)

    def condition(self, v: np.ndarray, values) -> tuple[np.ndarray, np.ndarray]:
        """``g(v)`` (n,) and ``dg/dv`` (n, 3)."""
        return _along_condition(v)

    def condition_with_calibration(self, v: np.ndarray, values) -> tuple[np.ndarray, np.ndarray,
                                                                       dict[Key, np.ndarray]]:
        """``g``, ``dg/dv`` and no direct derivatives: the scan errors leave the mirror's plane."""
        return (*_along_condition(v), {})

    def pixel(self, v: np.ndarray, values) -> tuple[np.ndarray, np.ndarray, dict[Key, np.ndarray]]:
        """Pixel (n,), ``dpixel/dv`` (n, 3) and ``{key: dpixel/dkey (n, m)}`` for calibration keys."""
        sen = self.sensor
        index = float(values[self.index_key][0])
        scale = float(values[self.scale_key][0])
        k = sen.scan_direction / (sen.step * (1 + scale))
        vy, vz = v[:, 1], v[:, 2]
        pixel = sen.centre + k * (np.arctan2(vy, vz) - index)
        dpix_dv = k * np.column_stack([np.zeros_like(vz), vz, -vy]) / (vy**2 + vz**2)[:, None]
        direct = {self.index_key: np.full((v.shape[0], 1), -k),
                  self.scale_key: (-(pixel - sen.centre) / (1 + scale))[:, None]}
        return pixel, dpix_dv, direct

    def time_offset(self, pixel: np.ndarray) -> np.ndarray:
        return self.sensor.time_offset(pixel)


class PushbroomPlane:
    """Scan-plane terms of a pushbroom line sensor (pinhole or look-angle table) and its calibration.

    With the nominal tangents ``T_a(j)``, ``T_x(j)`` of the sensor and the calibration unknowns
    (``a = AcrossOffset()``, ``s = AcrossScale()``, ``b = AlongOffset()``; ``scangeo.sensors.models.Pushbroom``):
    the pixel solves ``T_x(pixel) = u`` with ``u = t_c + (v_y / v_z - a - t_c) / (1 + s)``
    (``t_c = T_x(j_c)``), and the condition is ``g = v_x / v_z - T_a(pixel) - b``.
    """

    dt_pixel = 0.0

    def __init__(self, sensor: Pushbroom, sensor_id: str = "") -> None:
        self.a_key, self.s_key, self.b_key = AcrossOffset(sensor_id), AcrossScale(sensor_id), AlongOffset(sensor_id)
        self.calibration_keys: tuple[Key, ...] = (self.a_key, self.s_key, self.b_key)
        # the nominal sensor: the calibration comes from the unknowns
        self.sensor = sensor.with_calibration(across_offset=0.0, across_scale=0.0, along_offset=0.0)
        self.centre_tangent = self.sensor.centre_tangent
        if not sensor.is_pinhole:
            self._tan_along = np.tan(np.asarray(sensor.along, float))
            self._tan_across = np.tan(np.asarray(sensor.across, float))

    def _segment(self, pixel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Table segment ``j`` (pixels j, j+1; the end segments extrapolate) and the fraction."""
        j = np.clip(np.floor(pixel), 0, self.sensor.pixels - 2).astype(np.intp)
        return j, pixel - j

    def _pixel_of_tan(self, tx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Pixel of the nominal ``T_x`` and ``dpixel / dT_x``."""
        sen = self.sensor
        pixel = sen.pixel_of(np.column_stack([np.zeros_like(tx), tx, np.ones_like(tx)]))
        # pinhole: x_u = x_d (1 + k1 r^2 + k2 r^4) = f tan(across), pixel = x_d / pitch + pp
        if sen.focal_length is not None:
            assert sen.principal_point is not None
            xd = (pixel - sen.principal_point) * sen.pitch
            r2 = xd * xd + sen.line_offset**2
            dxu_dxd = 1 + sen.k1 * (r2 + 2 * xd * xd) + sen.k2 * (r2 * r2 + 4 * xd * xd * r2)
            return pixel, sen.focal_length / (sen.pitch * dxu_dxd)
        j, _ = self._segment(pixel)
        return pixel, 1.0 / (self._tan_across[j + 1] - self._tan_across[j])

    def _tan_along_of(self, pixel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Nominal ``T_a`` of a pixel and its derivative per pixel."""
        sen = self.sensor
        if sen.focal_length is not None:  # pinhole
            return np.full_like(pixel, sen.line_offset / sen.focal_length), np.zeros_like(pixel)
        j, u = self._segment(pixel)
        slope = self._tan_along[j + 1] - self._tan_along[j]
        return self._tan_along[j] + u * slope, slope

    def pixel(self, v: np.ndarray, values) -> tuple[np.ndarray, np.ndarray, dict[Key, np.ndarray]]:
        """Pixel (n,), ``dpixel/dv`` (n, 3) and ``{key: dpixel/dkey (n, 1)}`` for the calibration keys."""
        a = float(values[self.a_key][0])
        s = float(values[self.s_key][0])
        tc = self.centre_tangent
        tx, dtx_dv = _tan_derivative(v)
        u = tc + (tx - a - tc) / (1 + s)
        pixel, dpix_du = self._pixel_of_tan(u)
        direct = {self.a_key: (-dpix_du / (1 + s))[:, None],
                  self.s_key: (-dpix_du * (u - tc) / (1 + s))[:, None],
                  self.b_key: np.zeros((v.shape[0], 1))}
        return pixel, (dpix_du / (1 + s))[:, None] * dtx_dv, direct

    def condition(self, v: np.ndarray, values) -> tuple[np.ndarray, np.ndarray]:
        """``g = v_x / v_z - T_a(pixel(v)) - b`` (n,) and ``dg/dv`` (n, 3)."""
        g, dg_dv, _ = self.condition_with_calibration(v, values)
        return g, dg_dv

    def condition_with_calibration(self, v: np.ndarray, values) -> tuple[np.ndarray, np.ndarray,
                                                                       dict[Key, np.ndarray]]:
        """``g`` (n,), ``dg/dv`` (n, 3) and ``{key: dg/dkey (n, 1)}`` (through the pixel's smile and ``b``)."""
        ta_v, dta_dv = _along_condition(v)
        pixel, dpix_dv, direct = self.pixel(v, values)
        ta, dta_dpix = self._tan_along_of(pixel)
        b = float(values[self.b_key][0])
        dg = {key: -dta_dpix[:, None] * d for key, d in direct.items()}
        dg[self.b_key] = np.full((v.shape[0], 1), -1.0)
        return ta_v - ta - b, dta_dv - dta_dpix[:, None] * dpix_dv, dg

    def time_offset(self, pixel: np.ndarray) -> np.ndarray:
        return np.zeros_like(pixel)


def scan_plane(sensor: Whiskbroom | Pushbroom, sensor_id: str = "") -> WhiskbroomPlane | PushbroomPlane:
    """The scan-plane terms of a sensor model, with the calibration unknowns of sensor ``sensor_id``."""
    if isinstance(sensor, Whiskbroom):
        return WhiskbroomPlane(sensor, sensor_id)
    if isinstance(sensor, Pushbroom):
        return PushbroomPlane(sensor, sensor_id)
    raise TypeError(f"no image-measurement model for sensor {type(sensor).__name__}")
