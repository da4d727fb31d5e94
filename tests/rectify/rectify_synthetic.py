"""An analytic strip for the rectification tests: exact ground <-> image, known texture.

A whiskbroom scanner flies due north along ``x = xs`` at constant height ``Zs`` and speed, with a
roll that may oscillate in time and no pitch or yaw: the scan plane of line ``l`` is ``y = y(l)``,
so ground -> image is exact in closed form (line from y, pixel from the across-track angle minus
the roll at that line's time). Image -> ground casts the ray onto the bilinear DTM (first hit, so
occluded ground is never seen). The ground carries a known smooth texture ``f(x, y)`` with
analytic gradient; a strip image is ``f`` at the ground points of its pixels.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import rasterio
from affine import Affine
from rasterio.errors import NotGeoreferencedWarning

from scangeo.grid import RasterGrid

CRS = "EPSG:32631"


def make_dtm(fn, xmin, xmax, ymin, ymax, res=2.0) -> RasterGrid:
    cols = int(np.ceil((xmax - xmin) / res))
    rows = int(np.ceil((ymax - ymin) / res))
    x = xmin + (np.arange(cols) + 0.5) * res
    y = ymax - (np.arange(rows) + 0.5) * res
    X, Y = np.meshgrid(x, y)
    return RasterGrid(fn(X, Y).astype(float), Affine(res, 0, xmin, 0, -res, ymax), CRS)


@dataclass
class AnalyticStrip:
    """Analytic whiskbroom strip (see module doc). Angles in radians, lengths in metres."""

    dtm: RasterGrid
    lines: int = 300
    pixels: int = 200
    xs: float = 500_000.0
    y0: float = 5_000_000.0
    Zs: float = 900.0
    speed: float = 62.5
    line_rate: float = 25.0
    step: float = 0.0025
    roll_amp: float = 0.0
    roll_period: float = 2.0
    t0: float = 1000.0
    nan_outside: bool = False
    crs: str = CRS

    @property
    def dy(self) -> float:
        return self.speed / self.line_rate

    def roll(self, line):
        return self.roll_amp * np.sin(2 * np.pi * np.asarray(line, float) / self.line_rate / self.roll_period)

    def scan_angle(self, pixel):
        return (np.asarray(pixel, float) - (self.pixels - 1) / 2.0) * self.step

    def time(self, line, pixel):
        return self.t0 + np.asarray(line, float) / self.line_rate + 0 * np.asarray(pixel, float)

    def height(self, x, y):
        return self.dtm.sample(np.asarray(x, float), np.asarray(y, float))

    def sensor_position(self, line):
        line = np.asarray(line, float)
        return np.full(line.shape, self.xs), self.y0 + line * self.dy, np.full(line.shape, self.Zs)

    def ground_to_image(self, x, y, H):
        x, y, H = (np.asarray(v, float) for v in (x, y, H))
        line = (y - self.y0) / self.dy
        angle = np.arctan2(x - self.xs, self.Zs - H)
        pixel = (angle - self.roll(line)) / self.step + (self.pixels - 1) / 2.0
        if self.nan_outside:
            bad = (line < -1) | (line > self.lines) | (pixel < -1) | (pixel > self.pixels)
            line = np.where(bad, np.nan, line)
            pixel = np.where(bad, np.nan, pixel)
        return line, pixel

    def image_to_ground(self, line, pixel):
        line, pixel = np.broadcast_arrays(np.asarray(line, float), np.asarray(pixel, float))
        shape = line.shape
        line, pixel = line.ravel(), pixel.ravel()
        y = self.y0 + line * self.dy
        tan = np.tan(self.scan_angle(pixel) + self.roll(line))
        hmin, hmax = np.nanmin(self.dtm.values), np.nanmax(self.dtm.values)
        # march in depth below the sensor from the highest to the lowest terrain
        d_lo = np.full(line.shape, self.Zs - hmax - 1.0)
        step = np.minimum(1.0, 0.5 / np.maximum(np.abs(tan), 1e-6))
        n = int(np.ceil((hmax - hmin + 2.0) / step.min())) + 1
        hit = np.full(line.shape, np.nan)
        found = np.zeros(line.shape, bool)
        d = d_lo.copy()
        for _ in range(n):
            d_next = d + step
            below = (self.Zs - d_next) <= self.height(self.xs + d_next * tan, y)
            new = below & ~found
            hit[new] = d[new]
            found |= new
            d = d_next
            if found.all():
                break
        # bisection on [hit, hit + step]
        a, b = hit.copy(), hit + step
        for _ in range(40):
            m = 0.5 * (a + b)
            below = (self.Zs - m) <= self.height(self.xs + m * tan, y)
            b = np.where(below, m, b)
            a = np.where(below, a, m)
        d = np.where(found, 0.5 * (a + b), np.nan)
        x = self.xs + d * tan
        return x.reshape(shape), y.reshape(shape), (self.Zs - d).reshape(shape)


@dataclass(frozen=True)
class Texture:
    """A sum of sinusoids on the ground: value and gradient at map points."""

    waves: tuple = (
        (300.0, 1 / 37.0, 1 / 53.0, 0.3),
        (250.0, -1 / 29.0, 1 / 41.0, 1.1),
        (200.0, 1 / 23.0, -1 / 61.0, 2.0),
        (150.0, 1 / 47.0, 1 / 19.0, 0.7),
    )
    mean: float = 1000.0

    def __call__(self, x, y):
        v = np.full(np.shape(x), self.mean)
        for a, kx, ky, ph in self.waves:
            v = v + a * np.sin(2 * np.pi * (kx * x + ky * y) + ph)
        return v

    def gradient(self, x, y):
        gx = np.zeros(np.shape(x))
        gy = np.zeros(np.shape(x))
        for a, kx, ky, ph in self.waves:
            c = a * 2 * np.pi * np.cos(2 * np.pi * (kx * x + ky * y) + ph)
            gx, gy = gx + c * kx, gy + c * ky
        return gx, gy


def render(strip: AnalyticStrip, texture: Texture, path, bands: int = 3, dtype="float32", nodata=None):
    """Write the strip image: band b holds ``texture + 100 b`` at the ground point of each pixel."""
    ll, pp = np.meshgrid(np.arange(strip.lines, dtype=float), np.arange(strip.pixels, dtype=float), indexing="ij")
    x, y, _ = strip.image_to_ground(ll, pp)
    base = texture(x, y)
    data = np.stack([base + 100 * b for b in range(bands)]).astype(dtype)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NotGeoreferencedWarning)
        with rasterio.open(
            path, "w", driver="GTiff", width=strip.pixels, height=strip.lines, count=bands, dtype=dtype,
            nodata=nodata,
        ) as dst:
            dst.write(data)
            for b in range(bands):
                dst.set_band_description(b + 1, f"channel {b + 1}")
                dst.update_tags(b + 1, wavelength=str(450.0 + 50 * b), wavelength_units="nm")
    return data


def flat(H=300.0):
    return lambda X, Y: np.full(X.shape, H)


def hills(X, Y):
    """Smooth rolling terrain, ~150 m relief."""
    return 300 + 80 * np.sin(X / 97.0) * np.cos(Y / 131.0) + 60 * np.cos((X + Y) / 211.0)


def estimate_shift(ortho, grid, texture, valid, window=32):
    """Least-squares shift (dx, dy) in cells of ``ortho`` against the texture, globally and per window.

    ``ortho(x) ~ f(x + d)``: d = (G^T G)^-1 G^T (ortho - f) with G the texture gradient.
    Returns (mean (2,), per-window array (n, 2)), in cells (x east, y north).
    """
    rows, cols = np.indices(ortho.shape)
    x, y = grid.x_of_col(cols), grid.y_of_row(rows)
    f = texture(x, y)
    gx, gy = texture.gradient(x, y)
    r = ortho - f

    def solve(m):
        G = np.stack([gx[m], gy[m]], 1)
        return np.linalg.solve(G.T @ G, G.T @ r[m]) / grid.resolution

    mean = solve(valid)
    per = []
    for r0 in range(0, ortho.shape[0] - window + 1, window):
        for c0 in range(0, ortho.shape[1] - window + 1, window):
            m = np.zeros_like(valid)
            m[r0:r0 + window, c0:c0 + window] = True
            m &= valid
            if m.sum() > window * window // 2:
                per.append(solve(m))
    return mean, np.array(per)
