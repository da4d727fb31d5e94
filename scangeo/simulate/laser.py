"""A simulated laser block with known truth: a laser project for ``scangeo lidar adjust``.

Parallel north-south strips (alternating direction) plus an east-west cross strip over a scene of
flat ground and gable roofs (``laser_scene.py``). Each strip's GPS/IMU has a shift and a drift of the
positions and an offset and a drift of the attitude (linear in the strip's normalised time, as the
adjustment's correction polynomials model them); the scanner has a boresight error that the
project file does not know; ranges get white noise. Returns are cast with the *true* trajectory and
calibration; the LAS files carry the points as a processor computes them from the *measured*
GPS/IMU and the nominal calibration; the trajectory CSVs are the measured GPS/IMU. Control and check
patches (four surveyed points each on flat ground or roof faces) go to ground.csv; ``truth.json``
holds every injected error, with ``c = true - measured`` as the adjustment estimates it.
"""

from __future__ import annotations

import json
import tomllib
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from scangeo.atomic import atomic_path, write_text
from scangeo.errors import ProjectFileError
from scangeo.frames import MapFrame
from scangeo.io.schema import read
from scangeo.lidar.georeference import Calibration, Polar, beam, body_rotations, georeference
from scangeo.rotation import R_ENU_NED, rph_to_matrix
from scangeo.simulate.laser_scene import LaserScene
from scangeo.trajectory.readers import write_trajectory_csv
from scangeo.trajectory.stream import GpsImuStream, ProjectTrajectory


@dataclass(frozen=True)
class LaserBlockConfig:
    """Every key of a laser preset's ``[laser]`` table (lengths m, angles deg, times s)."""

    crs: str = "EPSG:32633"
    centre: tuple[float, ...] = (500000.0, 5300000.0)
    seed: int = 16
    strips: int = 3
    strip_spacing: float = 220.0
    strip_length: float = 900.0
    cross_strip: bool = True
    height: float = 450.0
    speed: float = 60.0
    fov_deg: float = 40.0
    pulse_rate_hz: float = 20000.0
    scan_rate_hz: float = 40.0
    range_sigma: float = 0.02
    lever_arm: tuple[float, ...] = (0.1, -0.2, 0.3)
    boresight_deg: tuple[float, ...] = (0.0, 0.0, 0.0)
    boresight_error_deg: tuple[float, ...] = (0.02, -0.015, 0.03)
    gps_shift_sigma: tuple[float, ...] = (0.10, 0.10, 0.08)
    gps_drift_sigma: tuple[float, ...] = (0.05, 0.05, 0.05)
    imu_offset_sigma_deg: float = 0.003
    imu_drift_sigma_deg: float = 0.005
    attitude_wobble_deg: tuple[float, ...] = (1.0, 0.7, 0.5)
    building_spacing: float = 50.0
    building_fill: float = 0.55
    control_patches: int = 8
    check_patches: int = 6
    control_sigma: float = 0.01
    fourth_as_check: bool = False  # the fourth surveyed point of each control patch is a check point
    height_patches: int = 0  # sports fields: flat 20 m x 14 m, four height points each (height control)
    moved_roof: tuple[float, ...] = ()  # (strip index, dz m): one roof in that strip moved (a blunder)
    trajectory_rate_hz: float = 200.0
    time_start: float = 400000.0


@dataclass
class LaserTruth:
    """What the simulation injected (JSON-ready)."""

    boresight_error_deg: list
    strips: dict = field(default_factory=dict)  # id -> {t_start, t_end, position [[a0],[a1]], attitude_deg}
    moved_roof: dict | None = None


def load_laser_config(path, overrides: dict | None = None) -> LaserBlockConfig:
    """Read the ``[laser]`` table of a preset file (a Path or package resource); unknown keys are errors."""
    try:
        data = tomllib.loads(path.read_text())
    except (OSError, tomllib.TOMLDecodeError) as exc:
        raise ProjectFileError(f"{path}: cannot read the laser preset ({exc})") from exc
    unknown = sorted(set(data) - {"laser"})
    if unknown:
        raise ProjectFileError(f"{path}: unknown table [{unknown[0]}] (a laser preset has only [laser])")
    table = dict(data.get("laser", {}))
    table.update(overrides or {})
    return read(LaserBlockConfig, table, str(path), "laser")  # every key typed (scangeo.io.schema)


def is_laser_preset(path) -> bool:
    try:
        return "laser" in tomllib.loads(path.read_text())
    except (OSError, tomllib.TOMLDecodeError):
        return False


def _triangle(t: np.ndarray, rate: float) -> np.ndarray:
    """Oscillating-mirror scan angle pattern in [-1, 1]: +1 (right edge) -> -1 -> +1 per period."""
    phase = (t * rate) % 1.0
    return 4.0 * np.abs(phase - 0.5) - 1.0


@dataclass
class StripPlan:
    id: str
    start: np.ndarray  # (2,) project x, y
    heading: float  # rad, clockwise from north
    t0: float
    duration: float


def _plans(cfg: LaserBlockConfig) -> list[StripPlan]:
    out, t = [], cfg.time_start
    dur = cfg.strip_length / cfg.speed
    half = 0.5 * cfg.strip_length
    for k in range(cfg.strips):
        x = (k - 0.5 * (cfg.strips - 1)) * cfg.strip_spacing
        north = k % 2 == 0
        out.append(StripPlan(str(k + 1), np.array([x, -half if north else half]), 0.0 if north else np.pi, t, dur))
        t += dur + 60.0
    if cfg.cross_strip:
        out.append(StripPlan(str(cfg.strips + 1), np.array([-half, 0.0]), 0.5 * np.pi, t, dur))
    return out


def _true_trajectory(plan: StripPlan, cfg: LaserBlockConfig, t: np.ndarray, phase: np.ndarray):
    s = cfg.speed * (t - plan.t0)
    d = np.array([np.sin(plan.heading), np.cos(plan.heading)])
    pos = np.column_stack([plan.start[0] + s * d[0], plan.start[1] + s * d[1], np.full(t.shape, cfg.height)])
    w = np.radians(cfg.attitude_wobble_deg)
    tt = t - plan.t0
    ang = np.column_stack(
        [
            w[0] * np.sin(2 * np.pi * tt / 7.0 + phase[0]),
            w[1] * np.sin(2 * np.pi * tt / 11.0 + phase[1]),
            plan.heading + w[2] * np.sin(2 * np.pi * tt / 13.0 + phase[2]),
        ]
    )
    return pos, ang


def _correction(coef: np.ndarray, t: np.ndarray, t0: float, t1: float) -> np.ndarray:
    """c(t) (n, k) of coefficients (2, k): constant and linear term in tau over [t0, t1]."""
    tau = 2.0 * (t - t0) / (t1 - t0) - 1.0
    return coef[0] + tau[:, None] * coef[1]


def simulate_laser(out: str | Path, cfg: LaserBlockConfig, las_extension: str = ".las") -> dict:
    """Write a laser project (project.toml, strips/*.las, nav/*.csv, ground.csv, truth.json) to ``out``."""
    import laspy  # start-up cost: laspy and its LAZ backend load when a LAS file is read

    out = Path(out)
    (out / "strips").mkdir(parents=True, exist_ok=True)
    (out / "nav").mkdir(exist_ok=True)
    rng = np.random.default_rng(cfg.seed)
    frame = MapFrame.centred_on(cfg.crs, cfg.centre[0], cfg.centre[1], 0.0)
    half = 0.5 * cfg.strip_length + 0.5 * cfg.height * np.tan(np.radians(cfg.fov_deg / 2)) + 50.0
    scene = LaserScene.random((-half, -half, half, half), rng, cfg.building_spacing, cfg.building_fill)
    nominal = Calibration.of(np.radians(cfg.boresight_deg), cfg.lever_arm)
    true_cal = Calibration.of(np.radians(cfg.boresight_deg) + np.radians(cfg.boresight_error_deg), cfg.lever_arm)
    truth = LaserTruth(list(cfg.boresight_error_deg))
    moved = None
    if cfg.moved_roof:
        k = int(np.argmin(np.hypot(scene.buildings.x - 0.5 * cfg.strip_spacing, scene.buildings.y)))
        moved = (str(int(cfg.moved_roof[0]) + 1), k, float(cfg.moved_roof[1]))
        truth.moved_roof = {
            "strip": moved[0],
            "building": k,
            "dz": moved[2],
            "x": float(scene.buildings.x[k]),
            "y": float(scene.buildings.y[k]),
        }
    strips_toml = []
    for plan in _plans(cfg):
        n = int(plan.duration * cfg.pulse_rate_hz)
        t = plan.t0 + np.arange(n) / cfg.pulse_rate_hz
        phase = rng.uniform(0, 2 * np.pi, 3)
        pos, ang = _true_trajectory(plan, cfg, t, phase)
        theta = np.radians(cfg.fov_deg / 2) * _triangle(t - plan.t0, cfg.scan_rate_hz)
        R_PB = body_rotations(ang)
        R_BS = rph_to_matrix(*true_cal.boresight)
        d = np.einsum("nij,nj->ni", R_PB, beam(theta) @ R_BS.T)
        o = pos + R_PB @ true_cal.lever_arm
        if moved is not None and moved[0] == plan.id:
            scene.buildings.ridge[moved[1]] += moved[2]
            scene.buildings.eave[moved[1]] += moved[2]
        rho, ok = scene.cast(o, d)
        if moved is not None and moved[0] == plan.id:
            scene.buildings.ridge[moved[1]] -= moved[2]
            scene.buildings.eave[moved[1]] -= moved[2]
        t, theta, rho = t[ok], theta[ok], rho[ok] + rng.normal(0.0, cfg.range_sigma, int(ok.sum()))
        # the GPS/IMU errors, c = true - measured, linear in tau over the strip's span
        t_lo, t_hi = float(t[0]), float(t[-1])
        pos_coef = np.vstack([rng.normal(0, cfg.gps_shift_sigma), rng.normal(0, cfg.gps_drift_sigma)])
        att_coef = np.radians(
            np.vstack([rng.normal(0, cfg.imu_offset_sigma_deg, 3), rng.normal(0, cfg.imu_drift_sigma_deg, 3)])
        )
        truth.strips[plan.id] = {
            "t_start": t_lo,
            "t_end": t_hi,
            "position_m": pos_coef.tolist(),
            "attitude_deg": np.degrees(att_coef).tolist(),
            "returns": int(t.size),
        }
        pos_m = pos[ok] - _correction(pos_coef, t, t_lo, t_hi)
        ang_m = ang[ok] - _correction(att_coef, t, t_lo, t_hi)
        p_las = georeference(pos_m, ang_m, Polar(t, rho, theta, np.zeros_like(t)), nominal)
        x, y, z = frame.project_to_map(p_las)
        path = out / "strips" / f"{plan.id}{las_extension}"
        header = laspy.LasHeader(point_format=6, version="1.4")
        header.offsets = [np.floor(x.min()), np.floor(y.min()), np.floor(z.min())]
        header.scales = [0.001, 0.001, 0.001]
        header.add_crs(frame.crs)
        las = laspy.LasData(header)
        las.x, las.y, las.z = x, y, z
        las.gps_time = t
        las.scan_angle = np.round(np.degrees(theta) / 0.006).astype(np.int16)
        las.point_source_id = np.full(t.size, int(plan.id), np.uint16)
        las.intensity = np.full(t.size, 100, np.uint16)
        with atomic_path(path) as tmp:
            las.write(str(tmp), laz_backend=None) if las_extension == ".las" else las.write(str(tmp))
        # the measured GPS/IMU at the trajectory rate, a second beyond the strip at both ends
        tn = np.arange(plan.t0 - 1.0, plan.t0 + plan.duration + 1.0, 1.0 / cfg.trajectory_rate_hz)
        pn, an = _true_trajectory(plan, cfg, tn, phase)
        pn = pn - _correction(pos_coef, tn, t_lo, t_hi)
        an = an - _correction(att_coef, tn, t_lo, t_hi)
        R = R_ENU_NED @ rph_to_matrix(an[:, 0], an[:, 1], an[:, 2])
        stream = GpsImuStream.from_project(ProjectTrajectory.from_rotations(tn, pn, R), frame.frame)
        write_trajectory_csv(out / "nav" / f"{plan.id}.csv", stream)
        strips_toml.append(
            f'[[strips]]\nid = "{plan.id}"\nlas = "strips/{plan.id}{las_extension}"\ntrajectory = "nav/{plan.id}.csv"\n'
        )
    _write_ground(out, scene, frame, cfg, rng)
    lat0, lon0 = np.degrees(frame.frame.lat0), np.degrees(frame.frame.lon0)
    project = (
        f'[project]\ncrs = "{cfg.crs}"\norigin = [{lat0:.10f}, {lon0:.10f}, {frame.frame.h0:.4f}]\n\n'
        f'[sensor]\nkind = "laser"\nfov_deg = {cfg.fov_deg}\npulse_rate_hz = {cfg.pulse_rate_hz}\n'
        f"scan_rate_hz = {cfg.scan_rate_hz}\nrange_sigma_m = {cfg.range_sigma}\n"
        f"boresight_deg = {list(cfg.boresight_deg)}\nlever_arm_m = {list(cfg.lever_arm)}\n\n" + "\n".join(strips_toml)
    )
    write_text(out / "project.toml", project)
    summary = {"config": asdict(cfg), "truth": asdict(truth), "buildings": scene.buildings.count}
    write_text(out / "truth.json", json.dumps(summary, indent=1))
    return summary


def _write_ground(out: Path, scene: LaserScene, frame: MapFrame, cfg: LaserBlockConfig, rng) -> None:
    """Control and check patches: four surveyed points (a 5 m x 4 m rectangle) on ground or roof faces."""
    b = scene.buildings
    half = 0.5 * cfg.strip_length - 30.0
    total = cfg.control_patches + cfg.check_patches
    inside = np.flatnonzero((np.abs(b.x) < half) & (np.abs(b.y) < half))
    rng.shuffle(inside)
    # roof patches on distinct buildings, cycling through the ridge directions (roofs of one direction
    # alone leave the block's shift along the ridges free)
    by_azimuth = [list(inside[b.azimuth[inside] == a]) for a in np.unique(b.azimuth[inside])]
    roofs = [group[k] for k in range(max(map(len, by_azimuth), default=0)) for group in by_azimuth if k < len(group)]
    rows = []
    ring = 8.0 * np.array([[np.cos(a), np.sin(a)] for a in np.linspace(0, 2 * np.pi, 13)] + [[0.0, 0.0]])
    corners = np.array([[1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], [1.0, -1.0]])
    n_roof = 0
    for i in range(total):
        if i % 3 == 2 or n_roof >= len(roofs):  # every third patch on flat ground
            for _ in range(1000):
                c = rng.uniform(-half, half, 2)
                if np.all(scene.building_at(c[0] + ring[:, 0], c[1] + ring[:, 1])[0] < 0):
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
        rows += _surveyed(pid, role, c + 2.5 * corners[:, :1] * e1 + 2.0 * corners[:, 1:] * e2, scene, frame, cfg, rng)
    for i in range(cfg.height_patches):  # sports fields on open ground
        for _ in range(1000):
            c = rng.uniform(-half, half, 2)
            if np.all(scene.building_at(c[0] + 2.0 * ring[:, 0], c[1] + 2.0 * ring[:, 1])[0] < 0):
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

