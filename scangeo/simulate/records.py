"""The files of a simulated block: the project (project.toml, DTM, GPS/IMU, points) and its truth/ folder.

Per flight line ``nav/<id>.csv`` (the GPS/IMU as measured), ``truth/trajectory_<id>.csv`` and
``truth/errors_<id>.csv``; per image strip its measurements in points.csv. ``truth/errors.json`` holds
the drawn constants per flight line and each sensor's true mounting: for one ``[sensor]`` the lists of
before (``true_boresight_deg``, ``boresight_error_deg``, per strip ``strips``), for a platform a table
per sensor id (``true_boresight_deg``, ``boresight_error_deg``, ``true_lever_arm_m``), the true relative
mountings and per flight line ``flight_lines`` (docs/simulate.md).
"""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from scangeo.adjustment.mounting import relative_rotation
from scangeo.atomic import write_text
from scangeo.frames import MapFrame
from scangeo.simulate import writer
from scangeo.simulate.config import SimulationConfig
from scangeo.simulate.flight import FlightPlan, StripPlan
from scangeo.simulate.platform import SimulatedFlightLine, SimulatedStrip, look_angle_table
from scangeo.simulate.points import PointSet
from scangeo.simulate.seeds import rng_for
from scangeo.simulate.terrain import Terrain
from scangeo.trajectory import write_trajectory_csv


def _mean_errors(line: SimulatedFlightLine, plan_strip: StripPlan, line_rate: float) -> dict:
    """Mean position and attitude error over the strip's imaging time: what a degree-0 (SE)
    correction would take up, before the boresight error (which adds to the attitude part)."""
    t = line.errors.time
    t1 = plan_strip.first_line_time + (plan_strip.lines - 1) / line_rate
    inside = (t >= plan_strip.first_line_time) & (t <= t1)
    return {"mean_position_error_m": line.errors.position_total[inside].mean(axis=0).tolist(),
            "mean_attitude_error_deg": np.degrees(line.errors.attitude_total[inside].mean(axis=0)).tolist()}


def true_relative_mountings(config: SimulationConfig, configured: bool = False) -> list[dict]:
    """The true relative mountings: roll, pitch, heading of ``R_BS(reference)^T R_BS(sensor)`` (deg) and the
    lever-arm difference sensor minus reference (m, body frame); of the configured pairs (``configured``), or
    of every sensor to the first and then the configured pairs that are not among those."""
    sensors = {s.id: s for s in config.platform.sensors}
    pairs = [(r.sensor, r.reference) for r in config.platform.relative_mountings]
    if not configured:
        first = config.platform.sensors[0].id
        pairs = list(dict.fromkeys([(s, first) for s in sensors if s != first] + pairs))
    out = []
    for sensor, reference in pairs:
        s, ref = sensors[sensor], sensors[reference]
        rel = relative_rotation(np.radians(np.add(s.boresight_deg, s.boresight_error_deg)),
                                np.radians(np.add(ref.boresight_deg, ref.boresight_error_deg)))
        out.append({"sensor": sensor, "reference": reference, "boresight_deg": np.degrees(rel).tolist(),
                    "lever_arm_m": np.subtract(s.lever_arm_m, ref.lever_arm_m).tolist()})
    return out


def relative_mounting_priors(config: SimulationConfig, seed: int) -> list[dict]:
    """The ``[[relative_mountings]]`` of project.toml: the true relative mountings plus noise of their sigmas."""
    rng = rng_for(seed, "relative mountings")
    out = []
    for r, true in zip(config.platform.relative_mountings, true_relative_mountings(config, configured=True)):
        entry: dict = {"sensor": r.sensor, "reference": r.reference}
        sigma = np.array(r.boresight_sigma_deg)
        entry["boresight_deg"] = np.add(true["boresight_deg"], rng.standard_normal(3) * sigma)
        entry["boresight_sigma_deg"] = sigma
        if r.lever_arm_sigma_m:
            sigma = np.array(r.lever_arm_sigma_m)
            entry["lever_arm_m"] = np.add(true["lever_arm_m"], rng.standard_normal(3) * sigma)
            entry["lever_arm_sigma_m"] = sigma
        out.append(entry)
    return out


def _errors_record(config: SimulationConfig, plan: FlightPlan, lines: list[SimulatedFlightLine],
                   crab: float) -> dict:
    """truth/errors.json."""
    problem = plan.strips[config.gpsimu_errors.problem_strip - 1].strip_id if config.gpsimu_errors.problem_strip \
        else None
    per_line = {line.line_id: {**line.errors.parameters, **_mean_errors(line, line.plan, plan.line_rate_hz)}
                for line in lines}
    frame = {"position_frame": "project frame P (x east, y north, z up) of project.toml's origin"}
    if not config.is_platform:
        sensor = config.sensor
        return {
            "problem_strip": problem,
            "breaks_lines": list(config.gpsimu_errors.breaks_lines),
            "boresight_error_deg": list(sensor.boresight_error_deg),
            **({"calibration_error": {"across_offset_deg": sensor.across_offset_error_deg,
                                      "across_scale": sensor.across_scale_error,
                                      "along_offset_deg": sensor.along_offset_error_deg}}
               if sensor.kind == "pushbroom" else {}),
            "true_boresight_deg": list(np.add(sensor.boresight_deg, sensor.boresight_error_deg)),
            "crab_deg": float(np.degrees(crab)),
            **frame,
            "strips": per_line,
        }
    sensors = config.platform.sensors
    return {
        "problem_flight_line": problem,
        "breaks_lines": list(config.gpsimu_errors.breaks_lines),
        "breaks_lines_sensor": config.reference_sensor.id if config.gpsimu_errors.breaks_lines else None,
        "boresight_error_deg": {s.id: list(s.boresight_error_deg) for s in sensors},
        "true_boresight_deg": {s.id: list(np.add(s.boresight_deg, s.boresight_error_deg)) for s in sensors},
        "true_lever_arm_m": {s.id: list(s.lever_arm_m) for s in sensors},
        "calibration_error": {s.id: {"across_offset_deg": s.across_offset_error_deg,
                                     "across_scale": s.across_scale_error,
                                     "along_offset_deg": s.along_offset_error_deg}
                              for s in sensors if s.kind == "pushbroom"},
        "true_relative_mountings": true_relative_mountings(config),
        "crab_deg": float(np.degrees(crab)),
        **frame,
        "flight_lines": per_line,
    }


def write_project(root: Path, config: SimulationConfig, seed: int, map_frame: MapFrame, terrain: Terrain,
                  plan: FlightPlan, lines: list[SimulatedFlightLine], strips: list[SimulatedStrip],
                  points: PointSet, crab: float, laser_strips: tuple = ()) -> None:
    """Every file of the project and its truth but the images, the truth orthoimage and the LAS files.

    ``laser_strips``: the platform's :class:`~scangeo.simulate.laser_strip.SimulatedLaserStrip` (written
    already), which project.toml lists after the image strips of their flight line."""
    image_ext = ".tif" if config.output.image_format == "GTiff" else ".bsq"
    for line in lines:
        write_trajectory_csv(root / "nav" / f"{line.line_id}.csv", line.measured)
        write_trajectory_csv(root / "truth" / f"trajectory_{line.line_id}.csv", line.true_stream)
        writer.write_errors(root / "truth" / f"errors_{line.line_id}.csv", line.errors)
    entries: list[dict] = []
    for s in strips:
        entry: dict = {"id": s.strip_id, **({"sensor": s.sensor, "flight_line": s.flight_line} if config.is_platform
                                      else {"trajectory": f"nav/{s.strip_id}.csv"}),
                 "first_line_time": s.geometry.timing.first_line_time, "lines": s.geometry.n_lines}
        if config.output.images:
            entry["image"] = f"images/{s.strip_id}{image_ext}"
        entries.append(entry)
    for laser in laser_strips:
        entries.append({"id": laser.strip_id, "sensor": laser.sensor, "flight_line": laser.flight_line,
                        "las": laser.las, "point_source_id": laser.point_source_id})
    order = {line.line_id: k for k, line in enumerate(lines)}
    entries.sort(key=lambda e: order[str(e.get("flight_line", e["id"]))])  # stable: a flight line's strips together

    frame = map_frame.frame
    origin = (float(np.degrees(frame.lat0)), float(np.degrees(frame.lon0)), float(frame.h0))
    writer.write_raster(root / "dtm.tif", terrain.dtm, description="DTM height (orthometric, m)")
    writer.write_raster(root / "truth" / "terrain.tif", terrain.true, description="true terrain height (m)")
    writer.write_raster(root / "truth" / "dtm_error.tif",
                        dataclasses.replace(terrain.dtm, values=terrain.dtm_error), description="DTM minus truth (m)")
    pc = config.points
    sigmas = {
        "control": (pc.control_sigma_xy_m, pc.control_sigma_z_m),
        "check": (pc.control_sigma_xy_m, pc.control_sigma_z_m),
        "height": (pc.height_sigma_xy_m, pc.height_sigma_z_m),
    }
    rng = rng_for(seed, "ground coordinates")
    given = np.column_stack([points.x, points.y, points.z])
    for i, kind in enumerate(points.kind):
        role = {"E": "control", "B": "check", "K": "check", "H": "height"}.get(kind)
        if role:
            sxy, sz = sigmas[role]
            given[i] += rng.standard_normal(3) * np.array([sxy, sxy, sz])
    writer.write_points(root, points, [sim.strip_id for sim in strips], pc.measurement_sigma_px, given, sigmas)
    writer.write_json(root / "truth" / "errors.json", _errors_record(config, plan, lines, crab))
    writer.write_json(
        root / "truth" / "scenario.json",
        {
            "seed": seed,
            "config_source": config.source,
            "config": config.record(),
            "crs": map_frame.crs.to_string(),
            "origin_deg": origin,
            "flight_height_m": plan.flight_height_m,
            "swath_m": plan.swath_m,
            "strip_spacing_m": plan.spacing_m,
            "strips": [dataclasses.asdict(s) for s in plan.strips],
            **({"sensors": [{"id": s.id, "kind": s.kind} for s in config.platform.sensors],
                "image_strips": [{"id": s.strip_id, "sensor": s.sensor, "flight_line": s.flight_line,
                                  "lines": s.geometry.n_lines} for s in strips],
                "laser_strips": [dataclasses.asdict(s) for s in laser_strips]} if config.is_platform else {}),
        },
    )
    for sensor in config.sensors():
        if sensor.kind == "pushbroom":
            name = f"sensors/{sensor.id}.csv" if config.is_platform else "look_angles.csv"
            writer.write_look_angles(root / name, look_angle_table(sensor))
    common = dict(crs=map_frame.crs.to_string(), origin_deg=origin, geoid_undulation_m=config.block.geoid_undulation_m,
                  dtm_sigma_m=config.terrain.dtm_error_sigma_m, strips=entries)
    if config.is_platform:
        text = writer.project_toml(sensor=None, sensors=config.platform.sensors,
                                   relative_mountings=tuple(relative_mounting_priors(config, seed)),
                                   flight_lines=tuple({"id": line.line_id, "trajectory": f"nav/{line.line_id}.csv"}
                                                      for line in lines), **common)
    else:
        text = writer.project_toml(sensor=config.sensor, **common)
    write_text(root / "project.toml", text)


__all__ = ["relative_mounting_priors", "true_relative_mountings", "write_project"]
