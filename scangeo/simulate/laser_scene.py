"""A scene for simulated laser strips: flat, gently tilted ground with gable-roofed buildings whose
roof faces look north, south, east, west or diagonally (different expositions), in the project frame.

Buildings sit on a regular lattice (one building at most per lattice cell, jittered), so the height
of any point is found without a search: the lattice cell gives the only candidate building.
Returns are cast onto the surface by a fixed-point iteration on the height; returns that do not
converge (they graze a wall) are dropped as occluded.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


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

    @classmethod
    def random(
        cls,
        bounds: tuple[float, float, float, float],
        rng: np.random.Generator,
        spacing: float = 50.0,
        fill: float = 0.5,
        z0: float = 0.0,
        slope: tuple[float, float] = (0.005, -0.003),
    ) -> LaserScene:
        x0, y0, x1, y1 = bounds
        nx, ny = int(np.ceil((x1 - x0) / spacing)), int(np.ceil((y1 - y0) / spacing))
        take = rng.random((ny, nx)) < fill
        iy, ix = np.nonzero(take)
        n = ix.size
        half_l = rng.uniform(10.0, 15.0, n)
        half_w = rng.uniform(8.0, 11.0, n)
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
        return cls(z0, slope[0], slope[1], spacing, (x0, y0), (ny, nx), slot, b)

    def ground(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        return self.z0 + self.gx * x + self.gy * y

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
        z[on] += roof
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
        for _ in range(iterations):
            p = o + lam[:, None] * d
            z = self.height(p[:, 0], p[:, 1])
            lam = (z - o[:, 2]) / d[:, 2]
        p = o + lam[:, None] * d
        ok = np.abs(self.height(p[:, 0], p[:, 1]) - p[:, 2]) < tolerance
        return lam, ok
