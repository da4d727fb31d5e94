"""Configuration of a simulated block: typed frozen dataclasses read from a preset TOML file.

Presets are package data: ``scangeo/data/presets/NAME.toml`` (``quick``, ``small``,
``vienna2000``, ``block24``; :mod:`scangeo.resources`); a user's own TOML file works the same way.
Every key is documented in docs/simulate.md; an unknown key is an error naming it. Angles are in degrees in the file and
stay so in these dataclasses (the simulator converts at use); lengths in metres, times in seconds.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from importlib.resources.abc import Traversable
from pathlib import Path

from scangeo.errors import MissingFileError, ProjectFileError
from scangeo.io.schema import Setting, read, setting
from scangeo.io.toml_config import load_toml
from scangeo.resources import preset_file, preset_names


@dataclass(frozen=True)
class BlockConfig:
    """Where the block lies and its time base.

    ``crs = "auto"`` picks the UTM zone of the centre; ``centre`` is given in the map CRS (or, with
    ``centre_lonlat``, in degrees); with a DTM file and no explicit centre the DTM's centre is used.
    """

    name: str = "block"
    crs: str = "auto"
    centre: tuple[float, ...] = ()
    centre_lonlat: tuple[float, ...] = ()
    geoid_undulation_m: float = 0.0
    time_start_s: float = 300000.0


@dataclass(frozen=True)
class SensorConfig:
    """The scanner (whiskbroom or pushbroom) and its mounting; ``boresight_error_deg`` is the true
    misalignment that project.toml does not know (uncalibrated), roll/pitch/heading order.

    A pushbroom's look-angle table (written to ``look_angles.csv``): with ``u`` from -1 to 1 over the
    pixels, ``across = fov/2 u + across_cubic_deg (u^3 - u)`` and ``along = along_deg + smile_deg u^2``.
    Its true calibration differs from that table by the ``*_error`` keys (``scangeo.sensors.models.Pushbroom``:
    offsets of the tangents, degrees; the scale relative)."""

    kind: str = setting("whiskbroom", choices=("whiskbroom", "pushbroom"), doc="the scanner type")
    pixels: int = setting(716, ge=16)
    fov_deg: float = setting(42.9, gt=0, lt=120)
    line_rate_hz: float = setting(25.0, gt=0)
    pixel_timing: bool = True
    boresight_deg: tuple[float, ...] = setting((0.0, 0.0, 0.0), length=3)
    lever_arm_m: tuple[float, ...] = setting((0.0, 0.0, 0.0), length=3)
    boresight_error_deg: tuple[float, ...] = setting((0.0, 0.0, 0.0), length=3)
    noise_dn: float = 0.0
    along_deg: float = setting(0.0, doc="pushbroom: along-track look angle of the centre pixel")
    smile_deg: float = setting(0.0, doc="pushbroom: along-track look angle at the swath edges minus at the centre")
    across_cubic_deg: float = setting(0.0, doc="pushbroom: cubic term of the across-track look angles")
    across_offset_error_deg: float = setting(0.0, doc="pushbroom: true across_offset (project.toml says 0)")
    across_scale_error: float = setting(0.0, gt=-0.1, lt=0.1, unit="1", doc="pushbroom: true across_scale")
    along_offset_error_deg: float = setting(0.0, doc="pushbroom: true along_offset")


@dataclass(frozen=True)
class TerrainConfig:
    """True terrain (``fractal`` hills, ``urban`` flat, or ``file``) and the project DTM's error."""

    kind: str = setting("fractal", choices=("fractal", "urban", "file"))
    file: str = ""
    mean_height_m: float = 200.0
    relief_m: float = 60.0
    min_wavelength_m: float = 150.0
    max_wavelength_m: float = 8000.0
    resolution_m: float = 10.0
    margin_m: float = 1500.0
    dtm_error_sigma_m: float = 1.5
    dtm_error_wavelength_m: float = 400.0
    dtm_resolution_m: float = 10.0


@dataclass(frozen=True)
class SceneConfig:
    """What the ground looks like: procedural ``landcover`` or an orthophoto ``texture``."""

    kind: str = setting("landcover", choices=("landcover", "texture"))
    texture: str = ""
    texture_pixel_m: float = 0.0
    urban_fraction: float = 0.3
    forest_fraction: float = 0.15
    river: bool = True


@dataclass(frozen=True)
class TurbulenceConfig:
    """Attitude and position dynamics of the true flight: ``spectral`` (random sinusoids with a
    turbulence-like spectrum between ``period_s``) or ``replay`` of a real trajectory's dynamics."""

    kind: str = setting("spectral", choices=("spectral", "replay"))
    file: str = ""
    roll_deg: float = 1.0
    pitch_deg: float = 0.5
    heading_deg: float = 0.4
    crab_deg: float = 2.0
    pitch_trim_deg: float = 1.5
    lateral_m: float = 4.0
    vertical_m: float = 2.5
    along_m: float = 3.0
    period_s: tuple[float, ...] = setting((2.0, 60.0), length=2, gt=0)
    components: int = 48


@dataclass(frozen=True)
class FlightConfig:
    """Flight planning: north-south strips with sidelap, height above ground, speed, timing."""

    strips: int = setting(3, ge=1)
    lines: int = setting(7000, ge=50)
    height_above_ground_m: float = 2200.0
    sidelap: float = setting(0.35, ge=0.0, lt=0.9, unit="1")
    ground_speed_mps: float = 62.5
    direction: str = setting("alternate", choices=("alternate", "north", "south"))
    run_in_s: float = 8.0
    turn_s: float = 150.0
    gpsimu_rate_hz: float = setting(50.0, ge=1)
    turbulence: TurbulenceConfig = TurbulenceConfig()


@dataclass(frozen=True)
class StripErrorConfig:
    """GPS/IMU errors of one strip (or the defaults of every strip).

    ``excursion_lines`` are the epochs (image lines) between which the excursions are piecewise
    smooth: values at the epochs (``excursion_*_m``, ``excursion_roll_deg``) are joined linearly,
    and each piece gets a half-sine bulge (``bulge_*``, one per piece): continuous, with kinks at
    the inner epochs (``excursion_shape = "smooth"``: a natural cubic spline through the values
    instead of straight lines, plus the bulges). Empty lists mean no excursion. Position components in the project frame
    (x east, y north, z up).
    """

    strip: int = 0
    shift_m: tuple[float, ...] = setting((1.0, 3.0), length=2, doc="[smallest, largest]")
    rotation_deg: float = 0.001
    attitude_offset_deg: float = 0.02
    drift_m: float = 0.3
    drift_deg: float = 0.002
    drift_degree: int = 2
    random_walk_m: float = 0.005
    random_walk_deg: float = 0.00005
    jumps: int = 0
    jump_m: float = 0.3
    white_noise_m: float = 0.03
    white_noise_deg: float = 0.002
    height_wander_m: float = 1.0
    excursion_shape: str = setting("kinked", choices=("kinked", "smooth"))
    excursion_lines: tuple[float, ...] = ()
    excursion_x_m: tuple[float, ...] = ()
    excursion_y_m: tuple[float, ...] = ()
    excursion_z_m: tuple[float, ...] = ()
    excursion_roll_deg: tuple[float, ...] = ()
    bulge_x_m: tuple[float, ...] = ()
    bulge_y_m: tuple[float, ...] = ()
    bulge_z_m: tuple[float, ...] = ()
    bulge_roll_deg: tuple[float, ...] = ()


@dataclass(frozen=True)
class GpsImuErrorConfig:
    """Defaults for every strip, and overrides for chosen strips (1-based ``strip``)."""

    defaults: StripErrorConfig = StripErrorConfig()
    strip: tuple[StripErrorConfig, ...] = ()
    problem_strip: int = 0
    breaks_lines: tuple[float, ...] = ()


@dataclass(frozen=True)
class PointsConfig:
    """Control, check, tie and height points and their image measurements."""

    measurement_sigma_px: float = 0.3
    edge_margin_px: float = 10.0
    control_band_lines: float = 500.0
    control_per_band_per_strip: int = 5
    break_points_per_band_per_strip: int = 4
    break_band_lines: float = 400.0
    check_per_strip: int = 60
    tie_per_overlap: int = 60
    height_per_strip: int = 5
    control_sigma_xy_m: float = 0.05
    control_sigma_z_m: float = 0.08
    height_sigma_z_m: float = 0.1
    height_sigma_xy_m: float = 1.0
    blunders: int = 0
    blunder_px: tuple[float, ...] = setting((10.0, 40.0), length=2, doc="[smallest, largest]")


@dataclass(frozen=True)
class OutputConfig:
    """What is written: images (``GTiff`` or ``ENVI``; ``images = false`` skips rendering), the truth ortho."""

    image_format: str = setting("GTiff", choices=("GTiff", "ENVI"))
    images: bool = True
    ortho_resolution_m: float = 2.5
    truth_ortho: bool = True
    line_chunk: int = 256


@dataclass(frozen=True)
class PlatformSensorConfig(SensorConfig):
    """One sensor of a simulated platform (``[[platform.sensors]]``): the keys of ``[sensor]``, its ``id``, the
    scene bands it records, whether its strips measure the control points, and a laser scanner's pulses.

    A laser (``kind = "laser"``) uses ``fov_deg`` (the full scan angle), ``boresight_deg``, ``lever_arm_m`` and
    ``boresight_error_deg`` of the [sensor] keys and the laser keys below; its pixels and line rate are unused."""

    kind: str = setting("pushbroom", choices=("whiskbroom", "pushbroom", "laser"), doc="the sensor type")
    id: str = setting("", doc="the sensor's id in project.toml (required)")
    bands: tuple[int, ...] = setting((), doc="the scene's bands (1-11) the sensor records, in this order; empty: all")
    measures_control: bool = setting(True, doc="its strips measure the control points (E, B, H; false: a sensor "
                                     "without any control, seeing check and tie points only)")
    pulse_rate_hz: float = setting(20000.0, gt=0, doc="laser: pulses per second")
    scan_rate_hz: float = setting(40.0, gt=0, doc="laser: scan lines per second (an oscillating mirror)")
    range_sigma_m: float = setting(0.02, gt=0, doc="laser: white noise of the ranges")
    control_patches: int = setting(6, ge=0, unit="1", doc="laser: control patches (4 surveyed points each, on "
                                   "the open ground of the control flight lines)")
    check_patches: int = setting(6, ge=0, unit="1", doc="laser: check patches (over every flight line)")
    patch_sigma_m: float = setting(0.01, gt=0, doc="laser: sigma of the surveyed patch points' coordinates")


@dataclass(frozen=True)
class RelativeMountingConfig:
    """A relative-mounting prior written to project.toml: the true mounting of ``sensor`` relative to
    ``reference`` plus noise of the given sigmas (``[[platform.relative_mountings]]``)."""

    sensor: str = setting("", doc="the sensor whose mounting the prior gives (required)")
    reference: str = setting("", doc="the sensor it is relative to (required)")
    boresight_sigma_deg: tuple[float, ...] = setting((0.01, 0.01, 0.02), length=3, gt=0,
                                                     doc="roll, pitch, heading sigma of the prior (and of its noise)")
    lever_arm_sigma_m: tuple[float, ...] = setting((), doc="x, y, z sigma of a lever-arm prior; empty: none")


@dataclass(frozen=True)
class PlatformConfig:
    """Several sensors on one GPS/IMU (``[platform]``): each flight line is flown once and every sensor records
    its strip on it. Empty ``sensors``: the one ``[sensor]`` of a block."""

    sensors: tuple[PlatformSensorConfig, ...] = ()
    relative_mountings: tuple[RelativeMountingConfig, ...] = ()
    control_flight_lines: tuple[int, ...] = setting((), doc="the flight lines (1-based) whose strips measure "
                                                    "control points, placed in their zones only; empty: all")
    tie_per_flight_line: int = setting(0, ge=0, unit="1", doc="tie points in each flight line's own zone, measured "
                                       "by every image sensor on it (ties between the sensors)")


@dataclass(frozen=True)
class SimulationConfig:
    """A whole simulated block."""

    block: BlockConfig = BlockConfig()
    sensor: SensorConfig = SensorConfig()
    terrain: TerrainConfig = TerrainConfig()
    scene: SceneConfig = SceneConfig()
    flight: FlightConfig = FlightConfig()
    gpsimu_errors: GpsImuErrorConfig = GpsImuErrorConfig()
    points: PointsConfig = PointsConfig()
    output: OutputConfig = OutputConfig()
    platform: PlatformConfig = PlatformConfig()
    seed: int = setting(1, doc="random seed: the same seed gives the same block byte for byte")
    source: str = field(default="<config>", compare=False, metadata={"setting": Setting(internal=True)})

    def strip_errors(self, strip: int) -> StripErrorConfig:
        """The error configuration of strip number ``strip`` (1-based): an override or the defaults."""
        for override in self.gpsimu_errors.strip:
            if override.strip == strip:
                return override
        return dataclasses.replace(self.gpsimu_errors.defaults, strip=strip)

    @property
    def is_platform(self) -> bool:
        """Whether the block flies a platform of several sensors (``[[platform.sensors]]``)."""
        return bool(self.platform.sensors)

    def sensors(self) -> tuple[PlatformSensorConfig, ...]:
        """Every sensor of the block: the platform's, or the one ``[sensor]`` (id ``""``)."""
        if self.platform.sensors:
            return self.platform.sensors
        return (PlatformSensorConfig(**dataclasses.asdict(self.sensor)),)

    @property
    def reference_sensor(self) -> PlatformSensorConfig:
        """The sensor the flight is planned for (swath, sidelap, lines): the first line scanner."""
        return next(s for s in self.sensors() if s.kind != "laser")

    def record(self) -> dict:
        """The configuration as truth/scenario.json records it (a one-sensor block without ``platform``)."""
        data = dataclasses.asdict(self)
        if not self.is_platform:
            data.pop("platform")
        return data


# --- reading (scangeo.io.schema: every key typed and checked, errors naming the file and key) -----------
def merge(base: dict, overrides: dict) -> dict:
    """Deep merge of nested dictionaries (``overrides`` wins); lists are replaced, not merged."""
    out = dict(base)
    for key, value in overrides.items():
        if isinstance(value, dict) and isinstance(out.get(key), dict):
            out[key] = merge(out[key], value)
        else:
            out[key] = value
    return out


def config_from_dict(data: dict, source: str = "<config>") -> SimulationConfig:
    """A SimulationConfig from a parsed TOML dictionary; errors name ``source`` and the key."""
    config = read(SimulationConfig, data, source, source=source)
    validate(config)
    return config


def preset_path(name: str | Path) -> Path | Traversable:
    """The TOML file of a preset name (``small``) or a user's file path."""
    candidate = Path(name)
    if candidate.suffix == ".toml" or candidate.exists():
        if not candidate.is_file():
            raise MissingFileError(f"{candidate}: preset file not found")
        return candidate
    path = preset_file(str(name))
    if path is None:
        known = ", ".join(available_presets()) or "none"
        raise ProjectFileError(f"unknown preset {name!r} (known presets: {known}; or give a .toml file)")
    return path


def available_presets() -> list[str]:
    """Names of the presets shipped with the package (scangeo/data/presets)."""
    return preset_names()


def load_preset(name: str | Path, overrides: dict | None = None) -> SimulationConfig:
    """Read a preset (name or TOML path), apply nested ``overrides`` (same keys as the file).

    A preset with ``extends = "NAME"`` is that preset with the file's keys merged over it (:func:`merge`:
    tables merged key by key, arrays and arrays of tables replaced whole)."""
    path = preset_path(name)
    data = _extended(load_toml(path), str(path), ())
    if overrides:
        data = merge(data, overrides)
    return config_from_dict(data, source=str(path))


def _extended(data: dict, source: str, seen: tuple[str, ...]) -> dict:
    """A preset's table with the preset it ``extends`` under it (recursively; a cycle is an error)."""
    base = data.pop("extends", None)
    if base is None:
        return data
    if not isinstance(base, str) or not base:
        raise ProjectFileError(f"{source} [extends]: expected the name or file of a preset, found {base!r}")
    path = preset_path(base)
    if str(path) in seen or str(path) == source:
        raise ProjectFileError(f"{source} [extends]: {base!r} extends itself (through {', '.join(seen) or source})")
    return merge(_extended(load_toml(path), str(path), (*seen, source)), data)


def validate(config: SimulationConfig) -> None:
    """Raise ProjectFileError for values that cannot make a block."""
    checks = [
        (config.terrain.kind != "file" or bool(config.terrain.file), "terrain.file", "a DTM path with kind = 'file'"),
        (config.scene.kind != "texture" or bool(config.scene.texture), "scene.texture",
         "an image path with kind = 'texture'"),
        (0 <= config.gpsimu_errors.problem_strip <= config.flight.strips, "gpsimu_errors.problem_strip",
         "0 (none) or a strip number"),
    ]
    for ok, key, expected in checks:
        if not ok:
            raise ProjectFileError(f"{config.source} [{key}]: expected {expected}")
    for errors in (config.gpsimu_errors.defaults, *config.gpsimu_errors.strip):
        _validate_strip_errors(errors, config)
    _validate_platform(config)


def _validate_platform(config: SimulationConfig) -> None:
    """The platform's sensors, relative mountings and control flight lines name what exists."""
    p, where = config.platform, f"{config.source} [platform"
    if not p.sensors:
        if p.relative_mountings or p.control_flight_lines or p.tie_per_flight_line:
            raise ProjectFileError(f"{where}]: relative_mountings, control_flight_lines and tie_per_flight_line "
                                   "need [[platform.sensors]]")
        return
    if config.sensor != SensorConfig():
        raise ProjectFileError(f"{config.source} [sensor]: give [sensor] (one sensor) or [[platform.sensors]], "
                               "not both")
    ids = [s.id for s in p.sensors]
    for k, s in enumerate(p.sensors):
        if not s.id or ids.index(s.id) != k:
            raise ProjectFileError(f"{where}.sensors] entry {k + 1}: expected a unique, non-empty id, found {s.id!r}")
        if any(not 1 <= b <= 11 for b in s.bands) or len(set(s.bands)) != len(s.bands):
            raise ProjectFileError(f"{where}.sensors.bands] of {s.id}: expected distinct scene bands 1-11, "
                                   f"found {list(s.bands)}")
    if all(s.kind == "laser" for s in p.sensors):
        raise ProjectFileError(f"{where}.sensors]: expected at least one line scanner (whiskbroom or pushbroom) "
                               "to plan the flight for")
    for r in p.relative_mountings:
        if r.sensor not in ids or r.reference not in ids or r.sensor == r.reference:
            raise ProjectFileError(f"{where}.relative_mountings]: sensor {r.sensor!r} and reference {r.reference!r} "
                                   f"must be two of the sensors {', '.join(ids)}")
        if len(r.lever_arm_sigma_m) not in (0, 3) or any(v <= 0 for v in r.lever_arm_sigma_m):
            raise ProjectFileError(f"{where}.relative_mountings.lever_arm_sigma_m]: expected 3 positive sigmas "
                                   f"(or none), found {list(r.lever_arm_sigma_m)}")
    bad = [n for n in p.control_flight_lines if not 1 <= n <= config.flight.strips]
    if bad:
        raise ProjectFileError(f"{where}.control_flight_lines]: {bad[0]} is not a flight line "
                               f"(1..{config.flight.strips})")


def _validate_strip_errors(errors: StripErrorConfig, config: SimulationConfig) -> None:
    key = f"gpsimu_errors.strip {errors.strip}" if errors.strip else "gpsimu_errors.defaults"
    if errors.strip and not 1 <= errors.strip <= config.flight.strips:
        raise ProjectFileError(f"{config.source} [{key}]: strip must be 1..{config.flight.strips}")
    n = len(errors.excursion_lines)
    for name in ("excursion_x_m", "excursion_y_m", "excursion_z_m", "excursion_roll_deg"):
        if len(getattr(errors, name)) not in (0, n):
            raise ProjectFileError(f"{config.source} [{key}.{name}]: expected {n} values (one per excursion line)")
    for name in ("bulge_x_m", "bulge_y_m", "bulge_z_m", "bulge_roll_deg"):
        if len(getattr(errors, name)) not in (0, max(n - 1, 0)):
            raise ProjectFileError(f"{config.source} [{key}.{name}]: expected {max(n - 1, 0)} values (one per piece)")
    if n and any(b <= a for a, b in zip(errors.excursion_lines, errors.excursion_lines[1:])):
        raise ProjectFileError(f"{config.source} [{key}.excursion_lines]: lines must increase")

