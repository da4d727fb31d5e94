"""Whether two imported lines' navigation is one stretch of one GNSS/INS: the figures and the verdict.

Two cameras on one aircraft record their lines with one GNSS/INS; a tool such as PARGE then keeps a
copy of the navigation per line, sampled at the line's own times (one record a line), sometimes with
the camera's offsets folded into the attitude angles. :func:`compare_navigation` compares such a
copy with another at the other's times:

* **time**: the share of the other's records inside the reference's span, and the time offset
  between the two copies (the shift of the other's times that makes its attitudes agree best with
  the reference's, at most :attr:`AgreementThresholds.time_offset_s`);
* **positions**: north, east, up differences (m) at the other's times, as given and after the time
  offset;
* **attitude**: the differences of roll, pitch and heading (deg, as angles: what folded-in offsets
  change), their constant part and their rms beyond it, as given and after the time offset; and the
  rotation between the two attitudes, its constant part and the angle by which it departs from it
  (rms, largest): offsets added to the angles are a constant rotation of the body only in level
  flight.

The reference is interpolated with a cubic spline through its records (as the orientation spline of a
project with a knot per record). :class:`AgreementThresholds` says when two copies are one: every
threshold is written into ``import.json`` beside the figures.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.optimize import minimize_scalar

from scangeo.rotation import matrix_to_rph, rph_to_matrix, unwrap_heading
from scangeo.trajectory.stream import GpsImuStream

#: metres per radian of latitude and of longitude at the equator (WGS84 semi-major axis): the position
#: differences are figures, not geodesy (a few centimetres, exact to 0.7 %)
_EARTH_M = 6378137.0


@dataclass(frozen=True)
class AgreementThresholds:
    """When two lines' navigation is taken as one stretch of one GNSS/INS.

    ``overlap``: the share of the other line's records within the reference's span; ``time_offset_s``:
    the largest time offset searched for and accepted; ``position_m``: the largest position difference
    after the time offset; ``attitude_rms_deg``: the rms of the attitude angles' differences beyond
    their constant part, after the time offset. The defaults are some five to ten times what one
    INS's copies of the shared HySpex pair show (6 cm, 0.002 deg after 1.5 ms: docs/real-data.md),
    and well below what two navigation systems show (decimetres to metres, 0.01-0.1 deg).
    """

    overlap: float = 0.9
    time_offset_s: float = 0.05
    position_m: float = 0.30
    attitude_rms_deg: float = 0.02


@dataclass(frozen=True)
class NavigationAgreement:
    """How the other line's navigation agrees with the reference's (module docstring; degrees, metres, s).

    ``attitude_constant_deg``: the mean differences (other minus reference) of roll, pitch, heading as
    angles; ``attitude_rms_deg``: their rms beyond it (both as given, and ``_shifted`` after the time
    offset); ``rotation_constant_deg``: roll, pitch, heading of the mean body rotation from the
    reference's attitude to the other's; ``rotation_departure_deg``: rms and largest angle between each
    record's rotation and that constant. ``position_*_m``: largest distance and the mean north, east,
    up differences (other minus reference).
    """

    overlap: float
    common_records: int
    time_offset_s: float
    position_max_m: float
    position_mean_neu_m: tuple[float, float, float]
    position_max_shifted_m: float
    position_mean_neu_shifted_m: tuple[float, float, float]
    attitude_constant_deg: tuple[float, float, float]
    attitude_rms_deg: tuple[float, float, float]
    attitude_constant_shifted_deg: tuple[float, float, float]
    attitude_rms_shifted_deg: tuple[float, float, float]
    rotation_constant_deg: tuple[float, float, float]
    rotation_departure_deg: tuple[float, float]

    def agrees(self, thresholds: AgreementThresholds) -> tuple[bool, list[str]]:
        """Whether the two are one stretch of one GNSS/INS, and the reasons they are not."""
        why = []
        if self.overlap < thresholds.overlap:
            why.append(f"{100 * self.overlap:.0f} % of the records within the reference's time span (at least "
                       f"{100 * thresholds.overlap:.0f} % expected)")
            return False, why
        if abs(self.time_offset_s) >= thresholds.time_offset_s:
            why.append(f"a time offset of {self.time_offset_s:.3f} s (below {thresholds.time_offset_s:g} s expected)")
        if self.position_max_shifted_m > thresholds.position_m:
            why.append(f"positions up to {self.position_max_shifted_m:.2f} m apart (at most "
                       f"{thresholds.position_m:g} m expected)")
        worst = max(self.attitude_rms_shifted_deg)
        if worst > thresholds.attitude_rms_deg:
            why.append(f"attitude angles {worst:.3f} deg rms apart beyond a constant (at most "
                       f"{thresholds.attitude_rms_deg:g} deg expected)")
        return not why, why


def _angles_deg(s: GpsImuStream) -> np.ndarray:
    return np.degrees(np.column_stack([s.roll, s.pitch, unwrap_heading(np.asarray(s.heading))]))


def _neu_m(s: GpsImuStream, lat0: float) -> np.ndarray:
    """North, east, up (m) on a plane tangent at latitude ``lat0`` (rad): one scale for both streams."""
    return np.column_stack([np.asarray(s.lat) * _EARTH_M, np.asarray(s.lon) * _EARTH_M * np.cos(lat0),
                            np.asarray(s.h)])


def compare_navigation(reference: GpsImuStream, other: GpsImuStream,
                       thresholds: AgreementThresholds | None = None) -> NavigationAgreement:
    """Compare ``other`` with ``reference`` at the other's times (module docstring); the time offset is
    searched within ``thresholds.time_offset_s`` (default :class:`AgreementThresholds`)."""
    thresholds = thresholds or AgreementThresholds()
    t_ref, t = np.asarray(reference.time), np.asarray(other.time)
    inside = (t >= t_ref[0]) & (t <= t_ref[-1])
    overlap = float(inside.mean())
    if inside.sum() < 4 or len(t_ref) < 4:  # no common stretch to compare
        nan3 = (np.nan, np.nan, np.nan)
        return NavigationAgreement(overlap, int(inside.sum()), np.nan, np.nan, nan3, np.nan, nan3, nan3, nan3, nan3,
                                   nan3, nan3, (np.nan, np.nan))
    angles_ref = CubicSpline(t_ref, _angles_deg(reference), axis=0)
    lat0 = float(np.mean(reference.lat))
    positions_ref = CubicSpline(t_ref, _neu_m(reference, lat0), axis=0)
    angles = _angles_deg(other)[inside]
    heading_turns = np.round((angles[0, 2] - angles_ref(t[inside][0])[2]) / 360.0) * 360.0
    angles[:, 2] -= heading_turns
    positions = _neu_m(other, lat0)[inside]
    times = t[inside]
    margin = thresholds.time_offset_s

    def spread(dt: float) -> float:
        ok = (times + dt >= t_ref[0]) & (times + dt <= t_ref[-1])
        d = angles[ok] - angles_ref(times[ok] + dt)
        return float(np.sum(np.var(d, axis=0)))

    found = minimize_scalar(spread, bounds=(-margin, margin), method="bounded",
                            options={"xatol": 1e-6})
    dt = float(found.x)

    def figures(shift: float):
        ok = (times + shift >= t_ref[0]) & (times + shift <= t_ref[-1])
        d_pos = positions[ok] - positions_ref(times[ok] + shift)
        d_ang = angles[ok] - angles_ref(times[ok] + shift)
        return (float(np.linalg.norm(d_pos, axis=1).max()), _triple(d_pos.mean(axis=0)), _triple(d_ang.mean(axis=0)),
                _triple(d_ang.std(axis=0)))

    pos_max, pos_mean, att_mean, att_rms = figures(0.0)
    pos_max_s, pos_mean_s, att_mean_s, att_rms_s = figures(dt)
    constant, departure = _rotation_figures(angles, angles_ref(times + dt))
    return NavigationAgreement(overlap, int(inside.sum()), dt, pos_max, pos_mean, pos_max_s, pos_mean_s, att_mean,
                               att_rms, att_mean_s, att_rms_s, constant, departure)


def _rotation_figures(angles_deg: np.ndarray, angles_ref_deg: np.ndarray):
    """The mean body rotation from the reference's attitudes to the other's, and the departure from it."""
    a, b = np.radians(angles_deg), np.radians(angles_ref_deg)
    relative = np.einsum("nji,njk->nik", rph_to_matrix(b[:, 0], b[:, 1], b[:, 2]),
                         rph_to_matrix(a[:, 0], a[:, 1], a[:, 2]))
    mean = mean_rotation(relative)
    angle = rotation_angles_deg(np.einsum("ji,njk->nik", mean, relative))
    return _triple(np.degrees(matrix_to_rph(mean))), (float(np.sqrt(np.mean(angle**2))), float(angle.max()))


def mean_rotation(R: np.ndarray) -> np.ndarray:
    """The rotation closest (Frobenius) to the mean of ``R`` (n, 3, 3)."""
    u, _, vt = np.linalg.svd(R.sum(axis=0))
    return u @ np.diag([1.0, 1.0, np.linalg.det(u @ vt)]) @ vt


def rotation_angles_deg(R: np.ndarray) -> np.ndarray:
    """The angle (deg) of each rotation of ``R`` (n, 3, 3)."""
    return np.degrees(np.arccos(np.clip((np.trace(R, axis1=1, axis2=2) - 1.0) / 2.0, -1.0, 1.0)))


def _triple(v) -> tuple[float, float, float]:
    return float(v[0]), float(v[1]), float(v[2])


__all__ = ["AgreementThresholds", "NavigationAgreement", "compare_navigation", "mean_rotation",
           "rotation_angles_deg"]
