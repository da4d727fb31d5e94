"""A laser scanner on a simulated platform: its strip on a flight line, and its control and check patches.

The laser flies the flight line's true trajectory (the truth spline the line scanners' strips are
recorded with) from the flight line's first line time to its last planned line. Its pulses scan an
oscillating mirror's pattern (:func:`scangeo.simulate.laser_plan.triangle`, ``scan_rate_hz``) over the
full angle ``fov_deg``; each beam of the true pose and the true calibration (boresight plus its error,
lever arm: the laser equation of :func:`scangeo.simulate.laser.beams`) is cast on the true terrain,
and its range gets white noise of ``range_sigma_m``. The LAS file (:func:`scangeo.simulate.laser.write_las`)
holds the points a processor computes from the *measured* GPS/IMU of the flight line (its stream
linearly interpolated, as the laser adjustment reads it) and the nominal calibration: the flight line's
GPS/IMU errors are in the laser's points as in the images.

The control and check patches (``patches.csv``: point,patch,x,y,z,sigma_xy,sigma_z,role, the laser
projects' ground format of docs/formats.md) are four surveyed points each, a 5 m x 4 m rectangle on
open ground, their heights on the true terrain plus noise of ``patch_sigma_m``: control patches in the
zones of the control flight lines, check patches over every flight line.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from scangeo.atomic import write_text
from scangeo.dtm import DTM
from scangeo.frames import MapFrame
from scangeo.lidar.georeference import Calibration, Polar, TrajectorySampler, georeference
from scangeo.sensors.strip import cast_rays
from scangeo.simulate.config import PlatformSensorConfig
from scangeo.simulate.flight import FlightPlan
from scangeo.simulate.laser import beams, write_las
from scangeo.simulate.laser_plan import triangle
from scangeo.simulate.platform import SimulatedFlightLine
from scangeo.simulate.scene import OPEN_GROUND
from scangeo.simulate.terrain import Terrain

#: pulses cast at once (bounds the memory of the rotations: 9 float64 per pulse)
PULSE_CHUNK = 250_000
#: half sides (m) of a patch's surveyed rectangle, as the laser presets' ``survey_half``
SURVEY_HALF = (2.5, 2.0)


@dataclass(frozen=True)
class SimulatedLaserStrip:
    """A laser strip written: ``strip_id`` of ``sensor`` on ``flight_line``, its LAS file (relative to the
    project folder), the returns written and their time span (s)."""

    strip_id: str
    sensor: str
    flight_line: str
    las: str
    returns: int
    t_start: float
    t_end: float
    point_source_id: int


def true_calibration(cfg: PlatformSensorConfig) -> Calibration:
    """The laser's true calibration: its boresight plus the boresight error, its lever arm (rad, m)."""
    return Calibration.of(np.radians(np.add(cfg.boresight_deg, cfg.boresight_error_deg)), cfg.lever_arm_m)


def nominal_calibration(cfg: PlatformSensorConfig) -> Calibration:
    """The calibration project.toml gives (what the LAS points are computed with)."""
    return Calibration.of(np.radians(cfg.boresight_deg), cfg.lever_arm_m)


def record_laser(root: Path, strip_id: str, cfg: PlatformSensorConfig, line: SimulatedFlightLine, t_end: float,
                 true_dtm: DTM, map_frame: MapFrame, rng: np.random.Generator, source_id: int) -> SimulatedLaserStrip:
    """Fly the laser ``cfg`` along ``line`` from its first line time to ``t_end`` and write ``strips/<id>.las``.

    Returns
    -------
    SimulatedLaserStrip
        What was written (the returns that hit the true terrain).
    """
    t0 = line.plan.first_line_time
    n = int(np.floor((t_end - t0) * cfg.pulse_rate_hz + 1e-6)) + 1  # the last pulse at t_end, not beyond
    true_cal, nominal = true_calibration(cfg), nominal_calibration(cfg)
    measured = TrajectorySampler(line.measured.to_project(map_frame.frame), f"measured flight line {line.line_id}")
    parts: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
    for start in range(0, n, PULSE_CHUNK):
        t = t0 + np.arange(start, min(start + PULSE_CHUNK, n)) / cfg.pulse_rate_hz
        theta = np.radians(cfg.fov_deg / 2) * triangle(t - t0, cfg.scan_rate_hz)
        pose = line.true_spline.evaluate(t)
        o, d = beams(pose[:, :3], pose[:, 3:], theta, true_cal)
        hit, status = cast_rays(o, d, true_dtm)
        ok = status == 0
        t, theta = t[ok], theta[ok]
        rho = np.linalg.norm(hit[ok] - o[ok], axis=1) + rng.normal(0.0, cfg.range_sigma_m, int(ok.sum()))
        pos_m, ang_m = measured.at(t)
        parts.append((georeference(pos_m, ang_m, Polar(t, rho, theta, np.zeros_like(t)), nominal), t, theta))
    p_las, t, theta = (np.concatenate([p[k] for p in parts]) for k in range(3))
    las = f"strips/{strip_id}.las"
    write_las(root / las, map_frame, p_las, t, theta, source_id)
    return SimulatedLaserStrip(strip_id, cfg.id, line.line_id, las, int(t.size), float(t[0]), float(t[-1]), source_id)


def write_patches(root: Path, cfg: PlatformSensorConfig, plan: FlightPlan, control_lines: tuple[int, ...],
                  terrain: Terrain, scene, rng: np.random.Generator) -> int:
    """``patches.csv``: the laser's control patches in the zones of the flight lines ``control_lines``
    (0-based; empty: all; none for a laser that ``measures_control`` false) and its check patches over every
    flight line, on open ground inside the imaged
    part of the strips. Returns the number of patches written."""
    half_zone = plan.spacing_m / 2.0
    y_lo = min(plan.strips[0].y_start, plan.strips[0].y_end) + 3.0 * SURVEY_HALF[0]
    y_hi = max(plan.strips[0].y_start, plan.strips[0].y_end) - 3.0 * SURVEY_HALF[0]
    controlled = [k for k in range(len(plan.strips)) if not control_lines or k in control_lines]
    rows: list[str] = []
    corners = np.array([[1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], [1.0, -1.0]]) * SURVEY_HALF
    ring = 8.0 * np.array([[np.cos(a), np.sin(a)] for a in np.linspace(0, 2 * np.pi, 13)])
    plans = [("C", "control", cfg.control_patches if cfg.measures_control else 0, controlled),
             ("K", "check", cfg.check_patches, list(range(len(plan.strips))))]
    number = 0
    for prefix, role, count, lines in plans:
        for i in range(count if lines else 0):
            k = lines[i % len(lines)]
            x0 = plan.strips[k].x
            for _ in range(1000):  # open ground all around the patch
                c = np.array([rng.uniform(x0 - half_zone, x0 + half_zone), rng.uniform(y_lo, y_hi)])
                around = np.vstack([c + ring, c + corners])
                if np.all(np.isin(scene.classes(around[:, 0], around[:, 1]), OPEN_GROUND)):
                    break
            number += 1
            pid = f"{prefix}{number}"
            xy = c + corners
            z = terrain.height(xy[:, 0], xy[:, 1]) + rng.normal(0.0, cfg.patch_sigma_m, 4)
            s = f"{cfg.patch_sigma_m:g}"
            rows += [f"{pid}.{j + 1},{pid},{xy[j, 0]:.4f},{xy[j, 1]:.4f},{z[j]:.4f},{s},{s},{role}" for j in range(4)]
    write_text(root / "patches.csv", "point,patch,x,y,z,sigma_xy,sigma_z,role\n" + "\n".join(rows) + "\n")
    return number


__all__ = ["SimulatedLaserStrip", "nominal_calibration", "record_laser", "true_calibration", "write_patches"]
