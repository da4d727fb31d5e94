"""Simulating a whole block: ``simulate(out, config)`` writes a project with known truth.

Order of work: location and frames -> terrain and project DTM -> flight plan -> per flight line the
true trajectory, the injected GPS/IMU errors and the measured stream, and every line scanner's strip
recorded on it (:mod:`scangeo.simulate.platform`) -> points and their measurements -> a platform's laser
strips -> files -> images rendered strip by strip -> the truth orthoimage. A block of one ``[sensor]`` is
the platform of that one sensor (its strips are its flight lines); ``[[platform.sensors]]`` fly several.
Every random draw comes from a generator named after its purpose and seeded by the block's seed
(:func:`~scangeo.simulate.seeds.rng_for`), so a seed gives the same block whatever is switched on or off.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pyproj

from scangeo.atomic import atomic_directory
from scangeo.dtm import DTM
from scangeo.errors import ProjectFileError
from scangeo.frames import Geoid, MapFrame, parse_crs
from scangeo.progress import no_progress, scaled
from scangeo.simulate.config import SimulationConfig
from scangeo.simulate.dynamics import make_dynamics
from scangeo.simulate.flight import FlightPlan, block_extent, plan_flight
from scangeo.simulate.laser_strip import SimulatedLaserStrip, record_laser, write_patches
from scangeo.simulate.ortho import write_truth_ortho
from scangeo.simulate.platform import (
    SimulatedFlightLine,
    SimulatedStrip,
    fly,
    look_angle_table,
    record,
    strip_id_of,
    true_sensor,
)
from scangeo.simulate.points import PointSet, measure_points, place_points
from scangeo.simulate.records import write_project
from scangeo.simulate.render import render_strip, write_image
from scangeo.simulate.scene import make_scene
from scangeo.simulate.seeds import rng_for
from scangeo.simulate.terrain import Extent, Terrain, dtm_centre_lonlat, make_terrain

log = logging.getLogger(__name__)


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
        Every image strip's true and measured orientation (a platform's flight line by flight line).
    points : PointSet
        Every simulated point and measurement (kind, true position, image coordinates, blunders).
    scene : object
        The scene the images were rendered from.
    ortho_extent : Extent
        The extent of the true orthoimage, map CRS.
    flight_lines : list of SimulatedFlightLine
        Every flight line flown (one per planned strip): its truth, GPS/IMU errors and measured stream.
    laser_strips : list of SimulatedLaserStrip
        A platform's laser strips (LAS files written).
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
    flight_lines: list[SimulatedFlightLine] = field(default_factory=list)
    laser_strips: list[SimulatedLaserStrip] = field(default_factory=list)


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
        if config.is_platform and any(s.kind == "pushbroom" for s in config.sensors()):
            (staging / "sensors").mkdir()  # the look-angle tables
        block = _simulate_into(staging, config, seed, dtm_file, texture, progress)
    block.root = out
    return block


def _simulate_into(root: Path, config: SimulationConfig, seed: int, dtm_file, texture, progress) -> SimulatedBlock:
    sensor_cfg, flight_cfg = config.reference_sensor, config.flight
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
    lines = fly(config, seed, plan, map_frame, dynamics, crab)  # each flight line flown once
    strips = record(config, plan, lines)  # and every line scanner's strip recorded on it
    progress(1, 1, "flight")

    scene = make_scene(config.scene, (extent.xmin, extent.ymax) if (texture or config.scene.kind == "texture")
                       else centre, seed, texture)
    points = _points(config, seed, plan, strips, map_frame, terrain, scene)
    progress(1, 1, "points")

    lasers = _lasers(root, config, seed, plan, lines, true_dtm, map_frame, terrain, scene)
    write_project(root, config, seed, map_frame, terrain, plan, lines, strips, points, crab, tuple(lasers))
    image_ext = ".tif" if config.output.image_format == "GTiff" else ".bsq"
    sensors = {s.id: s for s in config.sensors()}
    n = len(strips)
    for k, sim in enumerate(strips if config.output.images else []):
        sensor = sensors[sim.sensor]
        image = render_strip(sim.geometry, true_dtm, scene, sensor.noise_dn,
                             rng_for(seed, f"noise {sim.strip_id}"), config.output.line_chunk,
                             scaled(progress, k, k + 1, n), f"image {sim.strip_id}", sensor.bands)
        write_image(root / "images" / f"{sim.strip_id}{image_ext}", image, config.output.image_format, sensor.bands)
        del image
    half = plan.swath_m / 2.0
    ortho_extent = Extent(min(s.x for s in plan.strips) - half, extent.ymin + plan.run_in_s * plan.ground_speed_mps,
                          max(s.x for s in plan.strips) + half, extent.ymax - plan.run_in_s * plan.ground_speed_mps)
    if config.output.truth_ortho:
        write_truth_ortho(root / "truth" / "ortho.tif", scene, ortho_extent, config.output.ortho_resolution_m,
                          map_frame.crs.to_wkt(), progress=progress)
    return SimulatedBlock(root, config, seed, map_frame, terrain, plan, strips, points, scene, ortho_extent, lines,
                          lasers)


def _points(config: SimulationConfig, seed: int, plan: FlightPlan, strips: list[SimulatedStrip], map_frame: MapFrame,
            terrain: Terrain, scene) -> PointSet:
    """The points placed on the strips of the sensor the flight was planned for (a platform's ties between
    its sensors on every strip of a flight line) and measured in every image strip that sees them."""
    reference = config.reference_sensor
    planned = [s for s in strips if s.sensor == reference.id]
    others = [s for s in strips if s.sensor != reference.id]
    placed = [s.geometry for s in planned + others]
    index = {s.strip_id: k for k, s in enumerate(planned + others)}
    line_strips = [[index[s.strip_id] for s in strips if s.flight_line == line.strip_id] for line in plan.strips]
    platform = config.platform
    control_lines = tuple(n - 1 for n in platform.control_flight_lines)
    ids, kinds, xs, ys = place_points(config.points, plan, placed, map_frame, terrain, scene,
                                      rng_for(seed, "points"), config.gpsimu_errors.problem_strip,
                                      config.gpsimu_errors.breaks_lines, control_lines,
                                      platform.tie_per_flight_line, line_strips)
    sensors = {s.id: s for s in config.sensors()}
    measures = [sensors[s.sensor].measures_control and (not control_lines or s.flight_line in
                                                       [plan.strips[k].strip_id for k in control_lines])
                for s in strips]
    return measure_points(ids, kinds, xs, ys, [sim.geometry for sim in strips], map_frame, terrain, scene,
                          config.points, rng_for(seed, "measurements"), None if all(measures) else measures)


def _lasers(root: Path, config: SimulationConfig, seed: int, plan: FlightPlan, lines: list[SimulatedFlightLine],
            true_dtm: DTM, map_frame: MapFrame, terrain: Terrain, scene) -> list[SimulatedLaserStrip]:
    """A platform's laser strips on every flight line (``strips/*.las``) and their patches (``patches.csv``)."""
    lasers = [s for s in config.sensors() if s.kind == "laser"]
    if not lasers:
        return []
    (root / "strips").mkdir(exist_ok=True)
    out = []
    for number, line in enumerate(lines, start=1):
        t_end = line.plan.first_line_time + (line.plan.lines - 1) / plan.line_rate_hz
        for cfg in lasers:
            sid = strip_id_of(cfg.id, line.line_id)
            out.append(record_laser(root, sid, cfg, line, t_end, true_dtm, map_frame, rng_for(seed, f"laser {sid}"),
                                    number))
    control_lines = tuple(n - 1 for n in config.platform.control_flight_lines)
    for cfg in lasers:
        write_patches(root, cfg, plan, control_lines, terrain, scene, rng_for(seed, f"patches {cfg.id}"))
    return out


__all__ = ["SimulatedBlock", "SimulatedStrip", "look_angle_table", "resolve_location", "rng_for", "simulate",
           "true_sensor", "utm_crs"]
