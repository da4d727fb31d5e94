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

Options of the adjustment itself (``[adjustment]``) are documented in :mod:`scangeo.lidar.adjust`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np

from scangeo.errors import ProjectFileError
from scangeo.frames import Geoid, MapFrame, ProjectFrame
from scangeo.io.toml_config import Table, load_toml
from scangeo.lidar.georeference import Calibration


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
            raise ProjectFileError(f"{file}: no such project file")
        root = file.parent
        data = load_toml(file)
        for key in data:
            if key not in ("project", "sensor", "strips", "adjustment"):
                raise ProjectFileError(f"{file}: unknown table [{key}] (expected project, sensor, strips, adjustment)")
        p = Table(data.get("project", {}), file, "project")
        crs = p.get("crs", str)
        origin = p.vector("origin", 3, None)
        geoid = Geoid(p.get("geoid_undulation_m", float, 0.0))
        traj_crs = p.get("trajectory_crs", str, None)
        p.finish()
        s = Table(data.get("sensor", {}), file, "sensor")
        kind = s.get("kind", str)
        if kind != "laser":
            raise ProjectFileError(f"{file} [sensor] kind: expected 'laser' for scangeo lidar adjust, found {kind!r}")
        info = {
            k: s.get(k, (int, float, str), None) for k in ("fov_deg", "pulse_rate_hz", "scan_rate_hz", "scan_pattern")
        }
        sensor = LaserSensor(
            tuple(s.vector("boresight_deg", 3, [0.0, 0.0, 0.0])),
            tuple(s.vector("lever_arm_m", 3, [0.0, 0.0, 0.0])),
            s.get("range_sigma_m", float, 0.02),
            s.get("angle_sigma_deg", float, 0.005),
            s.get("range_offset_m", float, 0.0),
            s.get("scan_index_deg", float, 0.0),
            {k: v for k, v in info.items() if v is not None},
        )
        s.finish()
        raw = data.get("strips", [])
        if not isinstance(raw, list) or not raw:
            raise ProjectFileError(f"{file}: expected at least one [[strips]] entry")
        strips = []
        for i, entry in enumerate(raw):
            t = Table(entry, file, f"strips #{i + 1}")
            sid = str(t.get("id", (str, int)))
            las = t.get("las", (str, list))
            files = tuple(root / f for f in ([las] if isinstance(las, str) else las))
            if not files or not all(isinstance(f, Path) for f in files):
                raise ProjectFileError(f"{file} [strips #{i + 1}] las: expected a file name or a list of them")
            traj = t.get("trajectory", str, None)
            strips.append(LaserStrip(sid, files, t.get("point_source_id", int, None), root / traj if traj else None))
            t.finish()
        ids = [s.id for s in strips]
        dup = sorted({i for i in ids if ids.count(i) > 1})
        if dup:
            raise ProjectFileError(f"{file}: strip id {dup[0]!r} appears more than once")
        adjustment = data.get("adjustment", {})
        if not isinstance(adjustment, dict):
            raise ProjectFileError(f"{file} [adjustment]: expected a table")
        return cls(root, crs, tuple(origin) if origin else None, geoid, sensor, tuple(strips), adjustment, traj_crs)

    @property
    def has_trajectories(self) -> bool:
        return all(s.trajectory is not None for s in self.strips)

    @cached_property
    def map_frame(self) -> MapFrame:
        if self.origin is not None:
            return MapFrame(self.crs, ProjectFrame.from_origin(*self.origin), self.geoid)
        from scangeo.lidar.lasio import bounds

        b = np.array([bounds(f) for s in self.strips for f in s.las])
        cx, cy = 0.5 * (b[:, 0].min() + b[:, 2].max()), 0.5 * (b[:, 1].min() + b[:, 3].max())
        return MapFrame.centred_on(self.crs, float(cx), float(cy), 0.0, self.geoid)

    def trajectory(self, strip: LaserStrip):
        """The strip's GPS/IMU in the project frame (ProjectTrajectory)."""
        from scangeo.trajectory.readers import read_trajectory

        if strip.trajectory is None:
            raise ProjectFileError(f"{self.root / 'project.toml'}: strip {strip.id} has no trajectory")
        stream = read_trajectory(strip.trajectory, crs=self.trajectory_crs or self.crs)
        return stream.to_project(self.map_frame.frame)
