"""Which orientation a variant rectifies with: direct georeferencing or an adjustment's result.

* ``PROJECT/results/NAME/`` holding adjusted trajectories -> the adjusted orientation: per strip
  ``trajectory_<id>.csv`` (or ``trajectories/<id>.csv``), the same format as the input trajectory
  CSV (``time,lat,lon,h,roll,pitch,heading``, degrees), refitted with the project's knot spacing;
  the adjusted mounting, scanner calibration and sigma0 from ``report.json`` when it states them
  (``sigma0``; ``mounting.lever_arm_m``, ``mounting.boresight_deg``, ``mounting.time_offset_s``;
  ``scanner.index_error_deg``, ``scanner.scale_error``).
* no such folder and the variant ``DG`` -> direct georeferencing: the GPS/IMU stream as measured.
* no such folder and another variant -> an error: adjust first.
"""
from __future__ import annotations

import json
import logging
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from scangeo.errors import ProjectFileError
from scangeo.io.project import Project
from scangeo.sensors import Mounting
from scangeo.sensors import StripGeometry as CoreGeometry
from scangeo.trajectory.readers import read_trajectory
from scangeo.trajectory.spline import OrientationSpline

log = logging.getLogger(__name__)

DIRECT = "DG"


@dataclass(frozen=True)
class OrientationSource:
    """Where a variant's orientation comes from."""

    variant: str
    folder: Path | None = None
    sigma0: float | None = None
    report: dict | None = None

    @property
    def adjusted(self) -> bool:
        return self.folder is not None

    def trajectory_file(self, strip_id: str) -> Path:
        for candidate in (self.folder / f"trajectory_{strip_id}.csv", self.folder / "trajectories" / f"{strip_id}.csv"):
            if candidate.exists():
                return candidate
        raise ProjectFileError(
            f"{self.folder}: no adjusted trajectory for strip {strip_id} "
            f"(expected trajectory_{strip_id}.csv or trajectories/{strip_id}.csv)"
        )

    def files(self, strip_id: str) -> list[Path]:
        """The files this strip's orientation is read from (for resume fingerprints)."""
        if not self.adjusted:
            return []
        out = [self.trajectory_file(strip_id)]
        if (self.folder / "report.json").exists():
            out.append(self.folder / "report.json")
        return out


def results_folder(project: Project, variant: str) -> Path:
    return project.root / "results" / variant


def orientation_source(project: Project, variant: str) -> OrientationSource:
    """The orientation of ``variant``: adjusted when its results exist, DG otherwise."""
    folder = results_folder(project, variant)
    has_trajectories = folder.is_dir() and (
        any(folder.glob("trajectory_*.csv")) or (folder / "trajectories").is_dir()
    )
    if not has_trajectories:
        if variant.upper() == DIRECT:
            return OrientationSource(variant)
        raise ProjectFileError(
            f"{folder}: no adjusted trajectories for variant {variant!r} (run 'scangeo adjust "
            f"{project.root} --variant {variant}' first, or rectify with --variant {DIRECT})"
        )
    report = None
    if (folder / "report.json").exists():
        try:
            report = json.loads((folder / "report.json").read_text())
        except (OSError, ValueError) as exc:
            raise ProjectFileError(f"{folder / 'report.json'}: cannot read ({exc})") from exc
    sigma0 = _number(report, ("sigma0",), ("statistics", "sigma0"))
    return OrientationSource(variant, folder, sigma0, report)


def _number(report: dict | None, *paths) -> float | None:
    for path in paths:
        node = report
        for key in path:
            node = node.get(key) if isinstance(node, dict) else None
        if isinstance(node, (int, float)):
            return float(node)
    return None


def core_geometry(project: Project, source: OrientationSource, strip_id: str) -> CoreGeometry:
    """The strip's geometry for the variant (geometry core)."""
    if not source.adjusted:
        return project.geometry(strip_id)
    stream = read_trajectory(source.trajectory_file(strip_id), crs=project.trajectory_crs or project.crs)
    spline = OrientationSpline.from_trajectory(stream.to_project(project.map_frame.frame), project.knot_spacing)
    mounting = project.sensor.mounting
    sensor = project.sensor.model
    report = source.report or {}
    m = report.get("mounting") if isinstance(report.get("mounting"), dict) else None
    if m:
        mounting = Mounting(
            lever_arm_B=np.asarray(m.get("lever_arm_m", mounting.lever_arm_B), float),
            boresight=np.radians(m["boresight_deg"]) if "boresight_deg" in m else mounting.boresight,
            time_offset=float(m.get("time_offset_s", mounting.time_offset)),
        )
    s = report.get("scanner") if isinstance(report.get("scanner"), dict) else None
    if s and hasattr(sensor, "with_calibration"):
        sensor = sensor.with_calibration(
            index_error=float(np.radians(s.get("index_error_deg", 0.0))), scale_error=float(s.get("scale_error", 0.0))
        )
    log.info("strip %s: adjusted orientation of %s from %s", strip_id, source.variant, source.folder)
    return project.geometry(strip_id, spline=spline, mounting=mounting, sensor=sensor)
