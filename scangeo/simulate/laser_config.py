"""The keys of a laser preset's ``[laser]`` table (``scangeo simulate --preset laser|montafon``)."""

from __future__ import annotations

from dataclasses import dataclass

from scangeo.errors import ProjectFileError
from scangeo.io.schema import read
from scangeo.io.toml_config import load_toml


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
    building_scale: float = 1.0  # buildings' lengths and widths times this
    control_patches: int = 8
    check_patches: int = 6
    control_sigma: float = 0.01
    fourth_as_check: bool = False  # the fourth surveyed point of each control patch is a check point
    height_patches: int = 0  # sports fields: flat 20 m x 14 m, four height points each (height control)
    flat_control_every: int = 3  # every n-th control or check patch on flat ground (0: all on roofs)
    survey_half: tuple[float, ...] = (2.5, 2.0)  # half sides of the surveyed rectangle of a patch
    moved_roof: tuple[float, ...] = ()  # (strip index, dz m): one roof in that strip moved (a blunder)
    moved_roofs: int = 0  # roofs moved by moved_roof_dz, each in one strip flying over it (blunders)
    moved_roof_dz: float = 0.5
    trajectory_rate_hz: float = 200.0
    time_start: float = 400000.0
    # missions (the montafon preset); empty: `strips` parallel strips and one cross strip, one mission
    mission_strips: tuple[int, ...] = ()  # parallel (north-south) strips of each mission
    mission_cross_strips: tuple[int, ...] = ()  # east-west cross strips of each mission
    mission_spacing: tuple[float, ...] = ()  # between the parallel strips of each mission
    mission_clearance: tuple[float, ...] = ()  # a strip's altitude above the highest ground near its track
    mission_shift_sigma: tuple[float, ...] = (0.0, 0.0, 0.0)  # GPS shift of each mission (east, north, up)
    mission_misalignment_sigma_deg: float = 0.0  # IMU misalignment (roll, pitch, heading) of each mission
    limits: tuple[float, ...] = ()  # semi-axes (x, y) of the elliptic project limits: strips end there
    # relief: (floor, top, floor half width, side slope deg) of a valley along y (Valley); empty: flat
    valley: tuple[float, ...] = ()
    valley_ripple: float = 0.0
    valley_meander: float = 0.0
    adjustment: dict[str, float] | None = None  # the [adjustment] table written to project.toml


def load_laser_config(path, overrides: dict | None = None) -> LaserBlockConfig:
    """Read the ``[laser]`` table of a preset file (a Path or package resource); unknown keys are errors."""
    data = load_toml(path)
    unknown = sorted(set(data) - {"laser"})
    if unknown:
        raise ProjectFileError(f"{path}: unknown table [{unknown[0]}] (a laser preset has only [laser])")
    table = dict(data.get("laser", {}))
    table.update(overrides or {})
    config = read(LaserBlockConfig, table, str(path), "laser")  # every key typed (scangeo.io.schema)
    m = len(config.mission_strips)
    for key in ("mission_cross_strips", "mission_spacing", "mission_clearance"):
        if len(getattr(config, key)) != m:
            raise ProjectFileError(f"{path} [laser.{key}]: expected {m} values (one per mission of mission_strips), "
                                   f"found {len(getattr(config, key))}")
    if config.valley and len(config.valley) != 4:
        raise ProjectFileError(f"{path} [laser.valley]: expected floor, top, floor half width, slope (deg)")
    if config.limits and len(config.limits) != 2:
        raise ProjectFileError(f"{path} [laser.limits]: expected the two semi-axes (x, y) of the limits")
    return config


def is_laser_preset(path) -> bool:
    try:
        return "laser" in load_toml(path)
    except ProjectFileError:
        return False
