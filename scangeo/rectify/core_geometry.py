"""The rectifier's view of a strip, on the geometry core (sensor model, spline, DTM, map frame).

:class:`CoreStripGeometry` implements :class:`scangeo.rectify.refined_map.RefinableStrip`: it turns
map coordinates with orthometric heights into project-frame points (``MapFrame.map_to_project``),
asks ``scangeo.sensors.StripGeometry.ground_to_image`` for (line, pixel), and the reverse through
DTM ray casting. The map -> project conversion of the many points of an inverse map goes through a
local polynomial (``scangeo.localmap``, fitted once over the DTM's extent and height range, error
under 0.2 mm) instead of pyproj; points outside its box, or a DTM too large for one polynomial,
take the exact conversion. Points the core reports as not seen (outside the swath, before or after the
strip, no convergence) come back as NaN; over-scanned points keep their first time.
"""
from __future__ import annotations

import copy
import weakref

import numba
import numpy as np

from scangeo.dtm import DTM
from scangeo.errors import GeometryError, ScangeoError
from scangeo.frames import MapFrame
from scangeo.localmap import LocalPolynomialMap, poly_eval_point
from scangeo.sensors import StripGeometry as CoreGeometry
from scangeo.sensors.kernels import MULTIPLE, OK
from scangeo.threading_layer import choose_threading_layer

#: points per call into the core (bounds the temporary arrays of the conversions)
CHUNK = 262_144
#: the earth's smallest radius of curvature, metres (a bound on the tilt of the vertical)
EARTH_RADIUS = 6_335_000.0
#: height margin of the local map's box beyond the DTM's range, metres (levels, check points)
HEIGHT_MARGIN = 100.0


@numba.njit(parallel=True, cache=True)
def _poly_eval(coef, exps, centre, scale, box, x, y, H, out, inside):
    """The local polynomial at map points (x, y, H) inside its box; ``inside`` says which."""
    n = x.shape[0]
    chunks = min(n, 64)
    size = (n + chunks - 1) // max(chunks, 1)
    for c in numba.prange(chunks):
        work = np.empty(3 * (exps.max() + 1))
        res = np.empty(3)
        for k in range(c * size, min(n, (c + 1) * size)):
            ok = (box[0, 0] <= x[k] <= box[0, 1]) and (box[1, 0] <= y[k] <= box[1, 1]) and (
                box[2, 0] <= H[k] <= box[2, 1])
            inside[k] = ok
            if not ok:
                continue
            poly_eval_point(coef, exps, centre, scale, x[k], y[k], H[k], res, work)
            out[k, 0], out[k, 1], out[k, 2] = res[0], res[1], res[2]


def _apply(local: LocalPolynomialMap, x: np.ndarray, y: np.ndarray, H: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    x, y, H = (np.ascontiguousarray(v, dtype=float).ravel() for v in (x, y, H))
    out = np.empty((x.size, 3))
    inside = np.empty(x.size, dtype=np.bool_)
    choose_threading_layer()
    _poly_eval(local.coef, local.exps, local.centre, local.scale, np.ascontiguousarray(local.box, dtype=float),
               x, y, H, out, inside)
    return out, inside


#: the local map of each DTM in use, fitted once for all the strips on it (the fit grows with the
#: DTM's extent: 0.24 s over 96 strips' DTM against 0.02 s over 24's, once per strip before)
_LOCAL_MAPS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _local_map_to_project(map_frame: MapFrame, dtm: DTM) -> LocalPolynomialMap | None:
    """A polynomial (x, y, H) -> p_P over the DTM's extent, or None if none is accurate enough."""
    cached = _LOCAL_MAPS.get(dtm)
    if cached is not None and cached[0] is map_frame:
        return cached[1]
    xmin, ymin, xmax, ymax = dtm.grid.bounds()
    box = [[xmin, xmax], [ymin, ymax], [dtm.h_min - HEIGHT_MARGIN, dtm.h_max + HEIGHT_MARGIN]]

    def exact(q: np.ndarray) -> np.ndarray:
        return map_frame.map_to_project(q[:, 0], q[:, 1], q[:, 2])

    try:
        local: LocalPolynomialMap | None = LocalPolynomialMap.fit(exact, box)
    except ScangeoError:
        local = None
    _LOCAL_MAPS[dtm] = (map_frame, local)
    return local


def _with_fixed_overscan_window(geometry: CoreGeometry, dtm: DTM) -> CoreGeometry:
    """A copy of the strip geometry whose over-scan search window is computed once, for the DTM's
    whole height range, instead of on every ``ground_to_image`` call.

    The core derives the window from the heights of the points of each call (about 4 ms on a
    10,000-line strip); rectification calls it some ten times per tile with points inside the
    DTM's range, for which the window of the whole range is a safe (never smaller) bound.
    """
    fixed = copy.copy(geometry)
    centre = np.array([[0.0, 0.0, dtm.h_min], [0.0, 0.0, dtm.h_max]])
    x, y, _ = dtm.map_frame.project_to_map(np.zeros((1, 3)))
    lo = dtm.map_frame.map_to_project(x, y, np.array([dtm.h_min]))[0]
    hi = dtm.map_frame.map_to_project(x, y, np.array([dtm.h_max]))[0]
    centre[0], centre[1] = lo, hi
    window = geometry.overscan_window(centre)
    fixed.overscan_window = lambda p_P: window  # type: ignore[method-assign]  # shadows the method on the copy
    return fixed


class CoreStripGeometry:
    """A strip of the geometry core seen through map coordinates.

    Parameters
    ----------
    geometry : the strip geometry (sensor, orientation spline, timing, mounting).
    dtm : the DTM (map CRS, orthometric heights) the strip is rectified onto.
    """

    def __init__(self, geometry: CoreGeometry, dtm: DTM) -> None:
        self.core = _with_fixed_overscan_window(geometry, dtm)
        self.dtm = dtm
        self.map_frame: MapFrame = dtm.map_frame
        self.lines = int(geometry.n_lines)
        self.pixels = int(geometry.sensor.pixels)
        self.crs = self.map_frame.crs.to_wkt()
        self._to_project = _local_map_to_project(self.map_frame, dtm)
        #: the strip never over-scans: a ground point has one solution (``ground_to_image_near``)
        self.monotonic = self.core.overscan_window(np.zeros((1, 3))) == 0

    def map_to_project(self, x: np.ndarray, y: np.ndarray, H: np.ndarray) -> np.ndarray:
        """p_P (n, 3) of map points (x, y map units, H orthometric metres)."""
        if self._to_project is None:
            return self.map_frame.map_to_project(x, y, H)
        p_P, inside = _apply(self._to_project, x, y, H)
        if not inside.all():
            out = ~inside
            x, y, H = (np.asarray(v, dtype=float).ravel() for v in (x, y, H))
            p_P[out] = self.map_frame.map_to_project(x[out], y[out], H[out])
        return p_P

    def ground_to_image(self, x, y, H) -> tuple[np.ndarray, np.ndarray]:
        x, y, H = (np.asarray(v, dtype=float).ravel() for v in np.broadcast_arrays(x, y, H))
        line = np.full(x.shape, np.nan)
        pixel = np.full(x.shape, np.nan)
        for s in range(0, x.size, CHUNK):
            e = min(s + CHUNK, x.size)
            ok = np.isfinite(x[s:e]) & np.isfinite(y[s:e]) & np.isfinite(H[s:e])
            if not ok.any():
                continue
            p_P = self.map_to_project(x[s:e][ok], y[s:e][ok], H[s:e][ok])
            ln, p, status = self.core.ground_to_image(p_P)
            seen = (status & ~MULTIPLE) == OK
            idx = np.flatnonzero(ok)
            line[s + idx] = np.where(seen, ln, np.nan)
            pixel[s + idx] = np.where(seen, p, np.nan)
        return line, pixel

    def ground_to_image_near(self, x, y, H, line0, pixel0, tol_line: float = 1e-2, max_step_lines: float = 64.0,
                             max_iter: int = 8):
        """(line, pixel, status, evaluations) by Newton from the guesses (line0, pixel0), see
        ``scangeo.sensors.StripGeometry.ground_to_image_near``; line and pixel NaN where the status
        is not 0 (4: not converged, solve those with ``ground_to_image``)."""
        x, y, H = (np.asarray(v, dtype=float).ravel() for v in np.broadcast_arrays(x, y, H))
        return self.project_to_image_near(self.map_to_project(x, y, H), line0, pixel0, tol_line, max_step_lines,
                                          max_iter)

    def project_to_image_near(self, p_P, line0, pixel0, tol_line: float = 1e-2, max_step_lines: float = 64.0,
                              max_iter: int = 8):
        """``ground_to_image_near`` for project-frame points (n, 3)."""
        if not self.monotonic:
            raise GeometryError("ground_to_image_near: the strip over-scans; use ground_to_image")
        line, pixel, status, steps = self.core.ground_to_image_near(
            p_P, np.asarray(line0, dtype=float).ravel(), np.asarray(pixel0, dtype=float).ravel(), tol_line,
            max_step_lines, max_iter)
        seen = status == OK
        line[~seen] = np.nan
        pixel[~seen] = np.nan
        return line, pixel, status, steps

    def largest_view_zenith(self) -> float:
        """The largest angle between a ray and the local vertical over the strip, radians: the rays
        of the first and last pixel of every line (at a fixed attitude a scan line's view zenith is
        largest at one of its ends), against the project frame's vertical, plus the tilt of the
        local vertical from it at the sensor (its distance from the frame's origin over the earth's
        radius)."""
        lines = np.repeat(np.arange(self.lines, dtype=float), 2)
        pixels = np.tile([0.0, self.pixels - 1.0], self.lines)
        origin, direction = self.core.rays(lines, pixels)
        zenith = np.arccos(np.clip(-direction[:, 2], -1.0, 1.0)) + np.hypot(origin[:, 0], origin[:, 1]) / EARTH_RADIUS
        return float(zenith.max())

    def height_on_lattice(self, xs, ys) -> np.ndarray:
        """DTM heights (len(ys), len(xs)) on the lattice of map points (xs[j], ys[i])."""
        return self.dtm.height_on_lattice(xs, ys)

    def image_to_ground(self, line, pixel) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        line, pixel = (np.asarray(v, dtype=float).ravel() for v in np.broadcast_arrays(line, pixel))
        out = [np.full(line.shape, np.nan) for _ in range(3)]
        for s in range(0, line.size, CHUNK):
            e = min(s + CHUNK, line.size)
            p_P, status = self.core.image_to_ground(line[s:e], pixel[s:e], self.dtm)
            ok = (status & ~MULTIPLE) == OK
            if ok.any():
                x, y, H = self.map_frame.project_to_map(p_P[ok])
                for k, v in enumerate((x, y, H)):
                    out[k][s:e][ok] = v
        return out[0], out[1], out[2]

    def sensor_position(self, line) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        line = np.asarray(line, dtype=float).ravel()
        centre = np.full(line.shape, (self.pixels - 1) / 2.0)
        p_S, _ = self.core.pose(self.core.time_of(line, centre))
        x, y, H = self.map_frame.project_to_map(p_S)
        return np.asarray(x), np.asarray(y), np.asarray(H)

    def height(self, x, y) -> np.ndarray:
        return self.dtm.height_at_map(x, y)

    def scan_angle(self, pixel) -> np.ndarray:
        look = self.core.sensor.look_S(np.asarray(pixel, dtype=float))
        return np.arctan2(look[..., 1], look[..., 2])

    def time(self, line, pixel) -> np.ndarray:
        return self.core.time_of(np.asarray(line, dtype=float), np.asarray(pixel, dtype=float))
