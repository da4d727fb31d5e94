"""The true error of an adjusted orientation on a simulated project (against ``truth/``).

Check points measure an orientation only where they are, and with their measurement noise. A
simulated project knows the truth everywhere: ``truth/trajectory_<id>.csv`` (the flown
trajectory), ``truth/errors.json`` (the true boresight) and ``truth/terrain.tif`` (the true
terrain). On a grid of image positions (``lines`` x ``pixels`` samples over the whole image) the
true ground point is the true ray on the true terrain; the error of an orientation there is

* in the image: the true ground point projected with the orientation (ground -> image) minus the
  image position, along track in lines and across track in pixels (the sign of a check-point
  residual: model - measured);
* on the ground: the orientation's ray from the same image position on the true terrain minus
  the true ground point, horizontally, in metres.

Both leave out the DTM error and the measurement noise: they are the orientation's own error. The
image error leaves out the samples at the folds of an over-scanning mirror's scan lines, where the truth
itself sees the ground point more than once (:meth:`Truth.one_to_one`); of a point the orientation sees
more than once, the sighting nearest the sample counts
(:meth:`~scangeo.sensors.strip.StripGeometry.nearest_sighting`).
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field

import numpy as np

from scangeo.dtm import DTM
from scangeo.errors import ProjectFileError
from scangeo.io.project import Project
from scangeo.sensors.strip import MULTIPLE, Mounting, StripGeometry
from scangeo.trajectory.readers import read_trajectory
from scangeo.trajectory.spline import OrientationSpline


@dataclass(frozen=True)
class TrueError:
    """rms of an orientation's true error over a strip's sample grid (see the module doc)."""

    n: int
    rms_along_px: float
    rms_across_px: float
    rms_ground_m: float
    max_ground_m: float

    def as_dict(self) -> dict:
        return {"n": self.n, "rms_along_px": self.rms_along_px, "rms_across_px": self.rms_across_px,
                "rms_ground_m": self.rms_ground_m, "max_ground_m": self.max_ground_m}


@dataclass
class Truth:
    """The true geometry of a simulated project and its sample grid per strip (true ground points)."""

    project: Project
    terrain: DTM
    geometries: dict[str, StripGeometry]
    lines: int = 60
    pixels: int = 13
    _samples: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]] = field(default_factory=dict)
    _one_to_one: dict[str, np.ndarray] = field(default_factory=dict)

    @classmethod
    def load(cls, project: Project, lines: int = 60, pixels: int = 13) -> Truth | None:
        """The truth of ``project`` (None when it has no ``truth/`` folder of a simulation)."""
        folder = project.root / "truth"
        info_file = folder / "errors.json"
        if not info_file.exists() or not (folder / "terrain.tif").exists():
            return None
        try:
            info = json.loads(info_file.read_text())
            given = info["true_boresight_deg"]  # a list (one sensor), or per sensor id (a platform)
            boresights = {sid: np.radians(np.asarray(given[sid] if isinstance(given, dict) else given, float))
                          for sid in {s.sensor for s in project.image_strips}}
        except (OSError, ValueError, KeyError, TypeError) as exc:
            raise ProjectFileError(f"{info_file}: expected true_boresight_deg, a list of 3 angles or one per sensor "
                                   f"({exc})") from exc
        frame = project.map_frame.frame
        geometries = {}
        splines: dict[str, OrientationSpline] = {}
        for s in project.image_strips:
            if s.flight_line not in splines:  # the true trajectory of each flight line (a strip's own: its id)
                path = folder / f"trajectory_{s.flight_line}.csv"
                if not path.exists():
                    raise ProjectFileError(f"{path}: the true trajectory of flight line {s.flight_line} is missing")
                traj = read_trajectory(path, crs=project.trajectory_crs or project.crs).to_project(frame)
                spacing = float(np.median(np.diff(traj.time)))  # one knot per sample: the truth as simulated
                splines[s.flight_line] = OrientationSpline.from_trajectory(traj, spacing)
            mount = project.scanner_of(s.id).mounting
            mounting = Mounting(mount.lever_arm_B, boresights[s.sensor], mount.time_offset)
            geometries[s.id] = project.geometry(s.id, spline=splines[s.flight_line], mounting=mounting)
        terrain = DTM.open(folder / "terrain.tif", project.map_frame)
        return cls(project, terrain, geometries, lines, pixels)

    def samples(self, strip_id: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(line, pixel, true ground point p_P (n, 3)) of the strip's sample grid (points that hit the terrain)."""
        if strip_id not in self._samples:
            g = self.geometries[strip_id]
            line_grid, pixel_grid = np.meshgrid(np.linspace(0.0, g.n_lines - 1.0, self.lines),
                                                np.linspace(0.0, g.sensor.pixels - 1.0, self.pixels), indexing="ij")
            line, pixel = line_grid.ravel(), pixel_grid.ravel()
            p_P, status = g.image_to_ground(line, pixel, self.terrain)
            ok = (status == 0) & np.isfinite(p_P).all(axis=1)
            self._samples[strip_id] = (line[ok], pixel[ok], p_P[ok])
        return self._samples[strip_id]

    def one_to_one(self, strip_id: str) -> np.ndarray:
        """Of the strip's samples, those whose true ground point the true orientation sees once, at the
        sample (to 1e-3 lines and pixels). The others lie where the over-scanning mirror's scan lines fold
        over one another at the swath's edges: there the image position of a ground point is not one, and
        no orientation's error in the image is defined (their ground error still is)."""
        if strip_id not in self._one_to_one:
            line, pixel, p_true = self.samples(strip_id)
            l_t, p_t, status = self.geometries[strip_id].ground_to_image(p_true)
            self._one_to_one[strip_id] = ((status == 0) & (np.abs(l_t - line) < 1e-3)
                                          & (np.abs(p_t - pixel) < 1e-3))
        return self._one_to_one[strip_id]

    def error(self, strip_id: str, geometry: StripGeometry) -> TrueError:
        """The true error of ``geometry`` (an adjusted or measured orientation of the strip): in the image
        over the samples :meth:`one_to_one` keeps, on the ground over all."""
        line, pixel, p_true = self.samples(strip_id)
        l_m, p_m, status = geometry.nearest_sighting(p_true, line, pixel)
        ok_img = (((status & ~MULTIPLE) == 0) & np.isfinite(l_m) & np.isfinite(p_m)
                  & self.one_to_one(strip_id))
        dl, dp = (l_m - line)[ok_img], (p_m - pixel)[ok_img]
        p_adj, st = geometry.image_to_ground(line, pixel, self.terrain)
        ok_gnd = (st == 0) & np.isfinite(p_adj).all(axis=1)
        d = np.hypot(*(p_adj[ok_gnd, :2] - p_true[ok_gnd, :2]).T)
        def rms(v):
            return float(np.sqrt(np.mean(v**2))) if v.size else float("nan")
        return TrueError(int(ok_img.sum()), rms(dl), rms(dp), rms(d), float(d.max()) if d.size else float("nan"))


__all__ = ["TrueError", "Truth"]
