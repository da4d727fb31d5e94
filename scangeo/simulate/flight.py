"""Flight planning and the true trajectory of every strip.

Strips run north-south along map grid lines, side by side with the configured sidelap, at a
constant orthometric flight height (mean terrain height + height above ground), at constant ground
speed; the true flight wanders around this plan by the configured dynamics, with a crab angle into
a steady crosswind. Heading follows the true track over the ground (computed in the local NED frame
of every sample, so meridian convergence is in it). The true trajectory of a strip is an
``OrientationSpline`` (project frame) fitted to dense samples; it is the truth from which images
and image measurements are made, and it is written to truth/ at the GPS/IMU rate.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from scangeo.frames import MapFrame
from scangeo.simulate.config import FlightConfig, SensorConfig
from scangeo.simulate.terrain import Extent
from scangeo.trajectory import GpsImuStream, OrientationSpline


@dataclass(frozen=True)
class StripPlan:
    """One planned strip.

    number : 1-based strip number; ``strip_id`` the project's id ("01", ...).
    x : map easting of the centre line (m); y_start, y_end : northing of the first and last line.
    direction : +1 flying north, -1 flying south.
    first_line_time : time of line 0 (s); lines : image lines.
    """

    number: int
    strip_id: str
    x: float
    y_start: float
    y_end: float
    direction: int
    first_line_time: float
    lines: int


@dataclass(frozen=True)
class FlightPlan:
    """All strips of the block and the numbers they were planned from."""

    strips: tuple[StripPlan, ...]
    flight_height_m: float
    swath_m: float
    spacing_m: float
    ground_speed_mps: float
    line_rate_hz: float
    run_in_s: float
    rate_hz: float

    @property
    def strip_duration(self) -> float:
        """Seconds from the first to the last line of a strip."""
        return (self.strips[0].lines - 1) / self.line_rate_hz

    def sample_times(self, strip: StripPlan) -> np.ndarray:
        """GPS/IMU epochs (s) of a strip: multiples of 1/rate covering the strip and its run-in/out."""
        dt = 1.0 / self.rate_hz
        t0 = np.floor((strip.first_line_time - self.run_in_s) / dt)
        t1 = np.ceil((strip.first_line_time + self.strip_duration + self.run_in_s) / dt)
        return np.arange(t0, t1 + 1) * dt


def swath_width(sensor: SensorConfig, height_above_ground_m: float) -> float:
    """Ground swath (m) of a scanner over flat ground."""
    return 2.0 * height_above_ground_m * np.tan(np.radians(sensor.fov_deg) / 2.0)


def block_extent(flight: FlightConfig, sensor: SensorConfig, centre: tuple[float, float]) -> Extent:
    """The map rectangle the strips' footprints and run-ins cover (before any margin)."""
    swath = swath_width(sensor, flight.height_above_ground_m)
    spacing = swath * (1.0 - flight.sidelap)
    width = (flight.strips - 1) * spacing + swath
    length = (
        flight.lines / sensor.line_rate_hz * flight.ground_speed_mps + 2 * flight.run_in_s * flight.ground_speed_mps
    )
    cx, cy = centre
    return Extent(cx - width / 2, cy - length / 2, cx + width / 2, cy + length / 2)


def plan_flight(
    flight: FlightConfig, sensor: SensorConfig, centre: tuple[float, float], mean_height_m: float, time_start_s: float
) -> FlightPlan:
    """Strips side by side around the block centre, in the configured order and directions."""
    swath = swath_width(sensor, flight.height_above_ground_m)
    spacing = swath * (1.0 - flight.sidelap)
    duration = (flight.lines - 1) / sensor.line_rate_hz
    length = duration * flight.ground_speed_mps
    cx, cy = centre
    strips = []
    for k in range(flight.strips):
        if flight.direction == "alternate":
            direction = 1 if k % 2 == 0 else -1
        else:
            direction = 1 if flight.direction == "north" else -1
        t_first = time_start_s + k * (duration + 2 * flight.run_in_s + flight.turn_s)
        strips.append(
            StripPlan(
                number=k + 1,
                strip_id=f"{k + 1:02d}",
                x=cx + (k - (flight.strips - 1) / 2) * spacing,
                y_start=cy - direction * length / 2,
                y_end=cy + direction * length / 2,
                direction=direction,
                first_line_time=round(t_first, 6),
                lines=flight.lines,
            )
        )
    return FlightPlan(
        tuple(strips),
        mean_height_m + flight.height_above_ground_m,
        swath,
        spacing,
        flight.ground_speed_mps,
        sensor.line_rate_hz,
        flight.run_in_s,
        flight.gpsimu_rate_hz,
    )


def true_stream(
    plan: FlightPlan, strip: StripPlan, map_frame: MapFrame, dynamics, crab_rad: float, pitch_trim_rad: float = 0.0
) -> GpsImuStream:
    """The true GPS/IMU stream (geodetic, NED attitude) of a strip at the GPS/IMU epochs.

    Parameters
    ----------
    dynamics : callable t -> (n, 6) deviations (roll, pitch, heading rad; lateral, along, vertical m).
    crab_rad : crab angle into the crosswind (rad) for a northbound strip (mirrored southbound).
    pitch_trim_rad : mean nose-up pitch (rad).
    """
    t = plan.sample_times(strip)
    dev = dynamics(t)
    u = t - strip.first_line_time
    along = plan.ground_speed_mps * u + dev[:, 4]
    x = strip.x + strip.direction * dev[:, 3]  # lateral: positive to the right of the flight
    y = strip.y_start + strip.direction * along
    H = np.full(t.shape, plan.flight_height_m) + dev[:, 5]
    p_P = map_frame.map_to_project(x, y, H)
    lat, lon, h = map_frame.frame.project_to_geodetic(p_P)
    v_P = np.gradient(p_P, t, axis=0)
    R_LP = np.swapaxes(map_frame.frame.R_PL(lat, lon), -1, -2)
    v_L = np.einsum("nij,nj->ni", R_LP, v_P)
    track = np.arctan2(v_L[:, 1], v_L[:, 0])
    heading = np.unwrap(track + strip.direction * crab_rad + dev[:, 2])
    return GpsImuStream(
        t, lat, lon, h, dev[:, 0], pitch_trim_rad + dev[:, 1], heading, source=f"truth strip {strip.strip_id}"
    )


def truth_spline(stream: GpsImuStream, map_frame: MapFrame, rate_hz: float) -> OrientationSpline:
    """The true orientation (project frame) as a cubic B-spline through a true stream."""
    return OrientationSpline.from_trajectory(stream.to_project(map_frame.frame), 1.0 / rate_hz)
