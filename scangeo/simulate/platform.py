"""Flight lines flown once, and every sensor's strip recorded on them.

A simulated block is a platform: one GPS/IMU and one or more sensors. Each planned flight line is
flown once (:func:`fly`): its true trajectory (the truth spline), its GPS/IMU errors and its measured
stream. Each line scanner then records its strip on it (:func:`record`): the strip's geometry is the
sensor's model and true mounting on the flight line's true spline, from the flight line's first line
time for as many lines as the sensor's line rate takes in the planned time. A block of one ``[sensor]``
is the platform of that one sensor: its strips are its flight lines (the strip id is the flight line's).
Laser scanners record their strips in :mod:`scangeo.simulate.laser_strip`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from scangeo.frames import MapFrame
from scangeo.sensors import Mounting, Pushbroom, StripGeometry, Whiskbroom
from scangeo.simulate.config import SensorConfig, SimulationConfig
from scangeo.simulate.flight import FlightPlan, StripPlan, true_stream, truth_spline
from scangeo.simulate.gpsimu_errors import StripErrors, apply_errors, draw_errors
from scangeo.simulate.seeds import rng_for
from scangeo.timing import LineTiming
from scangeo.trajectory import GpsImuStream, OrientationSpline, ProjectTrajectory


@dataclass
class SimulatedFlightLine:
    """One flight line flown: its plan, true trajectory, injected GPS/IMU errors and measured stream.

    ``line_id`` is the flight line's id in project.toml (the plan's strip id, "01", ...); ``true_stream``
    the true navigation at the GPS/IMU epochs, ``true_spline`` the truth (project frame) every sensor's
    strip on the line is recorded with, ``measured`` the GPS/IMU as measured (``nav/<line_id>.csv``).
    """

    line_id: str
    plan: StripPlan
    true_stream: GpsImuStream
    true_spline: OrientationSpline
    errors: StripErrors
    measured: GpsImuStream


@dataclass
class SimulatedStrip:
    """One image strip's truth and measurements in memory: what ``sensor`` recorded on ``flight_line``
    (whose true and measured streams, spline and errors it shares with the other sensors' strips there)."""

    strip_id: str
    true_stream: GpsImuStream
    true_spline: OrientationSpline
    geometry: StripGeometry
    errors: StripErrors
    measured: GpsImuStream
    sensor: str = ""
    flight_line: str = ""


def look_angle_table(sensor_cfg: SensorConfig) -> np.ndarray:
    """A pushbroom's nominal look angles ``(pixels, 3)``: pixel, along_deg, across_deg (``SensorConfig``)."""
    u = np.linspace(-1.0, 1.0, sensor_cfg.pixels)
    across = 0.5 * sensor_cfg.fov_deg * u + sensor_cfg.across_cubic_deg * (u**3 - u)
    along = sensor_cfg.along_deg + sensor_cfg.smile_deg * u**2
    return np.column_stack([np.arange(sensor_cfg.pixels), along, across])


def true_sensor(sensor_cfg: SensorConfig) -> Whiskbroom | Pushbroom:
    """The sensor the images are rendered with: a pushbroom's nominal table with its true calibration."""
    if sensor_cfg.kind == "whiskbroom":
        return Whiskbroom(pixels=sensor_cfg.pixels, fov=np.radians(sensor_cfg.fov_deg),
                          line_rate=sensor_cfg.line_rate_hz, per_pixel_timing=sensor_cfg.pixel_timing)
    table = np.radians(look_angle_table(sensor_cfg)[:, 1:])
    return Pushbroom(sensor_cfg.pixels, along=table[:, 0], across=table[:, 1],
                     across_offset=float(np.radians(sensor_cfg.across_offset_error_deg)),
                     across_scale=sensor_cfg.across_scale_error,
                     along_offset=float(np.radians(sensor_cfg.along_offset_error_deg)))


def true_mounting(sensor_cfg: SensorConfig) -> Mounting:
    """The sensor's true mounting: its lever arm and its boresight plus the boresight error (radians)."""
    boresight = np.radians(np.add(sensor_cfg.boresight_deg, sensor_cfg.boresight_error_deg))
    return Mounting(lever_arm_B=np.array(sensor_cfg.lever_arm_m, float), boresight=boresight)


def strip_id_of(sensor_id: str, line_id: str) -> str:
    """A strip's id: the flight line's for the one sensor of a block, else ``<sensor>-<flight line>``."""
    return f"{sensor_id}-{line_id}" if sensor_id else line_id


def strip_lines(plan: FlightPlan, strip: StripPlan, line_rate_hz: float) -> int:
    """Lines a sensor of ``line_rate_hz`` records from the flight line's first line time until its planned last
    line (the plan's lines at the planned rate: the same number at that rate)."""
    if line_rate_hz == plan.line_rate_hz:
        return strip.lines
    return int(np.floor((strip.lines - 1) * line_rate_hz / plan.line_rate_hz + 1e-9)) + 1


def fly(config: SimulationConfig, seed: int, plan: FlightPlan, map_frame: MapFrame, dynamics,
        crab: float) -> list[SimulatedFlightLine]:
    """Every planned flight line flown: its truth, its GPS/IMU errors (drawn for its number; excursions at
    the planned lines) and the measured stream."""
    out = []
    pitch_trim = np.radians(config.flight.turbulence.pitch_trim_deg)
    for s in plan.strips:
        stream = true_stream(plan, s, map_frame, dynamics, crab, pitch_trim)
        spline = truth_spline(stream, map_frame, plan.rate_hz)
        truth = _stream_of_spline(spline, stream.time, map_frame, s.strip_id)
        p_true = map_frame.frame.geodetic_to_project(truth.lat, truth.lon, truth.h)
        centre_P = p_true[len(p_true) // 2]
        errors = draw_errors(config.strip_errors(s.number), truth.time, s.first_line_time, plan.line_rate_hz,
                             centre_P, p_true, rng_for(seed, f"errors {s.strip_id}"))
        measured, errors = apply_errors(truth, errors, map_frame)
        out.append(SimulatedFlightLine(s.strip_id, s, truth, spline, errors, measured))
    return out


def record(config: SimulationConfig, plan: FlightPlan, lines: list[SimulatedFlightLine]) -> list[SimulatedStrip]:
    """The strip every line scanner records on every flight line, flight line by flight line."""
    scanners = [(s, true_sensor(s), true_mounting(s)) for s in config.sensors() if s.kind != "laser"]
    strips = []
    for line in lines:
        for cfg, model, mounting in scanners:
            sid = strip_id_of(cfg.id, line.line_id)
            n = strip_lines(plan, line.plan, cfg.line_rate_hz)
            geometry = StripGeometry(model, line.true_spline, LineTiming(line.plan.first_line_time, cfg.line_rate_hz),
                                     n, mounting, sid)
            strips.append(SimulatedStrip(sid, line.true_stream, line.true_spline, geometry, line.errors,
                                         line.measured, cfg.id, line.line_id))
    return strips


def _stream_of_spline(spline: OrientationSpline, time: np.ndarray, map_frame: MapFrame, strip_id: str) -> GpsImuStream:
    values = spline.evaluate(time)
    trajectory = ProjectTrajectory(time, values[:, :3], values[:, 3:], f"truth strip {strip_id}")
    return GpsImuStream.from_project(trajectory, map_frame.frame)


__all__ = ["SimulatedFlightLine", "SimulatedStrip", "fly", "look_angle_table", "record", "strip_id_of",
           "strip_lines", "true_mounting", "true_sensor"]
