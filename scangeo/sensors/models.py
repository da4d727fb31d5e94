"""Line-scanner sensor models: whiskbroom (rotating mirror) and pushbroom (table or pinhole).

Every model answers, vectorised over pixels: the look direction ``look_S(pixel)`` (unit vectors in
the sensor frame S: x along track, y right, z down), the per-pixel time offset ``time_offset(pixel)``
(seconds after the line's time), the inverse ``pixel_of(look_S)`` from the across-track angle, and
the along-track look angle ``along_angle(pixel)`` (0 for a whiskbroom). ``kernel_params()`` packs
the model for the compiled ground <-> image kernels (``scangeo.sensors.kernels``).

Calibration parameters (``calibration_names``) have analytic derivatives of the look direction in
``look_S_derivatives``.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from scangeo.errors import SensorError

KIND_WHISKBROOM = 0
KIND_TABLE = 1
KIND_PINHOLE = 2


@dataclass(frozen=True)
class Whiskbroom:
    """Rotating-mirror scanner.

    Scan angle ``theta(j) = s * (j - j_c) * step * (1 + scale_error) + index_error`` with
    ``j_c = (pixels - 1) / 2`` and ``step = fov / pixels``; ``d = (0, sin theta, cos theta)``.
    Pixel j is recorded at ``t(line) + (j - j_c) * dt_pixel`` with ``dt_pixel = step / (2 pi rate)``
    (one scan per mirror revolution, i.e. the line rate), unless ``per_pixel_timing`` is off.

    Parameters
    ----------
    pixels : pixels per line.
    fov : total scan angle, radians.
    line_rate : lines (mirror revolutions) per second.
    scan_direction : +1 when pixel numbers grow to the right of the flight direction, -1 otherwise.
    per_pixel_timing : apply the per-pixel time offset.
    index_error : scan-angle offset, radians.
    scale_error : scan-angle scale error (unitless, 0 = none).
    """

    pixels: int = 716
    fov: float = float(np.radians(42.9))
    line_rate: float = 25.0
    scan_direction: int = 1
    per_pixel_timing: bool = True
    index_error: float = 0.0
    scale_error: float = 0.0
    calibration_names: tuple[str, ...] = field(default=("index_error", "scale_error"), init=False)

    def __post_init__(self) -> None:
        if self.pixels < 2:
            raise SensorError(f"[sensor] pixels must be at least 2, got {self.pixels}")
        if not 0 < self.fov < np.pi:
            raise SensorError(f"[sensor] fov_deg must be between 0 and 180, got {np.degrees(self.fov):g}")
        if self.scan_direction not in (1, -1):
            raise SensorError(f"[sensor] scan_direction must be +1 or -1, got {self.scan_direction}")
        if not self.line_rate > 0:
            raise SensorError(f"[sensor] line_rate_hz must be positive, got {self.line_rate}")

    @property
    def centre(self) -> float:
        return (self.pixels - 1) / 2.0

    @property
    def step(self) -> float:
        """Angular sampling step (rad per pixel)."""
        return self.fov / self.pixels

    @property
    def dt_pixel(self) -> float:
        """Time between neighbouring pixels (s); 0 with per-pixel timing off."""
        return self.step / (2 * np.pi * self.line_rate) if self.per_pixel_timing else 0.0

    def scan_angle(self, pixel) -> np.ndarray:
        """Scan angle theta (rad, positive to the right) of (fractional) pixels."""
        j = np.asarray(pixel, dtype=float)
        return self.scan_direction * (j - self.centre) * self.step * (1 + self.scale_error) + self.index_error

    def look_S(self, pixel) -> np.ndarray:
        theta = self.scan_angle(pixel)
        return np.stack([np.zeros_like(theta), np.sin(theta), np.cos(theta)], -1)

    def look_S_derivatives(self, pixel) -> dict[str, np.ndarray]:
        """d look_S / d(index_error) and d look_S / d(scale_error), each (n, 3)."""
        j = np.asarray(pixel, dtype=float)
        theta = self.scan_angle(j)
        d_theta = np.stack([np.zeros_like(theta), np.cos(theta), -np.sin(theta)], -1)
        d_scale = (self.scan_direction * (j - self.centre) * self.step)[..., None]
        return {"index_error": d_theta, "scale_error": d_theta * d_scale}

    def along_angle(self, pixel) -> np.ndarray:
        return np.zeros_like(np.asarray(pixel, dtype=float))

    def time_offset(self, pixel) -> np.ndarray:
        return (np.asarray(pixel, dtype=float) - self.centre) * self.dt_pixel

    def pixel_of(self, look_S: np.ndarray) -> np.ndarray:
        """Fractional pixel of sensor-frame directions (from the angle in the y-z plane)."""
        theta = np.arctan2(look_S[..., 1], look_S[..., 2])
        return self.centre + self.scan_direction * (theta - self.index_error) / (self.step * (1 + self.scale_error))

    def kernel_params(self) -> tuple[int, np.ndarray, np.ndarray]:
        p = np.array([self.centre, self.step * (1 + self.scale_error), self.scan_direction,
                      self.index_error, self.dt_pixel, self.pixels], dtype=float)
        return KIND_WHISKBROOM, p, np.zeros((0, 2))

    def with_calibration(self, **values: float) -> Whiskbroom:
        import dataclasses

        return dataclasses.replace(self, **values)  # type: ignore[arg-type]  # calibration fields are floats


@dataclass(frozen=True)
class Pushbroom:
    """Pushbroom line sensor: per-pixel look angles from a table, or a pinhole model, and its calibration.

    The nominal model gives the tangents of the along- and across-track look angles of every
    (fractional) pixel, ``T_a(j)`` and ``T_x(j)``; pixel j looks along ``(tan along, tan across, 1)``
    normalised (sensor frame S: x along track, y right, z down).

    * Table: ``along`` and ``across`` (n_pixels,) radians; ``T_a``, ``T_x`` are linear in the tangents
      between pixel centres (extrapolated linearly beyond the end pixels).
    * Pinhole (when ``focal_length`` is set): detector coordinate ``x_d = (j - principal_point) * pitch``
      (positive to the right), radial distortion ``x_u = x_d (1 + k1 r^2 + k2 r^4)`` with
      ``r^2 = x_d^2 + y0^2``, along-track focal-plane offset ``y0``: ``T_a = y0 / f``, ``T_x = x_u / f``.

    Calibration (the sensor's own unknowns, in the tangents of the look angles)::

        tan across(j) = T_x(j) + across_offset + across_scale * (T_x(j) - T_x(j_c))
        tan along(j)  = T_a(j) + along_offset

    with ``j_c = (pixels - 1) / 2`` the centre pixel. ``across_offset`` moves every pixel's line of
    sight across track (a shift of the detector on the focal plane by ``across_offset * f``);
    ``across_scale`` stretches the swath about the centre pixel (a focal length ``f / (1 + across_scale)``);
    ``along_offset`` tilts the detector line's plane of sight forward (a shift of the detector line by
    ``along_offset * f`` along track). Offsets are tangents: radians of look angle near the centre of
    the field of view (``tan a ~ a``; 1e-3 = 0.057 deg); the scale is relative (0.001 = 0.1 %). A table
    with calibration is again a table: the same affine map applied to its tangents.

    Parameters
    ----------
    pixels : detector elements.
    along, across : nominal look angle tables (rad), for the table form.
    focal_length, pitch, principal_point, k1, k2, line_offset : pinhole form (metres, metres, pixel,
        1/m^2, 1/m^4, metres).
    across_offset, along_offset : calibration offsets of the tangents (rad near the centre of the field).
    across_scale : calibration scale of the across-track tangents about the centre pixel (relative).
    """

    pixels: int
    along: np.ndarray | None = None
    across: np.ndarray | None = None
    focal_length: float | None = None
    pitch: float = 0.0
    principal_point: float | None = None
    k1: float = 0.0
    k2: float = 0.0
    line_offset: float = 0.0
    across_offset: float = 0.0
    across_scale: float = 0.0
    along_offset: float = 0.0
    calibration_names: tuple[str, ...] = field(default=("across_offset", "across_scale", "along_offset"),
                                               init=False)

    def __post_init__(self) -> None:
        if self.focal_length is None:
            if self.along is None or self.across is None:
                raise SensorError("[sensor] a pushbroom needs look-angle tables (along, across) or focal_length")
            if len(self.along) != self.pixels or len(self.across) != self.pixels:
                raise SensorError(
                    f"[sensor] look-angle tables have {len(self.along)}/{len(self.across)} entries, "
                    f"expected {self.pixels}"
                )
            tan_x = np.tan(np.asarray(self.across, dtype=float))
            if not (np.all(np.diff(tan_x) > 0) or np.all(np.diff(tan_x) < 0)):
                raise SensorError("[sensor] across-track look angles must be strictly monotonic over the pixels")
        else:
            if not self.focal_length > 0 or not self.pitch > 0:
                raise SensorError("[sensor] pinhole focal_length and pitch must be positive")
            if self.principal_point is None:
                object.__setattr__(self, "principal_point", (self.pixels - 1) / 2.0)
        for name in ("across_offset", "across_scale", "along_offset"):
            if not np.isfinite(getattr(self, name)):
                raise SensorError(f"[sensor] {name} must be a finite number, got {getattr(self, name)}")
        if not -0.5 < self.across_scale < 0.5:
            raise SensorError(f"[sensor] across_scale must be between -0.5 and 0.5, got {self.across_scale:g}")

    @property
    def is_pinhole(self) -> bool:
        return self.focal_length is not None

    @property
    def centre(self) -> float:
        """The centre pixel ``j_c = (pixels - 1) / 2`` about which ``across_scale`` stretches."""
        return (self.pixels - 1) / 2.0

    @property
    def is_calibrated(self) -> bool:
        """True when any calibration value is not zero."""
        return bool(self.across_offset or self.across_scale or self.along_offset)

    def nominal_tangents(self, pixel) -> tuple[np.ndarray, np.ndarray]:
        """``T_a(j), T_x(j)``: tangents of the nominal (uncalibrated) along- and across-track look angles."""
        j = np.asarray(pixel, dtype=float)
        if self.focal_length is not None:  # pinhole
            assert self.principal_point is not None
            xd = (j - self.principal_point) * self.pitch
            r2 = xd * xd + self.line_offset**2
            xu = xd * (1 + self.k1 * r2 + self.k2 * r2 * r2)
            return np.full_like(j, self.line_offset / self.focal_length), xu / self.focal_length
        idx = np.arange(self.pixels, dtype=float)
        ta, tx = np.tan(np.asarray(self.along, float)), np.tan(np.asarray(self.across, float))
        return _interp_linear(j, idx, ta), _interp_linear(j, idx, tx)

    @property
    def centre_tangent(self) -> float:
        """``T_x(j_c)``: the nominal across-track tangent of the centre pixel."""
        return float(self.nominal_tangents(np.array([self.centre]))[1][0])

    def _tangents(self, pixel) -> tuple[np.ndarray, np.ndarray]:
        ta, tx = self.nominal_tangents(pixel)
        if not self.is_calibrated:
            return ta, tx
        tc = self.centre_tangent
        return ta + self.along_offset, tx + self.across_offset + self.across_scale * (tx - tc)

    def look_S(self, pixel) -> np.ndarray:
        ta, tx = self._tangents(pixel)
        v = np.stack([ta, tx, np.ones_like(ta)], -1)
        return v / np.linalg.norm(v, axis=-1, keepdims=True)

    def look_S_derivatives(self, pixel) -> dict[str, np.ndarray]:
        """d look_S / d(across_offset), d(across_scale), d(along_offset), each (n, 3)."""
        ta, tx = self._tangents(pixel)
        v = np.stack([ta, tx, np.ones_like(ta)], -1)
        norm = np.linalg.norm(v, axis=-1, keepdims=True)
        look = v / norm

        def through(dv: np.ndarray) -> np.ndarray:  # d(v / |v|) = (dv - look (look . dv)) / |v|
            return (dv - look * np.sum(look * dv, -1, keepdims=True)) / norm

        zero = np.zeros_like(ta)
        stretch = self.nominal_tangents(pixel)[1] - self.centre_tangent
        return {"across_offset": through(np.stack([zero, zero + 1, zero], -1)),
                "across_scale": through(np.stack([zero, stretch, zero], -1)),
                "along_offset": through(np.stack([zero + 1, zero, zero], -1))}

    def along_angle(self, pixel) -> np.ndarray:
        return np.arctan(self._tangents(pixel)[0])

    def time_offset(self, pixel) -> np.ndarray:
        return np.zeros_like(np.asarray(pixel, dtype=float))

    def nominal_tangent_of_across(self, tan_across: np.ndarray) -> np.ndarray:
        """The nominal ``T_x`` whose calibrated across-track tangent is ``tan_across`` (the calibration inverted)."""
        if not self.is_calibrated:
            return tan_across
        tc = self.centre_tangent
        return tc + (tan_across - self.across_offset - tc) / (1 + self.across_scale)

    def pixel_of(self, look_S: np.ndarray) -> np.ndarray:
        tx = self.nominal_tangent_of_across(look_S[..., 1] / look_S[..., 2])
        if self.is_pinhole:
            xu = tx * self.focal_length
            xd = xu.copy()
            for _ in range(20):  # Newton on x_d (1 + k1 r^2 + k2 r^4) = x_u
                r2 = xd * xd + self.line_offset**2
                g = xd * (1 + self.k1 * r2 + self.k2 * r2 * r2) - xu
                dg = 1 + self.k1 * (r2 + 2 * xd * xd) + self.k2 * (r2 * r2 + 4 * xd * xd * r2)
                xd = xd - g / dg
            assert self.principal_point is not None  # set in __post_init__
            return xd / self.pitch + self.principal_point
        table = np.tan(np.asarray(self.across, float))
        idx = np.arange(self.pixels, dtype=float)
        if table[0] > table[-1]:
            table, idx = table[::-1], idx[::-1]
        return _interp_linear(tx, table, idx)

    def kernel_params(self) -> tuple[int, np.ndarray, np.ndarray]:
        """Kernel parameters. Table: the calibrated tangents at the pixel centres (``(n, 2)``: along,
        across). Pinhole: ``[pp, pitch, f, k1, k2, y0, T_x(j_c), across_scale, across_offset,
        along_offset, pixels]`` (``scangeo.sensors.kernels`` applies the calibration)."""
        if self.is_pinhole:
            p = np.array(
                [self.principal_point, self.pitch, self.focal_length, self.k1, self.k2, self.line_offset,
                 self.centre_tangent, self.across_scale, self.across_offset, self.along_offset, self.pixels],
                dtype=float,
            )
            return KIND_PINHOLE, p, np.zeros((0, 2))
        ta, tx = self._tangents(np.arange(self.pixels, dtype=float))
        return KIND_TABLE, np.array([self.pixels], dtype=float), np.column_stack([ta, tx])

    def with_calibration(self, **values: float) -> Pushbroom:
        """A copy with other calibration values (``across_offset``, ``across_scale``, ``along_offset``)."""
        import dataclasses

        unknown = set(values) - set(self.calibration_names)
        if unknown:
            raise SensorError(f"[sensor] {', '.join(sorted(unknown))}: not a pushbroom calibration value")
        return dataclasses.replace(self, **values)  # type: ignore[arg-type]  # calibration fields are floats


def _interp_linear(x, xp, fp) -> np.ndarray:
    """Linear interpolation that extrapolates linearly beyond the ends (xp increasing)."""
    x = np.asarray(x, dtype=float)
    y = np.interp(x, xp, fp)
    lo = fp[0] + (x - xp[0]) * (fp[1] - fp[0]) / (xp[1] - xp[0])
    hi = fp[-1] + (x - xp[-1]) * (fp[-1] - fp[-2]) / (xp[-1] - xp[-2])
    return np.where(x < xp[0], lo, np.where(x > xp[-1], hi, y))


SensorModel = Whiskbroom | Pushbroom
