"""Simulating a whole block: ``simulate(out, config)`` writes a project with known truth.

Order of work: location and frames -> terrain and project DTM -> flight plan -> per strip the true
trajectory, the injected GPS/IMU errors and the measured stream -> points and their measurements
-> files -> images rendered strip by strip -> the truth orthoimage. Every random draw comes from a
generator named after its purpose and seeded by the block's seed, so a seed gives the same block
whatever is switched on or off.
"""
from __future__ import annotations

import dataclasses
import logging
import zlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pyproj

from scangeo.atomic import atomic_directory, write_text
from scangeo.dtm import DTM
from scangeo.errors import ProjectFileError
from scangeo.frames import Geoid, MapFrame, parse_crs
from scangeo.progress import no_progress, scaled
from scangeo.sensors import Mounting, Pushbroom, StripGeometry, Whiskbroom
from scangeo.simulate import writer
from scangeo.simulate.config import SensorConfig, SimulationConfig
from scangeo.simulate.dynamics import make_dynamics
from scangeo.simulate.flight import FlightPlan, block_extent, plan_flight, true_stream, truth_spline
from scangeo.simulate.gpsimu_errors import StripErrors, apply_errors, draw_errors
from scangeo.simulate.ortho import write_truth_ortho
from scangeo.simulate.points import PointSet, measure_points, place_points
from scangeo.simulate.render import render_strip, write_image
from scangeo.simulate.scene import make_scene
from scangeo.simulate.terrain import Extent, Terrain, dtm_centre_lonlat, make_terrain
from scangeo.timing import LineTiming
from scangeo.trajectory import GpsImuStream, OrientationSpline, ProjectTrajectory, write_trajectory_csv

log = logging.getLogger(__name__)


def rng_for(seed: int, purpose: str) -> np.random.Generator:
    """A generator for one purpose ("terrain", "errors 02", ...) of a seeded block."""
    return np.random.default_rng([int(seed) & 0xFFFFFFFF, zlib.crc32(purpose.encode())])


@dataclass
class SimulatedStrip:
    """One strip's truth and measurements in memory."""

    strip_id: str
    true_stream: GpsImuStream
    true_spline: OrientationSpline
    geometry: StripGeometry
    errors: StripErrors
    measured: GpsImuStream


@dataclass
class SimulatedBlock:
    """A simulated block with its truth (:func:`simulate`; also written to its folder).

    Parameters
    ----------
    root : Path
        The project folder written.
    config : SimulationConfig
        The preset's settings with the overrides applied.
    seed : int
        The random seed used.
    map_frame : MapFrame
        The map CRS and the project frame.
    terrain : Terrain
        The true terrain (heights, metres, map CRS).
    plan : FlightPlan
        Flight height, swath and strip spacing, metres.
    strips : list of SimulatedStrip
        Every strip's true and measured orientation.
    points : PointSet
        Every simulated point and measurement (kind, true position, image coordinates, blunders).
    scene : object
        The scene the images were rendered from.
    ortho_extent : Extent
        The extent of the true orthoimage, map CRS.
    """

    root: Path
    config: SimulationConfig
    seed: int
    map_frame: MapFrame
    terrain: Terrain
    plan: FlightPlan
    strips: list[SimulatedStrip]
    points: PointSet
    scene: object
    ortho_extent: Extent


def utm_crs(lon: float, lat: float) -> str:
    zone = int(np.floor((lon + 180.0) / 6.0)) % 60 + 1
    return f"EPSG:{32600 + zone if lat >= 0 else 32700 + zone}"


def resolve_location(config: SimulationConfig, dtm_file: str | None) -> tuple[str, tuple[float, float]]:
    """The map CRS and the block centre (map coordinates).

    With a DTM file the block is centred on the DTM, in the configured CRS when that CRS is meant
    for the place, else in the UTM zone of the centre.
    """
    b = config.block
    if b.crs != "auto":
        parse_crs(b.crs, f"{config.source} [block] crs")
    if dtm_file:
        lon, lat = dtm_centre_lonlat(dtm_file)
        crs = b.crs
        if crs != "auto":
            area = pyproj.CRS.from_user_input(crs).area_of_use
            if area is None or not (area.west <= lon <= area.east and area.south <= lat <= area.north):
                crs = "auto"
    elif b.centre_lonlat:
        lon, lat = b.centre_lonlat
        crs = b.crs
    elif b.centre:
        if b.crs == "auto":
            raise ProjectFileError(f"{config.source} [block.centre]: a map centre needs block.crs (not 'auto')")
        to_geo = pyproj.Transformer.from_crs(b.crs, "EPSG:4326", always_xy=True)
        lon, lat = to_geo.transform(b.centre[0], b.centre[1])
        crs = b.crs
    else:
        raise ProjectFileError(f"{config.source} [block]: give centre (map) or centre_lonlat (degrees)")
    if crs == "auto":
        crs = utm_crs(lon, lat)
    to_map = pyproj.Transformer.from_crs("EPSG:4326", crs, always_xy=True)
    x, y = to_map.transform(lon, lat)
    return crs, (float(x), float(y))


def simulate(out: str | Path, config: SimulationConfig, seed: int | None = None, dtm_file: str | None = None,
             texture: str | None = None, overwrite: bool = False, progress=no_progress) -> SimulatedBlock:
    """Simulate a block and write it as a project folder with a truth/ folder.

    Parameters
    ----------
    out : the project folder to create (it must not exist, or be empty, unless ``overwrite``).
    config : the block's configuration (``load_preset``).
    seed : overrides ``config.seed``.
    dtm_file : a real DTM for the true terrain (overrides the configured terrain).
    texture : an RGB orthophoto for the scene (overrides the configured scene).
    progress : ``callback(done, total, message)``.
    """
    out = Path(out)
    seed = config.seed if seed is None else int(seed)
    if out.exists() and any(out.iterdir()) and not overwrite:
        raise ProjectFileError(f"{out}: the folder exists and is not empty (choose another or overwrite it)")
    with atomic_directory(out) as staging:  # the project appears whole, or not at all
        (staging / "truth").mkdir()
        (staging / "nav").mkdir()
        if config.output.images:
            (staging / "images").mkdir()
        block = _simulate_into(staging, config, seed, dtm_file, texture, progress)
    block.root = out
    return block


def _simulate_into(root: Path, config: SimulationConfig, seed: int, dtm_file, texture, progress) -> SimulatedBlock:
    sensor_cfg, flight_cfg = config.sensor, config.flight
    dtm_source = dtm_file or (config.terrain.file if config.terrain.kind == "file" else None)
    crs, centre = resolve_location(config, dtm_source)
    geoid = Geoid(config.block.geoid_undulation_m)
    map_frame = MapFrame.centred_on(crs, centre[0], centre[1], 0.0, geoid)
    extent = block_extent(flight_cfg, sensor_cfg, centre)
    progress(0, 1, "terrain")
    terrain = make_terrain(config.terrain, extent, map_frame.crs.to_wkt(), rng_for(seed, "terrain"), dtm_source)
    plan = plan_flight(flight_cfg, sensor_cfg, centre, terrain.mean_height(extent), config.block.time_start_s)
    true_dtm = DTM(terrain.true, map_frame, "true terrain")
    dyn_rng = rng_for(seed, "dynamics")
    dynamics = make_dynamics(flight_cfg.turbulence, dyn_rng)
    crab = np.radians(flight_cfg.turbulence.crab_deg) * dyn_rng.uniform(0.7, 1.0)
    sensor = true_sensor(sensor_cfg)
    true_boresight = np.radians(np.add(sensor_cfg.boresight_deg, sensor_cfg.boresight_error_deg))
    mounting = Mounting(lever_arm_B=np.array(sensor_cfg.lever_arm_m, float), boresight=true_boresight)

    strips: list[SimulatedStrip] = []
    for s in plan.strips:
        stream = true_stream(plan, s, map_frame, dynamics, crab, np.radians(flight_cfg.turbulence.pitch_trim_deg))
        spline = truth_spline(stream, map_frame, plan.rate_hz)
        truth = _stream_of_spline(spline, stream.time, map_frame, s.strip_id)
        geometry = StripGeometry(sensor, spline, LineTiming(s.first_line_time, sensor_cfg.line_rate_hz), s.lines,
                                 mounting, s.strip_id)
        p_true = map_frame.frame.geodetic_to_project(truth.lat, truth.lon, truth.h)
        centre_P = p_true[len(p_true) // 2]
        errors = draw_errors(config.strip_errors(s.number), truth.time, s.first_line_time, sensor_cfg.line_rate_hz,
                             centre_P, p_true, rng_for(seed, f"errors {s.strip_id}"))
        measured, errors = apply_errors(truth, errors, map_frame)
        strips.append(SimulatedStrip(s.strip_id, truth, spline, geometry, errors, measured))
    progress(1, 1, "flight")

    scene = make_scene(config.scene, (extent.xmin, extent.ymax) if (texture or config.scene.kind == "texture")
                       else centre, seed, texture)
    geometries = [sim.geometry for sim in strips]
    problem = config.gpsimu_errors.problem_strip
    ids, kinds, xs, ys = place_points(config.points, plan, geometries, map_frame, terrain, scene,
                                      rng_for(seed, "points"), problem, config.gpsimu_errors.breaks_lines)
    points = measure_points(ids, kinds, xs, ys, geometries, map_frame, terrain, scene, config.points,
                            rng_for(seed, "measurements"))
    progress(1, 1, "points")

    _write_project(root, config, seed, map_frame, terrain, plan, strips, points, crab)
    image_ext = ".tif" if config.output.image_format == "GTiff" else ".bsq"
    n = len(strips)
    for k, sim in enumerate(strips if config.output.images else []):
        image = render_strip(sim.geometry, true_dtm, scene, sensor_cfg.noise_dn,
                             rng_for(seed, f"noise {sim.strip_id}"), config.output.line_chunk,
                             scaled(progress, k, k + 1, n), f"image {sim.strip_id}")
        write_image(root / "images" / f"{sim.strip_id}{image_ext}", image, config.output.image_format)
        del image
    half = plan.swath_m / 2.0
    ortho_extent = Extent(min(s.x for s in plan.strips) - half, extent.ymin + plan.run_in_s * plan.ground_speed_mps,
                          max(s.x for s in plan.strips) + half, extent.ymax - plan.run_in_s * plan.ground_speed_mps)
    if config.output.truth_ortho:
        write_truth_ortho(root / "truth" / "ortho.tif", scene, ortho_extent, config.output.ortho_resolution_m,
                          map_frame.crs.to_wkt(), progress=progress)
    return SimulatedBlock(root, config, seed, map_frame, terrain, plan, strips, points, scene, ortho_extent)


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


def _stream_of_spline(spline: OrientationSpline, time: np.ndarray, map_frame: MapFrame, strip_id: str) -> GpsImuStream:
    values = spline.evaluate(time)
    trajectory = ProjectTrajectory(time, values[:, :3], values[:, 3:], f"truth strip {strip_id}")
    return GpsImuStream.from_project(trajectory, map_frame.frame)


def _mean_errors(strip: SimulatedStrip, plan_strip, line_rate: float) -> dict:
    """Mean position and attitude error over the strip's imaging time: what a degree-0 (SE)
    correction would take up, before the boresight error (which adds to the attitude part)."""
    t = strip.errors.time
    t1 = plan_strip.first_line_time + (plan_strip.lines - 1) / line_rate
    inside = (t >= plan_strip.first_line_time) & (t <= t1)
    return {"mean_position_error_m": strip.errors.position_total[inside].mean(axis=0).tolist(),
            "mean_attitude_error_deg": np.degrees(strip.errors.attitude_total[inside].mean(axis=0)).tolist()}


def _write_project(root: Path, config: SimulationConfig, seed: int, map_frame: MapFrame, terrain: Terrain,
                   plan: FlightPlan, strips: list[SimulatedStrip], points: PointSet, crab: float) -> None:
    image_ext = ".tif" if config.output.image_format == "GTiff" else ".bsq"
    entries = []
    for plan_strip, s in zip(plan.strips, strips):
        write_trajectory_csv(root / "nav" / f"{s.strip_id}.csv", s.measured)
        write_trajectory_csv(root / "truth" / f"trajectory_{s.strip_id}.csv", s.true_stream)
        writer.write_errors(root / "truth" / f"errors_{s.strip_id}.csv", s.errors)
        entries.append({"id": s.strip_id, "trajectory": f"nav/{s.strip_id}.csv",
                        "first_line_time": plan_strip.first_line_time, "lines": plan_strip.lines})
        if config.output.images:
            entries[-1]["image"] = f"images/{s.strip_id}{image_ext}"

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
    writer.write_json(
        root / "truth" / "errors.json",
        {
            "problem_strip": plan.strips[config.gpsimu_errors.problem_strip - 1].strip_id
            if config.gpsimu_errors.problem_strip
            else None,
            "breaks_lines": list(config.gpsimu_errors.breaks_lines),
            "boresight_error_deg": list(config.sensor.boresight_error_deg),
            **({"calibration_error": {"across_offset_deg": config.sensor.across_offset_error_deg,
                                      "across_scale": config.sensor.across_scale_error,
                                      "along_offset_deg": config.sensor.along_offset_error_deg}}
               if config.sensor.kind == "pushbroom" else {}),
            "true_boresight_deg": list(np.add(config.sensor.boresight_deg, config.sensor.boresight_error_deg)),
            "crab_deg": float(np.degrees(crab)),
            "position_frame": "project frame P (x east, y north, z up) of project.toml's origin",
            "strips": {
                s.strip_id: {**s.errors.parameters, **_mean_errors(s, plan_strip, config.sensor.line_rate_hz)}
                for s, plan_strip in zip(strips, plan.strips)
            },
        },
    )
    writer.write_json(
        root / "truth" / "scenario.json",
        {
            "seed": seed,
            "config_source": config.source,
            "config": dataclasses.asdict(config),
            "crs": map_frame.crs.to_string(),
            "origin_deg": origin,
            "flight_height_m": plan.flight_height_m,
            "swath_m": plan.swath_m,
            "strip_spacing_m": plan.spacing_m,
            "strips": [dataclasses.asdict(s) for s in plan.strips],
        },
    )
    if config.sensor.kind == "pushbroom":
        writer.write_look_angles(root / "look_angles.csv", look_angle_table(config.sensor))
    text = writer.project_toml(
        crs=map_frame.crs.to_string(),
        origin_deg=origin,
        geoid_undulation_m=config.block.geoid_undulation_m,
        dtm_sigma_m=config.terrain.dtm_error_sigma_m,
        sensor=config.sensor,
        strips=entries,
    )
    write_text(root / "project.toml", text)
