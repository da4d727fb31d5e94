"""Which orientation a variant rectifies with: direct georeferencing or an adjustment's result.

* ``PROJECT/results/NAME/`` written by ``scangeo adjust`` -> the adjusted orientation: per strip the
  spline ``spline_<id>.json`` (exact: t0, spacing, coefficients in the project frame) or, without
  it, ``trajectory_<id>.csv`` (the input trajectory format) refitted with the project's knot
  spacing; the adjusted calibration from ``report.json``: its ``coefficients`` entries of blocks
  ``Boresight()`` (deg), ``LeverArm()`` (m), ``TimeOffset()`` (s), ``ScanIndex()`` (deg),
  ``ScanScale()`` (free components only; fixed ones keep the project's values), and ``sigma0``.
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

    def spline_file(self, strip_id: str) -> Path | None:
        path = self.folder / f"spline_{strip_id}.json"
        return path if path.exists() else None

    def trajectory_file(self, strip_id: str) -> Path:
        for candidate in (self.folder / f"trajectory_{strip_id}.csv", self.folder / "trajectories" / f"{strip_id}.csv"):
            if candidate.exists():
                return candidate
        raise ProjectFileError(
            f"{self.folder}: no adjusted orientation for strip {strip_id} "
            f"(expected spline_{strip_id}.json or trajectory_{strip_id}.csv)"
        )

    def files(self, strip_id: str) -> list[Path]:
        """The files this strip's orientation is read from (for resume fingerprints)."""
        if not self.adjusted:
            return []
        out = [self.spline_file(strip_id) or self.trajectory_file(strip_id)]
        if (self.folder / "report.json").exists():
            out.append(self.folder / "report.json")
        return out


def results_folder(project: Project, variant: str) -> Path:
    return project.root / "results" / variant


def orientation_source(project: Project, variant: str) -> OrientationSource:
    """The orientation of ``variant``: adjusted when its results exist, DG otherwise."""
    folder = results_folder(project, variant)
    has_trajectories = folder.is_dir() and (
        any(folder.glob("spline_*.json")) or any(folder.glob("trajectory_*.csv")) or (folder / "trajectories").is_dir()
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


#: report.json coefficient blocks -> (component names in order, factor to SI units)
_CALIBRATION = {
    "Boresight()": (("roll", "pitch", "heading"), np.pi / 180.0),
    "LeverArm()": (("x", "y", "z"), 1.0),
    "TimeOffset()": (("dt",), 1.0),
    "ScanIndex()": (("index",), np.pi / 180.0),
    "ScanScale()": (("scale",), 1.0),
}


def calibration(report: dict | None) -> dict[str, np.ndarray]:
    """Adjusted calibration values (SI units) by block label, from report.json's coefficients."""
    out: dict[str, np.ndarray] = {}
    for entry in (report or {}).get("coefficients", []) or []:
        block = entry.get("block")
        if block not in _CALIBRATION or entry.get("value") is None:
            continue
        names, factor = _CALIBRATION[block]
        values = out.setdefault(block, np.full(len(names), np.nan))
        name = str(entry.get("name", ""))
        index = next((i for i, n in enumerate(names) if n == name or name.endswith(n)), 0 if len(names) == 1 else None)
        if index is None:
            log.warning("report.json: calibration component %r of %s not understood, ignored", name, block)
            continue
        values[index] = float(entry["value"]) * factor
    return out


def _spline(path: Path) -> OrientationSpline:
    try:
        data = json.loads(path.read_text())
        return OrientationSpline(float(data["t0"]), float(data["spacing"]), np.asarray(data["coef"], float))
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise ProjectFileError(f"{path}: not an adjusted spline (expected t0, spacing, coef): {exc}") from exc


def core_geometry(project: Project, source: OrientationSource, strip_id: str) -> CoreGeometry:
    """The strip's geometry for the variant (geometry core)."""
    if not source.adjusted:
        return project.geometry(strip_id)
    spline_file = source.spline_file(strip_id)
    if spline_file is not None:
        spline = _spline(spline_file)
    else:
        stream = read_trajectory(source.trajectory_file(strip_id), crs=project.trajectory_crs or project.crs)
        spline = OrientationSpline.from_trajectory(stream.to_project(project.map_frame.frame), project.knot_spacing)
    base = project.sensor.mounting
    cal = calibration(source.report)

    def pick(block, default):
        v = cal.get(block)
        return np.where(np.isfinite(v), v, default) if v is not None else np.asarray(default, float)

    mounting = Mounting(
        lever_arm_B=pick("LeverArm()", base.lever_arm_B),
        boresight=pick("Boresight()", base.boresight),
        time_offset=float(pick("TimeOffset()", [base.time_offset])[0]),
    )
    sensor = project.sensor.model
    if hasattr(sensor, "with_calibration") and ("ScanIndex()" in cal or "ScanScale()" in cal):
        sensor = sensor.with_calibration(
            index_error=float(pick("ScanIndex()", [sensor.index_error])[0]),
            scale_error=float(pick("ScanScale()", [sensor.scale_error])[0]),
        )
    log.info("strip %s: adjusted orientation of %s from %s", strip_id, source.variant, source.folder)
    return project.geometry(strip_id, spline=spline, mounting=mounting, sensor=sensor)
