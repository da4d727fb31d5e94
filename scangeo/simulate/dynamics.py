"""Flight dynamics of the true trajectory: attitude oscillations and position wander in turbulence.

A ``Dynamics`` gives, at any time (seconds), the deviations of the aircraft from its planned
straight, level flight: roll, pitch, heading (radians) and lateral, along-track and vertical
position (metres). Two kinds:

* ``SpectralDynamics``: each channel a sum of sinusoids with random phases and log-uniform
  frequencies between the configured periods, amplitudes falling as 1/f (a turbulence-like
  spectrum), scaled to the configured standard deviation; smooth, so a cubic spline at the GPS/IMU
  rate represents it to far below a millimetre.
* ``ReplayDynamics``: roll, pitch, heading and height deviations of a real trajectory (e.g. an
  SBET text export), taken from a straight part of it, high-passed (a moving
  average of ``period_s[1]`` removed) and mirrored end to end to cover any duration; the other
  channels spectral.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import uniform_filter1d

from scangeo.errors import TrajectoryError
from scangeo.simulate.config import TurbulenceConfig
from scangeo.textfile import read_text
from scangeo.trajectory import read_trajectory

CHANNELS = ("roll", "pitch", "heading", "lateral", "along", "vertical")


@dataclass(frozen=True)
class SpectralDynamics:
    """Sums of sinusoids per channel: ``frequency`` (c, m) Hz, ``amplitude`` (c, m), ``phase`` (c, m)."""

    frequency: np.ndarray
    amplitude: np.ndarray
    phase: np.ndarray

    @classmethod
    def from_config(cls, config: TurbulenceConfig, rng: np.random.Generator) -> SpectralDynamics:
        sigmas = np.array([np.radians(config.roll_deg), np.radians(config.pitch_deg), np.radians(config.heading_deg),
                           config.lateral_m, config.along_m, config.vertical_m])
        m = max(int(config.components), 1)
        shortest, longest = sorted(config.period_s)
        f = np.exp(rng.uniform(np.log(1.0 / longest), np.log(1.0 / shortest), (len(CHANNELS), m)))
        a = 1.0 / f
        a *= sigmas[:, None] / np.sqrt(0.5 * (a * a).sum(axis=1, keepdims=True))
        phase = rng.uniform(0.0, 2.0 * np.pi, (len(CHANNELS), m))
        return cls(f, a, phase)

    def __call__(self, t: np.ndarray) -> np.ndarray:
        """Deviations (n, 6) at times t (s): roll, pitch, heading (rad), lateral, along, vertical (m)."""
        t = np.asarray(t, dtype=float)
        out = np.empty((t.size, len(CHANNELS)))
        for c in range(len(CHANNELS)):
            arg = 2.0 * np.pi * self.frequency[c][None, :] * t.ravel()[:, None] + self.phase[c][None, :]
            out[:, c] = np.sin(arg) @ self.amplitude[c]
        return out


@dataclass(frozen=True)
class ReplayDynamics:
    """Attitude and height deviations replayed from a real trajectory, mirrored to any length.

    ``samples`` (n, 4): roll, pitch, heading (rad), vertical (m) at ``time`` (s from 0).
    """

    time: np.ndarray
    samples: np.ndarray
    offset: float
    others: SpectralDynamics

    @classmethod
    def from_file(cls, path: str, config: TurbulenceConfig, rng: np.random.Generator) -> ReplayDynamics:
        time, z, roll, pitch, heading = read_dynamics_source(path)
        rate = 1.0 / np.median(np.diff(time))
        window = max(int(round(config.period_s[1] * rate)), 3)
        straight = _longest_straight_run(roll, np.radians(5.0))
        if straight.stop - straight.start < 3 * window:
            raise TrajectoryError(f"{path}: no straight part of {3 * config.period_s[1]:g} s or more (|roll| < 5 deg)")
        sel = slice(straight.start, straight.stop)
        channels = np.column_stack([roll[sel], pitch[sel], np.unwrap(heading[sel]), z[sel]])
        highpass = channels - uniform_filter1d(channels, window, axis=0, mode="nearest")
        trim = slice(window // 2, len(highpass) - window // 2)
        samples = highpass[trim]
        t = time[sel][trim] - time[sel][trim][0]
        offset = float(rng.uniform(0.0, t[-1]))
        return cls(t, samples, offset, SpectralDynamics.from_config(config, rng))

    def __call__(self, t: np.ndarray) -> np.ndarray:
        t = np.asarray(t, dtype=float).ravel()
        span = self.time[-1]
        m = np.mod(t + self.offset, 2.0 * span)
        local = np.where(m > span, 2.0 * span - m, m)
        out = self.others(t)
        for c, k in enumerate((0, 1, 2, 5)):
            out[:, k] = np.interp(local, self.time, self.samples[:, c])
        return out


def read_dynamics_source(path: str):
    """(time, z, roll, pitch, heading) of a trajectory text (GpsTime, Y, X, Z, Roll, Pitch, Azimuth in
    degrees) or any trajectory file scangeo reads; angles returned in radians."""
    lines = read_text(path, "a trajectory text or CSV", TrajectoryError).splitlines()
    header = lines[0] if lines else ""
    try:
        names = [c.strip().strip('"').lower() for c in header.replace(",", " ").split()]
        if {"gpstime", "z", "roll", "pitch", "azimuth"} <= set(names):
            data = np.loadtxt(lines, delimiter="," if "," in header else None, skiprows=1, ndmin=2)
            col = {n: i for i, n in enumerate(names)}
            return (data[:, col["gpstime"]], data[:, col["z"]], *(np.radians(data[:, col[k]]) for k in
                                                                    ("roll", "pitch", "azimuth")))
    except (OSError, ValueError) as exc:
        raise TrajectoryError(f"{path}: cannot read the trajectory for replay ({exc})") from exc
    stream = read_trajectory(path)
    return stream.time, stream.h, stream.roll, stream.pitch, stream.heading


def _longest_straight_run(roll: np.ndarray, limit: float) -> slice:
    ok = np.abs(roll) < limit
    best, start = slice(0, 0), None
    for i, flag in enumerate(np.append(ok, False)):
        if flag and start is None:
            start = i
        elif not flag and start is not None:
            if i - start > best.stop - best.start:
                best = slice(start, i)
            start = None
    return best


def make_dynamics(config: TurbulenceConfig, rng: np.random.Generator):
    """The dynamics of a TurbulenceConfig."""
    if config.kind == "replay":
        if not config.file:
            raise TrajectoryError("[flight.turbulence] kind = 'replay' needs file = a trajectory to replay")
        return ReplayDynamics.from_file(config.file, config, rng)
    return SpectralDynamics.from_config(config, rng)
