"""A laser project: ``project.toml`` whose sensor is a laser scanner, strips as LAS/LAZ files.

    [project]
    crs = "EPSG:32633"                 # map CRS of the points, ground.csv and the outputs
    origin = [lat, lon, h]             # project frame origin (deg, deg, m); default: centre of the strips
    geoid_undulation_m = 0.0
    [sensor]
    kind = "laser"
    boresight_deg = [0, 0, 0]          # roll, pitch, heading of the scanner in the body frame
    lever_arm_m = [0, 0, 0]            # body frame (forward, right, down)
    range_sigma_m = 0.02               # ranging precision (plane fits' a priori sigma)
    angle_sigma_deg = 0.005            # scan-angle precision (documentation and the report)
    fov_deg, pulse_rate_hz, scan_rate_hz, scan_pattern   # the scan pattern (informative)
    [[strips]]
    id = "1"
    las = "strips/1.laz"               # or a list of files
    point_source_id = 7326             # optional: only the returns of this flight line
    trajectory = "nav/1.csv"           # optional (CSV or SBET): without it, the trajectory-free mode
    mission = "A"                      # optional (default "1"): the flight; [adjustment] models = "mission"

Options of the adjustment itself (``[adjustment]``) are documented in :mod:`scangeo.lidar.adjust`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np

from scangeo.errors import MissingFileError, ProjectFileError
from scangeo.frames import Geoid, MapFrame, ProjectFrame, parse_crs
from scangeo.io.schema import read, setting
from scangeo.io.toml_config import load_toml
from scangeo.lidar.georeference import Calibration
from scangeo.lidar.lasio import bounds
from scangeo.trajectory.readers import read_trajectory


# --- the keys of a laser project.toml (scangeo.io.schema: every key typed, errors naming file and key) ---
@dataclass(frozen=True)
class LaserProjectKeys:
    """The ``[project]`` table of a laser project."""

    crs: str = setting(doc="map CRS of the points, ground.csv and the outputs")
    origin: tuple[float, float, float] | None = setting(None, unit="deg, deg, m", default_doc="centre of the strips",
                                                        doc="project frame origin: lat, lon, ellipsoidal h")
    geoid_undulation_m: float = setting(0.0, doc="constant geoid undulation N")
    trajectory_crs: str | None = setting(None, default_doc="`crs`", doc="CRS of x, y trajectory CSVs")


@dataclass(frozen=True)
class LaserSensorKeys:
    """The ``[sensor]`` table of a laser project."""

    kind: str = setting(choices=("laser",), doc="laser for scangeo lidar adjust")
    boresight_deg: tuple[float, float, float] = setting((0.0, 0.0, 0.0), doc="roll, pitch, heading in the body frame")
    lever_arm_m: tuple[float, float, float] = setting((0.0, 0.0, 0.0), doc="body frame (forward, right, down)")
    range_sigma_m: float = setting(0.02, gt=0, doc="ranging precision (plane fits' a priori sigma)")
    angle_sigma_deg: float = setting(0.005, gt=0, doc="scan-angle precision")
    range_offset_m: float = setting(0.0, doc="range offset")
    scan_index_deg: float = setting(0.0, doc="scan-angle index error")
    fov_deg: float | None = setting(None, gt=0, doc="scan pattern (informative)")
    pulse_rate_hz: float | None = setting(None, gt=0, doc="scan pattern (informative)")
    scan_rate_hz: float | None = setting(None, gt=0, doc="scan pattern (informative)")
    scan_pattern: str | None = setting(None, doc="scan pattern (informative)")


@dataclass(frozen=True)
class LaserStripKeys:
    """One ``[[strips]]`` entry of a laser project."""

    id: str = setting(file_type=str | int, parse=lambda v, where: str(v), doc="the strip's name")
    las: str | tuple[str, ...] = setting(doc="LAS/LAZ file or a list of them")
    point_source_id: int | None = setting(None, unit="1", doc="only the returns of this flight line")
    trajectory: str | None = setting(None, doc="CSV or SBET; without it the trajectory-free mode")
    mission: str = setting("1", file_type=str | int, parse=lambda v, where: str(v),
                           doc="the mission (flight) the strip belongs to: GPS/IMU models per mission")


@dataclass(frozen=True)
class LaserProjectFile:
    """A laser project.toml: these four tables and nothing else."""

    project: LaserProjectKeys = setting(doc="the project")
    sensor: LaserSensorKeys = setting(doc="the laser scanner")
    strips: tuple[LaserStripKeys, ...] = setting((), doc="one per strip (at least one)")
    adjustment: dict[str, Any] | None = setting(None, default_doc="{}",
                                                doc="options of the adjustment (scangeo.lidar.adjust)")


@dataclass(frozen=True)
class LaserSensor:
    boresight_deg: tuple[float, float, float]
    lever_arm_m: tuple[float, float, float]
    range_sigma_m: float = 0.02
    angle_sigma_deg: float = 0.005
    range_offset_m: float = 0.0
    scan_index_deg: float = 0.0
    info: dict = field(default_factory=dict)

    def calibration(self) -> Calibration:
        return Calibration.of(
            np.radians(self.boresight_deg), self.lever_arm_m, self.range_offset_m, np.radians(self.scan_index_deg)
        )


@dataclass(frozen=True)
class LaserStrip:
    id: str
    las: tuple[Path, ...]
    point_source_id: int | None
    trajectory: Path | None
    mission: str = "1"


@dataclass(frozen=True)
class LaserProject:
    root: Path
    crs: str
    origin: tuple[float, float, float] | None
    geoid: Geoid
    sensor: LaserSensor
    strips: tuple[LaserStrip, ...]
    adjustment: dict
    trajectory_crs: str | None = None

    @classmethod
    def load(cls, path) -> LaserProject:
        path = Path(path)
        file = path / "project.toml" if path.is_dir() else path
        if not file.exists():
            raise MissingFileError(f"{file}: no such project file")
        root = file.parent
        keys: LaserProjectFile = read(LaserProjectFile, load_toml(file), str(file))
        p, s = keys.project, keys.sensor
        info = {k: getattr(s, k) for k in ("fov_deg", "pulse_rate_hz", "scan_rate_hz", "scan_pattern")}
        sensor = LaserSensor(s.boresight_deg, s.lever_arm_m, s.range_sigma_m, s.angle_sigma_deg, s.range_offset_m,
                             s.scan_index_deg, {k: v for k, v in info.items() if v is not None})
        if not keys.strips:
            raise ProjectFileError(f"{file}: expected at least one [[strips]] entry")
        strips = []
        for i, t in enumerate(keys.strips):
            names = (t.las,) if isinstance(t.las, str) else t.las
            if not names:
                raise ProjectFileError(f"{file} [strips[{i}].las]: expected a file name or a list of them, found []")
            strips.append(LaserStrip(t.id, tuple(root / n for n in names), t.point_source_id,
                                     root / t.trajectory if t.trajectory else None, t.mission))
        ids = [st.id for st in strips]
        dup = sorted({i for i in ids if ids.count(i) > 1})
        if dup:
            raise ProjectFileError(f"{file}: strip id {dup[0]!r} appears more than once")
        parse_crs(p.crs, f"{file} [project.crs]")
        if p.trajectory_crs is not None:
            parse_crs(p.trajectory_crs, f"{file} [project.trajectory_crs]")
        return cls(root, p.crs, p.origin, Geoid(p.geoid_undulation_m), sensor, tuple(strips),
                   dict(keys.adjustment or {}), p.trajectory_crs)

    @property
    def has_trajectories(self) -> bool:
        return all(s.trajectory is not None for s in self.strips)

    @cached_property
    def map_frame(self) -> MapFrame:
        if self.origin is not None:
            return MapFrame(self.crs, ProjectFrame.from_origin(*self.origin), self.geoid)
        b = np.array([bounds(f) for s in self.strips for f in s.las])
        cx, cy = 0.5 * (b[:, 0].min() + b[:, 2].max()), 0.5 * (b[:, 1].min() + b[:, 3].max())
        return MapFrame.centred_on(self.crs, float(cx), float(cy), 0.0, self.geoid)

    def trajectory(self, strip: LaserStrip):
        """The strip's GPS/IMU in the project frame (ProjectTrajectory)."""
        if strip.trajectory is None:
            raise ProjectFileError(f"{self.root / 'project.toml'}: strip {strip.id} has no trajectory")
        stream = read_trajectory(strip.trajectory, crs=self.trajectory_crs or self.crs)
        return stream.to_project(self.map_frame.frame)
