"""A scene for simulated laser strips: gently tilted ground, optionally an alpine valley (:class:`Valley`:
a flat floor, planar sides rising some 2000 m to the ridges, ripples of every exposition on the sides),
with gable-roofed buildings whose roof faces look north, south, east, west or diagonally (different
expositions), in the project frame.

Buildings sit on a regular lattice (one building at most per lattice cell, jittered), so the height
of any point is found without a search: the lattice cell gives the only candidate building.
Returns are cast onto the surface by a fixed-point iteration on the height (first on the ground
alone, then with the buildings); returns that do not converge (they graze a wall) are dropped as
occluded. The iteration contracts where the slope times the tangent of the beam's off-nadir angle is
below 1 (a 50 deg slope seen 20 deg off nadir: 0.43).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def _softplus(x: np.ndarray, r: float) -> np.ndarray:
    return r * np.logaddexp(0.0, x / r)


@dataclass(frozen=True)
class Valley:
    """A valley along the project's y axis (heights in m above the project origin's level).

    Across the valley (``u``: distance from its meandering axis) the ground is flat on the floor
    (``|u| < floor_half_width``), rises with the side ``slope`` (tangent) and levels off at ``top``,
    the kinks rounded over ``rounding`` metres; ripples of ``ripple`` metres (zero on the floor and on
    the ridges) give the sides every exposition; the floor climbs ``floor_gradient`` along y.

    The curvature stays small on the scale of a patch (rounding 200 m: at most ``slope / 800`` per
    metre, a 12 m patch sags 1.6 cm at a 42 deg side; ripples of 2.4 km: 0.1 cm): a plane fitted to a
    strongly curved patch depends on where in its box a strip's returns fall, and with 60 m rounding
    and 1.2 km ripples (sags of 6 and 3 cm, accepted under the 5 cm plane sigma) such patches tied
    the strips with systematic errors (526 rejections and heading constants at 3-4 sigma on the
    montafon block).
    """

    floor: float
    top: float
    floor_half_width: float
    slope: float
    ripple: float = 0.0
    ripple_wavelength: float = 2400.0
    meander: float = 0.0
    meander_wavelength: float = 6000.0
    floor_gradient: float = 0.0
    rounding: float = 200.0

    def side(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """0 on the floor, 1 on the ridges."""
        u = np.abs(x - self.meander * np.sin(2.0 * np.pi * y / self.meander_wavelength))
        rise = self.top - self.floor
        run = rise / self.slope
        g = _softplus(u - self.floor_half_width, self.rounding) - _softplus(u - self.floor_half_width - run,
                                                                                self.rounding)
        return g / run

    def height(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        s = self.side(x, y)
        k = 2.0 * np.pi / self.ripple_wavelength
        ripple = self.ripple * 4.0 * s * (1.0 - s) * np.sin(k * x) * np.sin(0.7 * k * y)
        return self.floor + self.floor_gradient * y + (self.top - self.floor) * s + ripple


@dataclass
class Buildings:
    """Gable-roofed buildings: centre (x, y), ridge direction (rad from +x), half length along the
    ridge, half width across it, eave and ridge heights above the ground (m)."""

    x: np.ndarray
    y: np.ndarray
    azimuth: np.ndarray
    half_length: np.ndarray
    half_width: np.ndarray
    eave: np.ndarray
    ridge: np.ndarray

    @property
    def count(self) -> int:
        return int(self.x.size)


@dataclass
class LaserScene:
    """Ground ``z = z0 + gx x + gy y`` and buildings on a lattice of ``spacing`` over ``[x0, x1] x [y0, y1]``."""

    z0: float
    gx: float
    gy: float
    spacing: float
    origin: tuple[float, float]
    shape: tuple[int, int]
    slot: np.ndarray  # (ny, nx) building index of each lattice cell, -1 when empty
    buildings: Buildings
    valley: Valley | None = None  # relief; its buildings stand level on the ground at their centre
    base: np.ndarray | None = None  # (buildings,) ground height at each centre (with a valley)

    @classmethod
    def random(
        cls,
        bounds: tuple[float, float, float, float],
        rng: np.random.Generator,
        spacing: float = 50.0,
        fill: float = 0.5,
        z0: float = 0.0,
        slope: tuple[float, float] = (0.005, -0.003),
        valley: Valley | None = None,
        building_scale: float = 1.0,
        max_building_slope: float = 0.15,
    ) -> LaserScene:
        """Buildings on a jittered lattice; with a ``valley`` only where its ground is gentler than
        ``max_building_slope`` (villages on the floor and the terraces), level on their centre's ground."""
        x0, y0, x1, y1 = bounds
        nx, ny = int(np.ceil((x1 - x0) / spacing)), int(np.ceil((y1 - y0) / spacing))
        take = rng.random((ny, nx)) < fill
        if valley is not None:
            cx = x0 + (np.arange(nx) + 0.5) * spacing
            cy = y0 + (np.arange(ny) + 0.5) * spacing
            gx_, gy_ = np.meshgrid(cx, cy)
            h = 5.0
            grad = np.hypot(valley.height(gx_ + h, gy_) - valley.height(gx_ - h, gy_),
                            valley.height(gx_, gy_ + h) - valley.height(gx_, gy_ - h)) / (2 * h)
            take &= grad < max_building_slope
        iy, ix = np.nonzero(take)
        n = ix.size
        half_l = building_scale * rng.uniform(10.0, 15.0, n)
        half_w = building_scale * rng.uniform(8.0, 11.0, n)
        margin = 0.5 * spacing - np.hypot(half_l, half_w) - 1.0
        jitter = np.maximum(margin, 0.0)[:, None] * rng.uniform(-1, 1, (n, 2))
        azimuth = rng.choice(np.radians([0.0, 90.0, 45.0, 135.0, 20.0]), n)
        eave = rng.uniform(5.0, 9.0, n)
        pitch = np.radians(rng.uniform(25.0, 40.0, n))
        slot = np.full((ny, nx), -1, dtype=np.int64)
        slot[iy, ix] = np.arange(n)
        b = Buildings(
            x0 + (ix + 0.5) * spacing + jitter[:, 0],
            y0 + (iy + 0.5) * spacing + jitter[:, 1],
            azimuth,
            half_l,
            half_w,
            eave,
            eave + half_w * np.tan(pitch),
        )
        scene = cls(z0, slope[0], slope[1], spacing, (x0, y0), (ny, nx), slot, b, valley)
        if valley is not None:
            scene.base = scene.ground(b.x, b.y)
        return scene

    def ground(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        z = self.z0 + self.gx * x + self.gy * y
        return z if self.valley is None else z + self.valley.height(x, y)

    def slope_at(self, x: np.ndarray, y: np.ndarray, h: float = 5.0) -> np.ndarray:
        """Gradient magnitude of the ground (tangent of its slope)."""
        x, y = np.asarray(x, float), np.asarray(y, float)
        gx = self.ground(x + h, y) - self.ground(x - h, y)
        return np.hypot(gx, self.ground(x, y + h) - self.ground(x, y - h)) / (2 * h)

    def building_at(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Index of the building over each point (-1: none) and its coordinates along/across the ridge."""
        ix = np.floor((x - self.origin[0]) / self.spacing).astype(np.int64)
        iy = np.floor((y - self.origin[1]) / self.spacing).astype(np.int64)
        inside = (ix >= 0) & (iy >= 0) & (ix < self.shape[1]) & (iy < self.shape[0])
        k = np.full(x.shape, -1, dtype=np.int64)
        k[inside] = self.slot[iy[inside], ix[inside]]
        b = self.buildings
        kk = np.maximum(k, 0)
        dx, dy = x - b.x[kk], y - b.y[kk]
        c, s = np.cos(b.azimuth[kk]), np.sin(b.azimuth[kk])
        u, v = c * dx + s * dy, -s * dx + c * dy
        hit = (k >= 0) & (np.abs(u) <= b.half_length[kk]) & (np.abs(v) <= b.half_width[kk])
        return np.where(hit, k, -1), u, v

    def height(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Surface height (ground or roof) at (x, y)."""
        x, y = np.asarray(x, float), np.asarray(y, float)
        z = self.ground(x, y)
        k, _, v = self.building_at(x, y)
        on = k >= 0
        b = self.buildings
        kb = k[on]
        roof = b.ridge[kb] - (b.ridge[kb] - b.eave[kb]) * np.abs(v[on]) / b.half_width[kb]
        if self.base is None:
            z[on] += roof
        else:
            z[on] = self.base[kb] + roof
        return z

    def roof_face(self, k: int, side: int) -> tuple[np.ndarray, np.ndarray]:
        """Centre (x, y, z) and upward unit normal of one face (side +1 or -1) of building k."""
        b = self.buildings
        c, s = np.cos(b.azimuth[k]), np.sin(b.azimuth[k])
        v = 0.5 * side * b.half_width[k]
        x, y = b.x[k] - s * v, b.y[k] + c * v
        slope = (b.ridge[k] - b.eave[k]) / b.half_width[k]
        # z falls by `slope` per metre of |v|: gradient along the across direction (-s, c) * side
        grad = -slope * side * np.array([-s, c])
        n = np.array([-grad[0], -grad[1], 1.0])
        return np.array([x, y, float(self.height(np.array([x]), np.array([y]))[0])]), n / np.linalg.norm(n)

    def cast(
        self, origin: np.ndarray, direction: np.ndarray, iterations: int = 12, tolerance: float = 1e-4
    ) -> tuple[np.ndarray, np.ndarray]:
        """Ranges along unit rays (downward) to the surface, and which rays converged."""
        o, d = np.asarray(origin, float), np.asarray(direction, float)
        z = self.ground(o[:, 0], o[:, 1])
        lam = (z - o[:, 2]) / d[:, 2]
        for _ in range(0 if self.valley is None else 40):  # onto the relief first (ground alone)
            p = o + lam[:, None] * d
            lam = (self.ground(p[:, 0], p[:, 1]) - o[:, 2]) / d[:, 2]
        for _ in range(iterations):
            p = o + lam[:, None] * d
            z = self.height(p[:, 0], p[:, 1])
            lam = (z - o[:, 2]) / d[:, 2]
        p = o + lam[:, None] * d
        ok = np.abs(self.height(p[:, 0], p[:, 1]) - p[:, 2]) < tolerance
        return lam, ok
