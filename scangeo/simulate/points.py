"""Points of a simulated block and their image measurements.

Kinds and id prefixes (the variants select roles by these; see docs/simulate.md):

* ``E``: control points in bands at both ends of the block (role ``control``);
* ``B``: points in bands across the block at the problem strip's break epochs (role ``check`` in
  ground.csv; the 4-band variants make them control);
* ``K``: check points spread over every strip (role ``check``);
* ``H``: height-only points (role ``height``);
* ``T``: tie points along the overlaps of neighbouring strips (not in ground.csv).

All points lie on open ground (fields, tracks, roads, pavement: no water, roofs or trees), so
every tie point may carry a DTM height. A point is measured in every strip whose image holds it
(at least ``edge_margin_px`` from the image border): the true (line, pixel) from the true
trajectory by ground-to-image, plus Gaussian noise of ``measurement_sigma_px`` in both, plus, for
the chosen blunders, an offset of a size drawn in ``blunder_px`` in a random direction.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from scangeo.frames import MapFrame
from scangeo.sensors import StripGeometry
from scangeo.simulate.config import PointsConfig
from scangeo.simulate.flight import FlightPlan
from scangeo.simulate.scene import OPEN_GROUND
from scangeo.simulate.terrain import Terrain

ROLE_OF_KIND = {"E": "control", "B": "check", "K": "check", "H": "height", "T": "tie"}
#: the kinds a strip without control does not measure (the break-band points are control in the 4-band variants)
CONTROL_KINDS = ("E", "B", "H")


@dataclass(frozen=True)
class PointSet:
    """Points (true map coordinates) and their measurements.

    ``id``, ``kind`` (n,) str; ``x, y, z`` (n,) true map coordinates (z orthometric, m); ``p_P`` (n, 3).
    Measurements (m,): ``point`` (index into the points), ``strip`` (index into the strips),
    ``line_true, pixel_true``, ``line, pixel`` (as measured), ``blunder`` (bool).
    """

    id: np.ndarray
    kind: np.ndarray
    x: np.ndarray
    y: np.ndarray
    z: np.ndarray
    p_P: np.ndarray
    land_class: np.ndarray
    m_point: np.ndarray
    m_strip: np.ndarray
    line_true: np.ndarray
    pixel_true: np.ndarray
    line: np.ndarray
    pixel: np.ndarray
    blunder: np.ndarray


class RecentStrips:
    """The strips' geometries, of which only the last ``keep`` used hold their ground -> image
    tables (about 5 MB per 7,000-line strip: held for every strip of a 96-strip block they were
    0.5 GB); an older strip's are released and rebuilt when it is used again (tens of ms). The
    placement visits the strips in order, phase by phase, so each strip's tables are built once
    per phase."""

    def __init__(self, geometries: list[StripGeometry], keep: int = 2) -> None:
        self.geometries = geometries
        self.keep = keep
        self.recent: list[int] = []

    def __getitem__(self, k: int) -> StripGeometry:
        if k in self.recent:
            self.recent.remove(k)
        self.recent.append(k)
        while len(self.recent) > self.keep:
            self.geometries[self.recent.pop(0)].release_tables()
        return self.geometries[k]

    def release(self) -> None:
        for k in self.recent:
            self.geometries[k].release_tables()
        self.recent.clear()


class _Placer:
    """Draws candidate points in map rectangles and keeps those visible and on open ground."""

    def __init__(self, geometries: RecentStrips, plan: FlightPlan, map_frame: MapFrame, terrain: Terrain, scene,
                 margin_px: float, rng: np.random.Generator) -> None:
        self.geometries = geometries
        self.plan = plan
        self.map_frame = map_frame
        self.terrain = terrain
        self.scene = scene
        self.margin = margin_px
        self.rng = rng

    def visible(self, x, y, strips) -> tuple[np.ndarray, np.ndarray]:
        """(mask of points visible in all given strips, true ground coordinates p_P)."""
        z = self.terrain.height(x, y)
        p_P = self.map_frame.map_to_project(x, y, z)
        ok = np.isfinite(z) & np.isin(self.scene.classes(x, y), OPEN_GROUND)
        for k in strips:
            g = self.geometries[k]
            line, pixel, status = g.ground_to_image(p_P)
            ok &= (status == 0) & (line >= self.margin) & (line <= g.n_lines - 1 - self.margin)
            ok &= (pixel >= self.margin) & (pixel <= g.sensor.pixels - 1 - self.margin)
        return ok, p_P

    def draw(self, count: int, xr, yr, strips, tries: int = 16, rounds: int = 20) -> tuple[np.ndarray, np.ndarray]:
        """``count`` map points (x, y) in the rectangle xr x yr visible in ``strips``, one per equal
        slice of the y range (so they spread along the strips); slices without a visible open-ground
        candidate after ``rounds`` rounds stay empty."""
        if count <= 0:
            return np.zeros(0), np.zeros(0)
        edges = np.linspace(yr[0], yr[1], count + 1)
        xs, ys = np.full(count, np.nan), np.full(count, np.nan)
        for _round in range(rounds):
            todo = np.flatnonzero(np.isnan(xs))
            if todo.size == 0:
                break
            cx = self.rng.uniform(xr[0], xr[1], (todo.size, tries))
            cy = self.rng.uniform(edges[todo][:, None], edges[todo + 1][:, None], (todo.size, tries))
            ok, _ = self.visible(cx.ravel(), cy.ravel(), strips)
            ok = ok.reshape(todo.size, tries)
            found = ok.any(axis=1)
            first = ok.argmax(axis=1)
            rows = np.flatnonzero(found)
            xs[todo[rows]] = cx[rows, first[rows]]
            ys[todo[rows]] = cy[rows, first[rows]]
        keep = ~np.isnan(xs)
        return xs[keep], ys[keep]


def _line_to_y(plan: FlightPlan, strip_index: int, line: float) -> float:
    s = plan.strips[strip_index]
    return s.y_start + s.direction * line * plan.ground_speed_mps / plan.line_rate_hz


def place_points(config: PointsConfig, plan: FlightPlan, geometries: list[StripGeometry], map_frame: MapFrame,
                 terrain: Terrain, scene, rng: np.random.Generator, problem_strip: int = 0,
                 breaks_lines: tuple = (), control_lines: tuple[int, ...] = (), sensor_ties: int = 0,
                 line_strips: list[list[int]] | None = None) -> tuple[list[str], list[str], np.ndarray, np.ndarray]:
    """Ids, kinds and true map x, y of all points of the block.

    ``geometries`` are the flight lines' strips of the sensor the flight was planned for (one per plan
    strip); ``control_lines`` the flight lines (0-based) in whose zones the control points (E, B, H) are placed
    (empty: all). A platform adds ``sensor_ties`` tie points in each flight line's own zone, visible in every
    strip of it: ``line_strips[k]`` indexes the flight line's strips in ``geometries`` (which then holds the
    other sensors' strips after the planned sensor's)."""
    recent = RecentStrips(geometries, keep=max([2, *(len(s) for s in line_strips or [])]))
    placer = _Placer(recent, plan, map_frame, terrain, scene, config.edge_margin_px, rng)
    n = len(plan.strips)
    half = plan.spacing_m / 2.0
    swath_half = plan.swath_m / 2.0
    y_lo = min(plan.strips[0].y_start, plan.strips[0].y_end)
    y_hi = max(plan.strips[0].y_start, plan.strips[0].y_end)
    band = min(config.control_band_lines * plan.ground_speed_mps / plan.line_rate_hz, (y_hi - y_lo) / 4.0)

    def own_zone(k):
        left = plan.strips[k].x - (half if k > 0 else swath_half)
        right = plan.strips[k].x + (half if k < n - 1 else swath_half)
        return left, right

    controlled = [k for k in range(n) if not control_lines or k in control_lines]
    groups: list[tuple[str, np.ndarray, np.ndarray]] = []
    for k in controlled:
        xr = own_zone(k)
        for yr in ((y_lo, y_lo + band), (y_hi - band, y_hi)):
            groups.append(("E", *placer.draw(config.control_per_band_per_strip, xr, yr, [k])))
    if problem_strip and breaks_lines:
        half_band = config.break_band_lines / 2.0 * plan.ground_speed_mps / plan.line_rate_hz
        for line in breaks_lines:
            yb = _line_to_y(plan, problem_strip - 1, line)
            for k in controlled:
                groups.append(("B", *placer.draw(config.break_points_per_band_per_strip, own_zone(k),
                                                 (yb - half_band, yb + half_band), [k])))
    for k in range(n):
        groups.append(("K", *placer.draw(config.check_per_strip, own_zone(k), (y_lo + band, y_hi - band), [k])))
        groups.append(("H", *placer.draw(config.height_per_strip if k in controlled else 0, own_zone(k),
                                         (y_lo + band, y_hi - band), [k])))
    for k in range(n - 1):
        centre = 0.5 * (plan.strips[k].x + plan.strips[k + 1].x)
        overlap = plan.swath_m - plan.spacing_m
        xr = (centre - 0.4 * overlap, centre + 0.4 * overlap)
        groups.append(("T", *placer.draw(config.tie_per_overlap, xr, (y_lo, y_hi), [k, k + 1])))
    for k in range(n if sensor_ties and line_strips else 0):
        groups.append(("T", *placer.draw(sensor_ties, own_zone(k), (y_lo, y_hi), line_strips[k])))  # type: ignore[index]
    recent.release()

    ids, kinds, xs, ys = [], [], [], []
    counters: dict[str, int] = {}
    for kind, gx, gy in groups:
        for x, y in zip(gx, gy):
            counters[kind] = counters.get(kind, 0) + 1
            ids.append(f"{kind}{counters[kind]:03d}")
            kinds.append(kind)
            xs.append(x)
            ys.append(y)
    return ids, kinds, np.array(xs), np.array(ys)


def measure_points(ids, kinds, x, y, geometries: list[StripGeometry], map_frame: MapFrame, terrain: Terrain,
                   scene, config: PointsConfig, rng: np.random.Generator,
                   measures_control: list[bool] | None = None) -> PointSet:
    """True ground points and their (noisy, possibly blundered) measurements in every strip; a strip whose
    ``measures_control`` is False (a sensor or flight line without control) measures no control point (E, B,
    H), only the check and tie points it sees."""
    control = np.isin(np.asarray(kinds), list(CONTROL_KINDS))
    z = terrain.height(x, y)
    p_P = map_frame.map_to_project(x, y, z)
    point_parts: list[np.ndarray] = []
    strip_parts: list[np.ndarray] = []
    lt: list[np.ndarray] = []
    pt: list[np.ndarray] = []
    margin = config.edge_margin_px
    for k, g in enumerate(geometries):
        line, pixel, status = g.ground_to_image(p_P)
        g.release_tables()  # each strip is used once here; a 96-strip block held 0.5 GB of them
        ok = ((status == 0) & (line >= margin) & (line <= g.n_lines - 1 - margin)
              & (pixel >= margin) & (pixel <= g.sensor.pixels - 1 - margin))
        if measures_control is not None and not measures_control[k]:
            ok &= ~control
        idx = np.flatnonzero(ok)
        point_parts.append(idx)
        strip_parts.append(np.full(idx.size, k))
        lt.append(line[idx])
        pt.append(pixel[idx])
    m_point = np.concatenate(point_parts)
    m_strip = np.concatenate(strip_parts)
    order = np.lexsort((m_strip, m_point))
    m_point, m_strip = m_point[order], m_strip[order]
    line_true, pixel_true = np.concatenate(lt)[order], np.concatenate(pt)[order]
    sigma = config.measurement_sigma_px
    line = line_true + rng.standard_normal(line_true.size) * sigma
    pixel = pixel_true + rng.standard_normal(pixel_true.size) * sigma
    blunder = np.zeros(line.size, dtype=bool)
    if config.blunders:
        chosen = rng.choice(line.size, size=min(config.blunders, line.size), replace=False)
        size = rng.uniform(config.blunder_px[0], config.blunder_px[1], chosen.size)
        angle = rng.uniform(0, 2 * np.pi, chosen.size)
        dl, dp = size * np.sin(angle), size * np.cos(angle)
        n_lines = np.array([g.n_lines for g in geometries])[m_strip[chosen]]
        n_pix = np.array([g.sensor.pixels for g in geometries])[m_strip[chosen]]
        dl = np.where((line[chosen] + dl < 0) | (line[chosen] + dl > n_lines - 1), -dl, dl)  # stay inside
        dp = np.where((pixel[chosen] + dp < 0) | (pixel[chosen] + dp > n_pix - 1), -dp, dp)
        line[chosen] += dl
        pixel[chosen] += dp
        blunder[chosen] = True
    return PointSet(np.asarray(ids), np.asarray(kinds), np.asarray(x), np.asarray(y), z, p_P,
                    scene.classes(x, y), m_point, m_strip, line_true, pixel_true, line, pixel, blunder)
