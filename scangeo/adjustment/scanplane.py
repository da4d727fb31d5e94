"""The sensor's part of an image measurement: scan-plane condition and pixel, with derivatives.

For a ground point seen at sensor time ``t`` in the direction ``v = R_PS(t)^T (P - p_S(t))`` (sensor
frame S: x along track, y right, z down) a line scanner's model needs

* the **scan-plane condition** ``g(v) = 0`` that fixes ``t``, with ``dg/dv``;
* the **pixel** from the across-track direction, with ``dpixel/dv`` and its direct derivatives with
  respect to the sensor's own calibration unknowns;
* the pixel's **time offset** after the line's time (its derivative ``dt_pixel`` per pixel).

Whiskbroom (rotating mirror): ``g = v_x / v_z`` (the mirror's plane), pixel from the scan angle
``theta = atan2(v_y, v_z)``: ``pixel = j_c + s (theta - index) / (step (1 + scale))``; unknowns
``ScanIndex()``, ``ScanScale()``; ``dt_pixel = step / (2 pi line_rate)``.

Pushbroom: pixel from ``tan(across) = v_y / v_z`` (inverse of the pinhole's radial distortion, or
of the table, linear in the tangents between pixel centres), and the along-track look angle of
*that* pixel: ``g = v_x / v_z - tan(along(pixel(v)))`` (docs/conventions.md: ``x_S = tan(along) z_S``).
A pinhole's along-track angle is constant (``line_offset / f``); a table's varies from pixel to pixel
(smile), so ``g`` depends on ``v_y`` through the pixel. No per-pixel time offset and no calibration
unknowns of its own (boresight, lever arm and time offset are the mounting's).
"""
from __future__ import annotations

import numpy as np

from scangeo.adjustment.keys import ScanIndex, ScanScale
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
    """Scan-plane terms of a rotating-mirror scanner (index and scale error from the unknowns)."""

    calibration_keys: tuple[Key, ...] = (ScanIndex(), ScanScale())

    def __init__(self, sensor: Whiskbroom) -> None:
        self.sensor = sensor
        self.dt_pixel = sensor.dt_pixel

    def condition(self, v: np.ndarray, values) -> tuple[np.ndarray, np.ndarray]:
        """``g(v)`` (n,) and ``dg/dv`` (n, 3)."""
        return _along_condition(v)

    def pixel(self, v: np.ndarray, values) -> tuple[np.ndarray, np.ndarray, dict[Key, np.ndarray]]:
        """Pixel (n,), ``dpixel/dv`` (n, 3) and ``{key: dpixel/dkey (n, m)}`` for calibration keys."""
        sen = self.sensor
        index = float(values[ScanIndex()][0])
        scale = float(values[ScanScale()][0])
        k = sen.scan_direction / (sen.step * (1 + scale))
        vy, vz = v[:, 1], v[:, 2]
        pixel = sen.centre + k * (np.arctan2(vy, vz) - index)
        dpix_dv = k * np.column_stack([np.zeros_like(vz), vz, -vy]) / (vy**2 + vz**2)[:, None]
        direct = {ScanIndex(): np.full((v.shape[0], 1), -k),
                  ScanScale(): (-(pixel - sen.centre) / (1 + scale))[:, None]}
        return pixel, dpix_dv, direct

    def time_offset(self, pixel: np.ndarray) -> np.ndarray:
        return self.sensor.time_offset(pixel)


class PushbroomPlane:
    """Scan-plane terms of a pushbroom line sensor (pinhole or look-angle table)."""

    calibration_keys: tuple[Key, ...] = ()
    dt_pixel = 0.0

    def __init__(self, sensor: Pushbroom) -> None:
        self.sensor = sensor
        if not sensor.is_pinhole:
            self._tan_along = np.tan(np.asarray(sensor.along, float))
            self._tan_across = np.tan(np.asarray(sensor.across, float))

    def _segment(self, pixel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Table segment ``j`` (pixels j, j+1; the end segments extrapolate) and the fraction."""
        j = np.clip(np.floor(pixel), 0, self.sensor.pixels - 2).astype(np.intp)
        return j, pixel - j

    def _pixel_of_tan(self, tx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Pixel of ``tan(across)`` and ``dpixel / dtan(across)``."""
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
        """``tan(along)`` of a pixel and its derivative per pixel."""
        sen = self.sensor
        if sen.focal_length is not None:  # pinhole
            return np.full_like(pixel, sen.line_offset / sen.focal_length), np.zeros_like(pixel)
        j, u = self._segment(pixel)
        slope = self._tan_along[j + 1] - self._tan_along[j]
        return self._tan_along[j] + u * slope, slope

    def pixel(self, v: np.ndarray, values) -> tuple[np.ndarray, np.ndarray, dict[Key, np.ndarray]]:
        """Pixel (n,), ``dpixel/dv`` (n, 3) and no direct calibration derivatives."""
        tx, dtx_dv = _tan_derivative(v)
        pixel, dpix_dtx = self._pixel_of_tan(tx)
        return pixel, dpix_dtx[:, None] * dtx_dv, {}

    def condition(self, v: np.ndarray, values) -> tuple[np.ndarray, np.ndarray]:
        """``g = v_x / v_z - tan(along(pixel(v)))`` (n,) and ``dg/dv`` (n, 3)."""
        ta_v, dta_dv = _along_condition(v)
        pixel, dpix_dv, _ = self.pixel(v, values)
        ta, dta_dpix = self._tan_along_of(pixel)
        return ta_v - ta, dta_dv - dta_dpix[:, None] * dpix_dv

    def time_offset(self, pixel: np.ndarray) -> np.ndarray:
        return np.zeros_like(pixel)


def scan_plane(sensor: Whiskbroom | Pushbroom) -> WhiskbroomPlane | PushbroomPlane:
    """The scan-plane terms of a sensor model."""
    if isinstance(sensor, Whiskbroom):
        return WhiskbroomPlane(sensor)
    if isinstance(sensor, Pushbroom):
        return PushbroomPlane(sensor)
    raise TypeError(f"no image-measurement model for sensor {type(sensor).__name__}")
