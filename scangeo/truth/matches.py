"""How good matched points are, on a simulated project (against ``truth/``).

A tie point's measurement in its first (master) strip is cast onto the true terrain through the
true orientation; that true ground point, seen through the true orientation of every other strip,
is where the other measurements should be. A control point's measurement, cast onto the true
terrain, gives the true ground position the point's x, y should have.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from scangeo.errors import ProjectFileError
from scangeo.io.points import GroundPoints, ImagePoints
from scangeo.io.project import Project
from scangeo.sensors.kernels import MULTIPLE
from scangeo.truth.true_error import Truth


@dataclass(frozen=True)
class MatchErrors:
    """True errors of matched measurements: ties in image pixels, control in map units."""

    tie_errors_px: np.ndarray  # (n, 2): line, pixel of the non-master measurements
    tie_points: np.ndarray  # point id of every row of tie_errors_px
    control_errors_m: np.ndarray  # (m, 2): x, y of control and check points

    def tie_rms(self) -> float:
        e = self.tie_errors_px
        return float(np.sqrt(np.mean(e**2))) if e.size else float("nan")

    def share_within(self, limit_px: float) -> float:
        d = np.hypot(*self.tie_errors_px.T) if self.tie_errors_px.size else np.empty(0)
        return float(np.mean(d <= limit_px)) if d.size else float("nan")


def match_errors(project_dir: str | Path, prefix: str = "M") -> MatchErrors:
    """True errors of the matched points (ids starting with ``prefix``) of a simulated project."""
    project = Project.load(project_dir)
    truth = Truth.load(project)
    if truth is None:
        raise ProjectFileError(f"{project.root}: no truth/ folder (not a simulated project)")
    pts = ImagePoints.read(project.root / "points.csv")
    mine = np.array([str(p).startswith(prefix) for p in pts.point])
    ties, ids = [], []
    ground = GroundPoints.read(project.root / "ground.csv") if (project.root / "ground.csv").exists() else None
    known = {} if ground is None else {str(p): xyz for p, xyz in zip(ground.point, ground.xyz)}
    control = []
    frame = project.map_frame
    for pid in dict.fromkeys(pts.point[mine].tolist()):
        rows = np.flatnonzero(pts.point == pid)
        master = rows[0]
        g = truth.geometries[str(pts.strip[master])]
        p_P, status = g.image_to_ground(pts.line[[master]], pts.pixel[[master]], truth.terrain)
        if status[0] != 0:
            continue
        if pid in known:
            x, y, _ = frame.project_to_map(p_P)
            control.append([x[0] - known[pid][0], y[0] - known[pid][1]])
            continue
        for r in rows[1:]:
            # of a point the over-scanning mirror sees more than once, the sighting nearest the match
            ln, px, st = truth.geometries[str(pts.strip[r])].nearest_sighting(p_P, pts.line[[r]], pts.pixel[[r]])
            if (st[0] & ~MULTIPLE) == 0:
                ties.append([pts.line[r] - ln[0], pts.pixel[r] - px[0]])
                ids.append(pid)
    return MatchErrors(np.array(ties).reshape(-1, 2), np.array(ids, dtype=object),
                       np.array(control).reshape(-1, 2))


def matched_points_project(source: str | Path, target: str | Path, prefix: str = "M",
                           check_prefix: str = "K") -> Path:
    """A copy of a simulated project whose points are only the matched ones plus the simulator's
    check points (ids starting with ``check_prefix``, kept as role ``check``): the project on which
    an adjustment with matched points is compared with the same adjustment on the simulator's points.
    """
    import shutil

    source, target = Path(source), Path(target)
    shutil.copytree(source, target, ignore=shutil.ignore_patterns("results", "variants.toml"))
    pts = ImagePoints.read(source / "points.csv")
    ground = GroundPoints.read(source / "ground.csv")
    # the matched check points go: both projects are judged on the same (simulator's) check points
    matched_check = {str(p) for p, r in zip(ground.point, ground.role) if str(p).startswith(prefix) and r == "check"}
    keep = np.array([str(p).startswith((prefix, check_prefix)) and str(p) not in matched_check for p in pts.point])
    ImagePoints(pts.point[keep], pts.strip[keep], pts.line[keep], pts.pixel[keep], pts.sigma_px[keep],
                pts.file_line[keep]).write(target / "points.csv")
    keep_g = np.array([(str(p).startswith(prefix) and r != "check")
                       or (str(p).startswith(check_prefix) and r == "check")
                       for p, r in zip(ground.point, ground.role)])
    GroundPoints(ground.point[keep_g], ground.xyz[keep_g], ground.sigma_xy[keep_g], ground.sigma_z[keep_g],
                 ground.role[keep_g], ground.file_line[keep_g]).write(target / "ground.csv")
    return target
