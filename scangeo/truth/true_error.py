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
more than once, the sighting nearest the sample counts (:func:`nearest_sighting`).
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field

import numpy as np

from scangeo.dtm import DTM
from scangeo.errors import ProjectFileError
from scangeo.io.project import Project
from scangeo.sensors.kernels import OK, OUTSIDE_SWATH
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
            boresight = np.radians(np.asarray(info["true_boresight_deg"], float))
        except (OSError, ValueError, KeyError) as exc:
            raise ProjectFileError(f"{info_file}: expected true_boresight_deg ({exc})") from exc
        frame = project.map_frame.frame
        mount = project.sensor.mounting
        mounting = Mounting(mount.lever_arm_B, boresight, mount.time_offset)
        geometries = {}
        for s in project.strips:
            path = folder / f"trajectory_{s.id}.csv"
            if not path.exists():
                raise ProjectFileError(f"{path}: the true trajectory of strip {s.id} is missing")
            traj = read_trajectory(path, crs=project.trajectory_crs or project.crs).to_project(frame)
            spacing = float(np.median(np.diff(traj.time)))  # one knot per sample: the truth as simulated
            spline = OrientationSpline.from_trajectory(traj, spacing)
            geometries[s.id] = project.geometry(s.id, spline=spline, mounting=mounting)
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
        l_m, p_m, status = nearest_sighting(geometry, p_true, line, pixel)
        ok_img = (((status & ~MULTIPLE) == 0) & np.isfinite(l_m) & np.isfinite(p_m)
                  & self.one_to_one(strip_id))
        dl, dp = (l_m - line)[ok_img], (p_m - pixel)[ok_img]
        p_adj, st = geometry.image_to_ground(line, pixel, self.terrain)
        ok_gnd = (st == 0) & np.isfinite(p_adj).all(axis=1)
        d = np.hypot(*(p_adj[ok_gnd, :2] - p_true[ok_gnd, :2]).T)
        def rms(v):
            return float(np.sqrt(np.mean(v**2))) if v.size else float("nan")
        return TrueError(int(ok_img.sum()), rms(dl), rms(dp), rms(d), float(d.max()) if d.size else float("nan"))


#: lines searched either side of a sample for its own sighting, and the step of that search (lines)
SIGHTING_WINDOW, SIGHTING_STEP = 64, 0.25


def _scan_condition(geometry: StripGeometry, p_P: np.ndarray, line: np.ndarray, pixel: np.ndarray):
    """The along-track condition ``g = v_x / v_z - tan(along(pixel))`` of points ``p_P`` (n, 3) at lines
    ``line`` (n, k), with the pixel their direction gives there (two passes: a whiskbroom pixel's time
    depends on the pixel); returns (g, pixel), both (n, k)."""
    n, k = line.shape
    P = np.repeat(p_P, k, axis=0)
    px = np.repeat(pixel, k) if np.ndim(pixel) == 1 else pixel.ravel()
    for _ in range(2):
        p_S, R = geometry.pose(geometry.time_of(line.ravel(), px))
        v = np.einsum("nji,nj->ni", R, P - p_S)
        px = geometry.sensor.pixel_of(v)
    g = v[:, 0] / v[:, 2] - np.tan(geometry.sensor.along_angle(px))
    return g.reshape(n, k), px.reshape(n, k)


def _nearest_root(geometry: StripGeometry, P: np.ndarray, px0: np.ndarray, centre: np.ndarray, half: float,
                  step: float) -> np.ndarray:
    """The line of the sighting of each point ``P`` nearest to ``centre`` within ``half`` lines of it (NaN
    where none): the sign changes of the scan-plane condition over lines ``step`` apart, refined by
    bisection, and the tangent sightings (the scan line turns back just there: a local minimum of ``|g|``
    that reaches zero), refined by golden section."""
    grid = centre[:, None] + np.arange(-half, half + step / 2, step)[None, :]

    def cond(at):
        return _scan_condition(geometry, P, at[:, None], px0)[0][:, 0]

    g, _ = _scan_condition(geometry, P, grid, px0)
    ok = np.isfinite(g)
    dist = np.abs(grid - centre[:, None])
    rows = np.arange(len(P))
    change = ok[:, :-1] & ok[:, 1:] & (np.sign(g[:, :-1]) != np.sign(g[:, 1:]))
    k = np.argmin(np.where(change, np.minimum(dist[:, :-1], dist[:, 1:]), np.inf), axis=1)
    lo, hi, g_lo = grid[rows, k], grid[rows, k + 1], g[rows, k]
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        g_m = cond(mid)
        left = np.sign(g_m) == np.sign(g_lo)
        lo, g_lo, hi = np.where(left, mid, lo), np.where(left, g_m, g_lo), np.where(left, hi, mid)
    root = np.where(change.any(axis=1), 0.5 * (lo + hi), np.nan)
    a = np.abs(np.where(ok, g, np.inf))
    is_min = np.zeros_like(ok)
    is_min[:, 1:-1] = (a[:, 1:-1] <= a[:, :-2]) & (a[:, 1:-1] <= a[:, 2:]) & ok[:, 1:-1]
    k = np.clip(np.argmin(np.where(is_min, dist, np.inf), axis=1), 1, grid.shape[1] - 2)
    lo, hi = grid[rows, k - 1], grid[rows, k + 1]
    for _ in range(60):
        c, d = hi - 0.618034 * (hi - lo), lo + 0.618034 * (hi - lo)
        keep_left = np.abs(cond(c)) < np.abs(cond(d))
        lo, hi = np.where(keep_left, lo, c), np.where(keep_left, d, hi)
    touch = 0.5 * (lo + hi)
    touch = np.where(is_min.any(axis=1) & (np.abs(cond(touch)) < 1e-9), touch, np.nan)
    return np.where(np.isnan(root) | (np.abs(touch - centre) < np.abs(root - centre)), touch, root)


def nearest_sighting(geometry: StripGeometry, p_P: np.ndarray, line: np.ndarray, pixel: np.ndarray):
    """(line, pixel, status) of project-frame points ``p_P`` in ``geometry``: of a point seen more than
    once, the sighting nearest to its true image position ``(line, pixel)``.

    A rotating mirror's scan lines overlap at the swath's edges when the pitch rate runs against the
    flight (over-scanning): a ground point there is seen by two or three scans, in the true orientation
    as in an adjusted one. ``ground_to_image`` keeps the first sighting, which can be scans away from the
    sample's own line (vienna2000 seed 37: 20 lines at one edge sample of 780; the truth itself put
    that sample 17 lines from its own line). An orientation's error there is the displacement of the
    sighting that stands for the sample's. For the points seen more than once, every sighting within
    :data:`SIGHTING_WINDOW` lines of the sample is found (the sign changes of the scan-plane condition
    over lines :data:`SIGHTING_STEP` apart, refined by bisection, and the tangent ones where the scan
    line turns back, local minima of ``|g|`` that reach zero) and the nearest kept. One just outside the
    swath keeps that status (the sample is then left out, like any other the orientation moves out of
    the swath).
    """
    l_m, p_m, status = geometry.ground_to_image(p_P)
    again = np.flatnonzero((status & MULTIPLE) != 0)
    if not again.size:
        return l_m, p_m, status
    best = np.full(len(again), np.nan)
    for half, step in ((SIGHTING_WINDOW, SIGHTING_STEP), (1.0, SIGHTING_STEP / 32)):  # then finely near the sample
        m = _nearest_root(geometry, p_P[again], pixel[again], line[again], half, step)
        best = np.where(np.isnan(best) | (np.abs(m - line[again]) < np.abs(best - line[again])), m, best)
    found = np.isfinite(best)
    pts, m = again[found], best[found]
    px = _scan_condition(geometry, p_P[pts], m[:, None], pixel[pts])[1][:, 0]
    inside = (px >= -0.5) & (px <= geometry.sensor.pixels - 0.5) & (m >= -0.5) & (m <= geometry.n_lines - 0.5)
    l_m[pts], p_m[pts] = m, px
    status[pts] = np.where(inside, OK, OUTSIDE_SWATH) | MULTIPLE
    return l_m, p_m, status


__all__ = ["SIGHTING_STEP", "SIGHTING_WINDOW", "TrueError", "Truth", "nearest_sighting"]
