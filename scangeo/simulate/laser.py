"""A simulated laser block with known truth: a laser project for ``scangeo run`` (docs/lidar.md section 6).

Parallel north-south strips (alternating direction) plus an east-west cross strip over a scene of flat
ground and gable roofs (``laser_scene.py``); or, with missions (the montafon preset, ``laser_plan.py``),
several flights of parallel and cross strips over an alpine valley, each mission with its own GPS shift
and IMU misalignment on top of the strips' errors. Each strip's GPS/IMU has a shift and a drift of the
positions and an offset and a drift of the attitude (linear in the strip's normalised time, as the
adjustment's correction polynomials model them); the scanner has a boresight error that the project file
does not know; ranges get white noise. Returns are cast with the *true* trajectory and calibration; the
LAS files carry the points as a processor computes them from the *measured* GPS/IMU and the nominal
calibration; the trajectory CSVs are the measured GPS/IMU. Control and check patches (four surveyed
points each on flat ground or roof faces) go to ground.csv; ``truth.json`` holds every injected error,
with ``c = true - measured`` as the adjustment estimates it.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from scangeo.atomic import atomic_path, write_text
from scangeo.frames import MapFrame
from scangeo.lidar.georeference import Calibration, Polar, beam, body_rotations, georeference
from scangeo.rotation import R_ENU_NED, rph_to_matrix
from scangeo.simulate.laser_config import LaserBlockConfig, is_laser_preset, load_laser_config
from scangeo.simulate.laser_plan import block_half_extent, inside_limits, plans, triangle, true_trajectory, valley_of
from scangeo.simulate.laser_scene import LaserScene
from scangeo.trajectory.readers import write_trajectory_csv
from scangeo.trajectory.stream import GpsImuStream, ProjectTrajectory


@dataclass
class LaserTruth:
    """What the simulation injected (JSON-ready)."""

    boresight_error_deg: list
    strips: dict = field(default_factory=dict)  # id -> {t_start, t_end, position [[a0],[a1]], attitude_deg}
    moved_roof: dict | None = None
    moved_roofs: list = field(default_factory=list)  # {strip, building, dz, x, y} per moved roof
    missions: dict = field(default_factory=dict)  # name -> {position_m, attitude_deg}: its constant errors


def _correction(coef: np.ndarray, t: np.ndarray, t0: float, t1: float) -> np.ndarray:
    """c(t) (n, k) of coefficients (2, k): constant and linear term in tau over [t0, t1]."""
    tau = 2.0 * (t - t0) / (t1 - t0) - 1.0
    return coef[0] + tau[:, None] * coef[1]


def simulate_laser(out: str | Path, cfg: LaserBlockConfig, las_extension: str = ".las") -> dict:
    """Write a laser project (project.toml, strips/*.las, nav/*.csv, ground.csv, truth.json) to ``out``."""
    out = Path(out)
    (out / "strips").mkdir(parents=True, exist_ok=True)
    (out / "nav").mkdir(exist_ok=True)
    rng = np.random.default_rng(cfg.seed)
    frame = MapFrame.centred_on(cfg.crs, cfg.centre[0], cfg.centre[1], 0.0)
    valley = valley_of(cfg)
    if cfg.mission_strips:
        hx, hy = block_half_extent(cfg)
        margin = 300.0  # beyond the outer strips' tracks: their swaths
        bounds = (-hx - margin, -hy - margin, hx + margin, hy + margin)
    else:
        half = 0.5 * cfg.strip_length + 0.5 * cfg.height * np.tan(np.radians(cfg.fov_deg / 2)) + 50.0
        bounds = (-half, -half, half, half)
    scene = LaserScene.random(bounds, rng, cfg.building_spacing, cfg.building_fill, valley=valley,
                              building_scale=cfg.building_scale)
    nominal = Calibration.of(np.radians(cfg.boresight_deg), cfg.lever_arm)
    true_cal = Calibration.of(np.radians(cfg.boresight_deg) + np.radians(cfg.boresight_error_deg), cfg.lever_arm)
    truth = LaserTruth(list(cfg.boresight_error_deg))
    flights = plans(cfg, scene)
    moved = []  # (strip id, building, dz)
    if cfg.moved_roof:
        k = int(np.argmin(np.hypot(scene.buildings.x - 0.5 * cfg.strip_spacing, scene.buildings.y)))
        moved.append((str(int(cfg.moved_roof[0]) + 1), k, float(cfg.moved_roof[1])))
        truth.moved_roof = _moved(scene, *moved[0])
    if cfg.moved_roofs:
        moved += _moved_roofs(cfg, scene, flights)
        truth.moved_roofs = [_moved(scene, *m) for m in moved[-cfg.moved_roofs:]]
    mission_errors = {}
    if cfg.mission_strips:  # a GPS shift and an IMU misalignment per mission (c = true - measured)
        for name in dict.fromkeys(p.mission for p in flights):
            mission_errors[name] = (
                rng.normal(0, cfg.mission_shift_sigma),
                np.radians(rng.normal(0, cfg.mission_misalignment_sigma_deg, 3)),
            )
            truth.missions[name] = {"position_m": mission_errors[name][0].tolist(),
                                    "attitude_deg": np.degrees(mission_errors[name][1]).tolist()}
    strips_toml = []
    for plan in flights:
        n = int(plan.duration * cfg.pulse_rate_hz)
        t = plan.t0 + np.arange(n) / cfg.pulse_rate_hz
        phase = rng.uniform(0, 2 * np.pi, 3)
        pos, ang = true_trajectory(plan, cfg, t, phase)
        theta = np.radians(cfg.fov_deg / 2) * triangle(t - plan.t0, cfg.scan_rate_hz)
        o, d = beams(pos, ang, theta, true_cal)
        mine = [(k, dz) for sid, k, dz in moved if sid == plan.id]
        _lift(scene, mine, 1.0)
        rho, ok = scene.cast(o, d)
        _lift(scene, mine, -1.0)
        t, theta, rho = t[ok], theta[ok], rho[ok] + rng.normal(0.0, cfg.range_sigma, int(ok.sum()))
        # the GPS/IMU errors, c = true - measured, linear in tau over the strip's span
        t_lo, t_hi = float(t[0]), float(t[-1])
        pos_coef = np.vstack([rng.normal(0, cfg.gps_shift_sigma), rng.normal(0, cfg.gps_drift_sigma)])
        att_coef = np.radians(
            np.vstack([rng.normal(0, cfg.imu_offset_sigma_deg, 3), rng.normal(0, cfg.imu_drift_sigma_deg, 3)])
        )
        if plan.mission in mission_errors:  # the mission's constant errors on top of the strip's
            pos_coef[0] += mission_errors[plan.mission][0]
            att_coef[0] += mission_errors[plan.mission][1]
        truth.strips[plan.id] = {
            "t_start": t_lo,
            "t_end": t_hi,
            "position_m": pos_coef.tolist(),
            "attitude_deg": np.degrees(att_coef).tolist(),
            "returns": int(t.size),
            "mission": plan.mission,
            "altitude_m": plan.altitude,
        }
        pos_m = pos[ok] - _correction(pos_coef, t, t_lo, t_hi)
        ang_m = ang[ok] - _correction(att_coef, t, t_lo, t_hi)
        p_las = georeference(pos_m, ang_m, Polar(t, rho, theta, np.zeros_like(t)), nominal)
        write_las(out / "strips" / f"{plan.id}{las_extension}", frame, p_las, t, theta, int(plan.id))
        # the measured GPS/IMU at the trajectory rate, a second beyond the strip at both ends
        tn = np.arange(plan.t0 - 1.0, plan.t0 + plan.duration + 1.0, 1.0 / cfg.trajectory_rate_hz)
        pn, an = true_trajectory(plan, cfg, tn, phase)
        pn = pn - _correction(pos_coef, tn, t_lo, t_hi)
        an = an - _correction(att_coef, tn, t_lo, t_hi)
        R = R_ENU_NED @ rph_to_matrix(an[:, 0], an[:, 1], an[:, 2])
        stream = GpsImuStream.from_project(ProjectTrajectory.from_rotations(tn, pn, R), frame.frame)
        write_trajectory_csv(out / "nav" / f"{plan.id}.csv", stream)
        mission = f'mission = "{plan.mission}"\n' if cfg.mission_strips else ""
        strips_toml.append(
            f'[[strips]]\nid = "{plan.id}"\nlas = "strips/{plan.id}{las_extension}"\ntrajectory = "nav/{plan.id}.csv"\n'
            + mission
        )
    _write_ground(out, scene, frame, cfg, rng, {m["building"] for m in truth.moved_roofs})
    lat0, lon0 = np.degrees(frame.frame.lat0), np.degrees(frame.frame.lon0)
    adjustment = ""
    if cfg.adjustment:
        adjustment = "[adjustment]\n" + "".join(
            f"{k} = {int(v) if float(v).is_integer() else v}\n" for k, v in cfg.adjustment.items()) + "\n"
    project = (
        f'[project]\ncrs = "{cfg.crs}"\norigin = [{lat0:.10f}, {lon0:.10f}, {frame.frame.h0:.4f}]\n\n'
        f'[sensor]\nkind = "laser"\nfov_deg = {cfg.fov_deg}\npulse_rate_hz = {cfg.pulse_rate_hz}\n'
        f"scan_rate_hz = {cfg.scan_rate_hz}\nrange_sigma_m = {cfg.range_sigma}\n"
        f"boresight_deg = {list(cfg.boresight_deg)}\nlever_arm_m = {list(cfg.lever_arm)}\n\n" + adjustment
        + "\n".join(strips_toml)
    )
    write_text(out / "project.toml", project)
    summary = {"config": asdict(cfg), "truth": asdict(truth), "buildings": scene.buildings.count}
    write_text(out / "truth.json", json.dumps(summary, indent=1))
    return summary


def beams(pos: np.ndarray, angles: np.ndarray, theta: np.ndarray, cal: Calibration) -> tuple[np.ndarray, np.ndarray]:
    """Origins (n, 3) and unit directions (n, 3) of laser beams in the project frame: the laser equation's
    ``p_nav + R_PB l_B`` and ``R_PB R_BS u_S(theta)`` of navigation positions ``pos`` and angles ``angles``
    (roll, pitch, heading w.r.t. the project NED frame, rad), scan angles ``theta`` (rad) and the calibration
    ``cal`` (:mod:`scangeo.lidar.georeference`)."""
    R_PB = body_rotations(angles)
    R_BS = rph_to_matrix(*cal.boresight)
    d = np.einsum("nij,nj->ni", R_PB, beam(theta) @ R_BS.T)
    return pos + R_PB @ cal.lever_arm, d


def write_las(path: Path, frame: MapFrame, p_P: np.ndarray, t: np.ndarray, theta: np.ndarray, source_id: int) -> None:
    """A strip's returns as a LAS 1.4 file (point format 6, millimetres, the map CRS), atomically: the points
    ``p_P`` (n, 3; project frame) in map coordinates, their GPS times ``t`` (s), scan angles ``theta`` (rad)
    and the flight line's ``point_source_id``; ``.laz`` names are compressed."""
    import laspy  # start-up cost: laspy and its LAZ backend load when a LAS file is written

    x, y, z = frame.project_to_map(p_P)
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.offsets = [np.floor(x.min()), np.floor(y.min()), np.floor(z.min())]
    header.scales = [0.001, 0.001, 0.001]
    header.add_crs(frame.crs)
    las = laspy.LasData(header)
    las.x, las.y, las.z = x, y, z
    las.gps_time = t
    las.scan_angle = np.round(np.degrees(theta) / 0.006).astype(np.int16)
    las.point_source_id = np.full(t.size, source_id, np.uint16)
    las.intensity = np.full(t.size, 100, np.uint16)
    with atomic_path(path) as tmp:
        las.write(str(tmp), laz_backend=None) if Path(path).suffix == ".las" else las.write(str(tmp))


def _moved(scene: LaserScene, strip: str, k: int, dz: float) -> dict:
    b = scene.buildings
    return {"strip": strip, "building": k, "dz": dz, "x": float(b.x[k]), "y": float(b.y[k])}


def _lift(scene: LaserScene, moved: list[tuple[int, float]], sign: float) -> None:
    """Raise (sign +1) or lower back (-1) the roofs of the given buildings."""
    for k, dz in moved:
        scene.buildings.ridge[k] += sign * dz
        scene.buildings.eave[k] += sign * dz


def _moved_roofs(cfg: LaserBlockConfig, scene: LaserScene, flights) -> list[tuple[str, int, float]]:
    """The ``moved_roofs`` buildings with the widest roof faces well inside the block (a patch fits
    on them), each moved in the parallel strip flying closest over it among those of the mission
    flown lowest (the densest)."""
    b = scene.buildings
    inside = np.flatnonzero(inside_limits(cfg, b.x, b.y, 100.0))
    chosen = inside[np.argsort(-b.half_width[inside], kind="stable")[: cfg.moved_roofs]]
    parallel = [p for p in flights if abs(np.sin(p.heading)) < 0.5]
    if cfg.mission_clearance:
        lowest = chr(ord("A") + int(np.argmin(cfg.mission_clearance)))
        parallel = [p for p in parallel if p.mission == lowest]
    out = []
    for k in chosen:
        best = min(parallel, key=lambda p: abs(p.start[0] - b.x[k]))
        out.append((best.id, int(k), cfg.moved_roof_dz))
    return out


def _open_flat(scene: LaserScene, cfg: LaserBlockConfig, c: np.ndarray, ring: np.ndarray) -> bool:
    """No building within the ring around ``c``, ground flatter than 3 %, inside the limits."""
    return bool(np.all(scene.building_at(c[0] + ring[:, 0], c[1] + ring[:, 1])[0] < 0)
                and np.all(scene.slope_at(c[0] + ring[:, 0], c[1] + ring[:, 1]) < 0.03)
                and inside_limits(cfg, c[0], c[1], 30.0))


def _write_ground(out: Path, scene: LaserScene, frame: MapFrame, cfg: LaserBlockConfig, rng,
                  exclude: set[int] = frozenset()) -> None:  # type: ignore[assignment]
    """Control and check patches: four surveyed points (a rectangle of ``survey_half``) on ground or roof
    faces (not on the buildings in ``exclude``: the moved roofs), and sports fields (height control)."""
    b = scene.buildings
    half = np.array(block_half_extent(cfg)) - 30.0
    total = cfg.control_patches + cfg.check_patches
    inside = np.flatnonzero(inside_limits(cfg, b.x, b.y, 30.0) & ~np.isin(np.arange(b.count), list(exclude)))
    rng.shuffle(inside)
    # roof patches on distinct buildings, cycling through the ridge directions (roofs of one direction
    # alone leave the block's shift along the ridges free)
    by_azimuth = [list(inside[b.azimuth[inside] == a]) for a in np.unique(b.azimuth[inside])]
    roofs = [group[k] for k in range(max(map(len, by_azimuth), default=0)) for group in by_azimuth if k < len(group)]
    rows = []
    ring = 8.0 * np.array([[np.cos(a), np.sin(a)] for a in np.linspace(0, 2 * np.pi, 13)] + [[0.0, 0.0]])
    corners = np.array([[1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], [1.0, -1.0]])
    n_roof = 0
    every = cfg.flat_control_every
    su, sv = cfg.survey_half[0], cfg.survey_half[1]
    for i in range(total):
        if (every and i % every == every - 1) or n_roof >= len(roofs):  # every n-th patch on flat ground
            for _ in range(1000):
                c = rng.uniform(-half, half, 2)
                if _open_flat(scene, cfg, c, ring):
                    break
            e1, e2 = np.array([1.0, 0.0]), np.array([0.0, 1.0])
        else:
            k = int(roofs[n_roof])
            centre, _ = scene.roof_face(k, 1 if n_roof % 2 == 0 else -1)
            n_roof += 1
            c = centre[:2]
            a = b.azimuth[k]
            e1, e2 = np.array([np.cos(a), np.sin(a)]), np.array([-np.sin(a), np.cos(a)])
        role = "control" if i < cfg.control_patches else "check"
        pid = f"{'C' if role == 'control' else 'K'}{i + 1}"
        rows += _surveyed(pid, role, c + su * corners[:, :1] * e1 + sv * corners[:, 1:] * e2, scene, frame, cfg, rng)
    for i in range(cfg.height_patches):  # sports fields on open, flat ground
        for _ in range(1000):
            c = rng.uniform(-half, half, 2)
            if _open_flat(scene, cfg, c, 2.0 * ring):
                break
        field = c + corners * [10.0, 7.0]
        rows += _surveyed(f"H{i + 1}", "height", field, scene, frame, cfg, rng)
    write_text(out / "ground.csv", "point,patch,x,y,z,sigma_xy,sigma_z,role\n" + "\n".join(rows) + "\n")


def _surveyed(pid: str, role: str, xy: np.ndarray, scene: LaserScene, frame: MapFrame, cfg: LaserBlockConfig,
              rng) -> list[str]:
    """ground.csv rows of the surveyed points ``xy`` (project frame) of one patch; with ``fourth_as_check``
    the fourth point of a control (or height) patch is a check point."""
    z = scene.height(xy[:, 0], xy[:, 1]) + rng.normal(0, cfg.control_sigma, len(xy))
    X, Y, Z = frame.project_to_map(np.column_stack([xy, z]))
    out = []
    for j in range(len(xy)):
        r = "check" if (cfg.fourth_as_check and role != "check" and j == 3) else role
        out.append(f"{pid}.{j + 1},{pid},{X[j]:.4f},{Y[j]:.4f},{Z[j]:.4f},{cfg.control_sigma},{cfg.control_sigma},{r}")
    return out



__all__ = ["LaserBlockConfig", "LaserTruth", "beams", "is_laser_preset", "load_laser_config", "simulate_laser",
           "write_las"]
