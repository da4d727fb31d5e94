"""GPS/IMU errors of a strip: what separates the measured stream from the true flight.

Per strip, every term recorded separately (truth/errors_<strip>.csv) so that the lead, the tests and
the reports can verify what an adjustment recovers:

* datum shift: a constant 3D offset of random direction and a length drawn in ``shift_m``;
* datum rotation: a small rotation of the whole strip (positions about the strip's centre, and the
  attitude with it), angles of sigma ``rotation_deg``;
* attitude offset: constant roll/pitch/heading errors of sigma ``attitude_offset_deg``;
* drift: Legendre polynomials in normalised time up to ``drift_degree`` (position and attitude);
* random walk: integrated white noise (``random_walk_m`` per sqrt(s), ``random_walk_deg`` per sqrt(s));
* jumps: steps of length ``jump_m`` at random epochs;
* height wander: a smooth random vertical error of standard deviation ``height_wander_m``;
* excursions: piecewise-smooth position (and roll) errors through values at chosen image lines,
  continuous with kinks at the inner lines (the "problem strip" of the Vienna 2000 flight);
* white noise.

Position errors are in the project frame (x east, y north, z up, metres); attitude errors are added
to the NED roll, pitch, heading (radians).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.polynomial import legendre

from scangeo.frames import MapFrame
from scangeo.rotation import matrix_to_rph, small_rotation
from scangeo.simulate.config import StripErrorConfig
from scangeo.trajectory import GpsImuStream

POSITION_TERMS = ("shift", "rotation", "drift", "random_walk", "jumps", "height_wander", "excursion", "white_noise")
ATTITUDE_TERMS = ("offset", "rotation", "drift", "random_walk", "excursion", "white_noise")


@dataclass(frozen=True)
class StripErrors:
    """The injected errors of one strip at its GPS/IMU epochs.

    position : term -> (n, 3) metres (project frame); attitude : term -> (n, 3) radians
    (roll, pitch, heading); ``parameters`` the drawn constants (shift vector, rotation angles,
    jump epochs, ...) for the record.
    """

    time: np.ndarray
    position: dict[str, np.ndarray]
    attitude: dict[str, np.ndarray]
    parameters: dict = field(default_factory=dict)

    @property
    def position_total(self) -> np.ndarray:
        return np.sum(list(self.position.values()), axis=0)

    @property
    def attitude_total(self) -> np.ndarray:
        return np.sum(list(self.attitude.values()), axis=0)


def piecewise_excursion(t: np.ndarray, t_knots: np.ndarray, values: tuple, bulges: tuple,
                        shape: str = "kinked") -> np.ndarray:
    """Through ``values`` at ``t_knots``, constant outside: ``kinked`` joins them linearly and adds a
    half-sine ``bulge`` per piece (C0, kinks at the knots); ``smooth`` is a natural cubic spline through
    them (C2) plus the same bulges."""
    if not len(values):
        return np.zeros_like(t)
    if shape == "smooth" and len(values) > 2:
        from scipy.interpolate import CubicSpline

        out = CubicSpline(t_knots, values, bc_type="natural")(np.clip(t, t_knots[0], t_knots[-1]))
    else:
        out = np.interp(t, t_knots, values)
    for k, b in enumerate(bulges):
        a, c = t_knots[k], t_knots[k + 1]
        inside = (t >= a) & (t <= c)
        out[inside] += b * np.sin(np.pi * (t[inside] - a) / (c - a))
    return out


def _smooth_random(t: np.ndarray, sigma: float, rng: np.random.Generator, periods=(60.0, 400.0), m: int = 6):
    if sigma <= 0:
        return np.zeros_like(t)
    f = 1.0 / rng.uniform(periods[0], periods[1], m)
    phase = rng.uniform(0, 2 * np.pi, m)
    s = np.sin(2 * np.pi * f[None, :] * t[:, None] + phase[None, :]).sum(axis=1)
    return sigma * s / np.sqrt(m / 2.0)


def draw_errors(config: StripErrorConfig, time: np.ndarray, first_line_time: float, line_rate: float,
                centre_P: np.ndarray, p_P: np.ndarray, rng: np.random.Generator) -> StripErrors:
    """Draw every error term of a strip at its epochs.

    Parameters
    ----------
    time : (n,) GPS/IMU epochs, seconds.
    first_line_time, line_rate : the strip's line timing (excursion epochs are given in lines).
    centre_P : (3,) the strip's centre (rotation centre), project frame.
    p_P : (n, 3) true positions, project frame (for the datum rotation's position effect).
    """
    n = len(time)
    deg = np.pi / 180.0
    pos: dict[str, np.ndarray] = {}
    att: dict[str, np.ndarray] = {}
    params: dict = {}

    direction = rng.standard_normal(3)
    direction /= np.linalg.norm(direction)
    shift = direction * rng.uniform(config.shift_m[0], config.shift_m[1])
    pos["shift"] = np.tile(shift, (n, 1))
    params["shift_m"] = shift.tolist()

    angles = rng.standard_normal(3) * config.rotation_deg * deg
    R = small_rotation(angles)
    pos["rotation"] = (p_P - centre_P) @ (R - np.eye(3)).T
    params["rotation_deg"] = (angles / deg).tolist()
    params["rotation_centre_P"] = np.asarray(centre_P).tolist()

    offset = rng.standard_normal(3) * config.attitude_offset_deg * deg
    att["offset"] = np.tile(offset, (n, 1))
    params["attitude_offset_deg"] = (offset / deg).tolist()

    tau = 2.0 * (time - time[0]) / (time[-1] - time[0]) - 1.0
    d = max(config.drift_degree, 1)
    coef_p = np.zeros((d + 1, 3))
    coef_p[1:] = rng.standard_normal((d, 3)) * config.drift_m / np.sqrt(d)
    coef_a = np.zeros((d + 1, 3))
    coef_a[1:] = rng.standard_normal((d, 3)) * config.drift_deg * deg / np.sqrt(d)
    pos["drift"] = legendre.legval(tau, coef_p).T
    att["drift"] = legendre.legval(tau, coef_a).T
    params["drift_legendre_m"] = coef_p.tolist()
    params["drift_legendre_deg"] = (coef_a / deg).tolist()

    dt = np.diff(time, prepend=time[0])[:, None]
    pos["random_walk"] = np.cumsum(rng.standard_normal((n, 3)) * config.random_walk_m * np.sqrt(dt), axis=0)
    att["random_walk"] = np.cumsum(rng.standard_normal((n, 3)) * config.random_walk_deg * deg * np.sqrt(dt), axis=0)

    jumps = np.zeros((n, 3))
    epochs = []
    if config.jumps:
        span = time[-1] - time[0]
        for _ in range(config.jumps):
            epoch = time[0] + rng.uniform(0.2, 0.8) * span
            step = rng.standard_normal(3)
            step *= config.jump_m / np.linalg.norm(step)
            jumps[time >= epoch] += step
            epochs.append({"time": float(epoch), "step_m": step.tolist()})
    pos["jumps"] = jumps
    params["jumps"] = epochs

    wander = np.zeros((n, 3))
    wander[:, 2] = _smooth_random(time - time[0], config.height_wander_m, rng)
    pos["height_wander"] = wander

    t_knots = first_line_time + np.asarray(config.excursion_lines, float) / line_rate
    excursion = np.zeros((n, 3))
    for k, (values, bulges) in enumerate(((config.excursion_x_m, config.bulge_x_m),
                                          (config.excursion_y_m, config.bulge_y_m),
                                          (config.excursion_z_m, config.bulge_z_m))):
        excursion[:, k] = piecewise_excursion(time, t_knots, values, bulges or (0.0,) * max(len(values) - 1, 0),
                                             config.excursion_shape)
    pos["excursion"] = excursion
    roll_exc = np.zeros((n, 3))
    roll_exc[:, 0] = deg * piecewise_excursion(
        time,
        t_knots,
        config.excursion_roll_deg,
        config.bulge_roll_deg or (0.0,) * max(len(config.excursion_roll_deg) - 1, 0),
        config.excursion_shape,
    )
    att["excursion"] = roll_exc

    pos["white_noise"] = rng.standard_normal((n, 3)) * config.white_noise_m
    att["white_noise"] = rng.standard_normal((n, 3)) * config.white_noise_deg * deg
    att["rotation"] = np.zeros((n, 3))  # filled by apply_errors (depends on the attitude itself)
    params["rotation_matrix"] = R.tolist()
    return StripErrors(np.asarray(time, float), pos, att, params)


def apply_errors(true: GpsImuStream, errors: StripErrors, map_frame: MapFrame) -> tuple[GpsImuStream, StripErrors]:
    """The measured stream (true + errors) and the errors with the rotation's attitude term filled in.

    Positions: ``p_meas = p_true + sum(position terms)``; attitude: ``R_PB' = R_datum R_PB_true`` expressed
    in the measured position's NED frame, then the other attitude terms added to roll, pitch, heading.
    """
    frame = map_frame.frame
    p_true = frame.geodetic_to_project(true.lat, true.lon, true.h)
    p_meas = p_true + errors.position_total
    lat, lon, h = frame.project_to_geodetic(p_meas)
    R_datum = np.asarray(errors.parameters["rotation_matrix"])
    R_PB = R_datum @ frame.R_PL(true.lat, true.lon) @ true.R_LB()
    R_LB = np.swapaxes(frame.R_PL(lat, lon), -1, -2) @ R_PB
    roll, pitch, heading = matrix_to_rph(R_LB)
    heading = true.heading + np.angle(np.exp(1j * (heading - true.heading)))
    rotation_att = np.column_stack([roll - true.roll, pitch - true.pitch, heading - true.heading])
    attitude = dict(errors.attitude)
    attitude["rotation"] = rotation_att
    filled = StripErrors(errors.time, errors.position, attitude, errors.parameters)
    total = filled.attitude_total
    measured = GpsImuStream(
        true.time,
        lat,
        lon,
        h,
        true.roll + total[:, 0],
        true.pitch + total[:, 1],
        true.heading + total[:, 2],
        source=true.source.replace("truth", "measured"),
    )
    return measured, filled
