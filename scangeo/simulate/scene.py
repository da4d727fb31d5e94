"""The simulated ground's appearance: 10 reflective bands and 1 thermal band at any map point.

Two scenes share one interface, ``values(x, y) -> (n, 11)`` in physical units (reflectance for
bands 1-10, brightness temperature in kelvin for band 11) and ``classes(x, y)``:

* ``LandcoverScene``: procedural land cover (fields with rows and farm tracks, roads, perimeter
  blocks with courtyards and parks, forest, a river and ponds), evaluated point by point from
  hash-based noise, so images, points and the truth orthoimage sample one and the same ground.
* ``TextureScene``: a real orthophoto (e.g. the Autzen RGB orthophoto) mirrored-tiled over the
  block, its RGB turned into the 11 bands by a simple spectral model (vegetation from the green
  excess, water from darkness).

Digital numbers: ``dn = reflectance * 10000`` for bands 1-10, ``dn = (T - 200 K) * 100`` for band 11.
"""
from __future__ import annotations

import math

import numba as nb
import numpy as np

from scangeo.errors import InputFileError
from scangeo.simulate.fields import fbm, fbm_at, hash01, noise_at
from scangeo.threading_layer import choose_threading_layer

#: Daedalus AADS 1268 channels: band name, lower and upper wavelength (micrometres).
BANDS = (
    ("ch1_blue", 0.42, 0.45), ("ch2_blue", 0.45, 0.52), ("ch3_green", 0.52, 0.60), ("ch4_orange", 0.605, 0.625),
    ("ch5_red", 0.63, 0.69), ("ch6_rededge", 0.695, 0.75), ("ch7_nir", 0.76, 0.90), ("ch8_nir", 0.91, 1.05),
    ("ch9_swir", 1.55, 1.75), ("ch10_swir", 2.08, 2.35), ("ch11_thermal", 8.5, 13.0),
)
N_BANDS = len(BANDS)
REFLECTANCE_GAIN = 10000.0
THERMAL_OFFSET_K = 200.0
THERMAL_GAIN = 100.0

#: Land-cover classes: reflectance in bands 1-10 and brightness temperature (K).
CLASSES = {
    "water": ([0.06, 0.06, 0.05, 0.04, 0.03, 0.025, 0.015, 0.01, 0.005, 0.003], 289.0),
    "asphalt": ([0.07, 0.08, 0.09, 0.10, 0.10, 0.11, 0.12, 0.13, 0.15, 0.14], 312.0),
    "concrete": ([0.22, 0.25, 0.28, 0.30, 0.31, 0.32, 0.33, 0.34, 0.35, 0.32], 306.0),
    "roof_tile": ([0.06, 0.07, 0.10, 0.18, 0.22, 0.27, 0.30, 0.32, 0.38, 0.35], 314.0),
    "roof_dark": ([0.08, 0.09, 0.10, 0.10, 0.10, 0.11, 0.11, 0.12, 0.12, 0.11], 318.0),
    "grass": ([0.04, 0.05, 0.10, 0.07, 0.05, 0.20, 0.45, 0.47, 0.25, 0.12], 297.0),
    "crop_green": ([0.03, 0.04, 0.09, 0.05, 0.04, 0.25, 0.55, 0.55, 0.22, 0.10], 295.0),
    "crop_ripe": ([0.08, 0.10, 0.16, 0.20, 0.22, 0.27, 0.32, 0.34, 0.38, 0.30], 303.0),
    "soil": ([0.08, 0.10, 0.14, 0.18, 0.20, 0.23, 0.26, 0.28, 0.33, 0.30], 308.0),
    "forest": ([0.02, 0.03, 0.06, 0.04, 0.03, 0.15, 0.35, 0.36, 0.15, 0.06], 293.0),
    "track": ([0.12, 0.14, 0.18, 0.21, 0.23, 0.25, 0.27, 0.29, 0.34, 0.31], 309.0),
}
CLASS_NAMES = tuple(CLASSES)
CLASS_ID = {name: i for i, name in enumerate(CLASS_NAMES)}
_SPECTRA = np.array([CLASSES[n][0] for n in CLASS_NAMES])
_TEMPERATURE = np.array([CLASSES[n][1] for n in CLASS_NAMES])
#: Classes on which a point can be measured and which lie on the bare terrain (no water, no roofs).
OPEN_GROUND = tuple(CLASS_ID[n] for n in ("grass", "crop_green", "crop_ripe", "soil", "track", "asphalt", "concrete"))


def to_dn(values: np.ndarray) -> np.ndarray:
    """Digital numbers (float) of physical band values (n, 11)."""
    dn = np.empty_like(values, dtype=np.float64)
    dn[..., :10] = values[..., :10] * REFLECTANCE_GAIN
    dn[..., 10] = (values[..., 10] - THERMAL_OFFSET_K) * THERMAL_GAIN
    return dn


def dn_to_uint16(dn: np.ndarray) -> np.ndarray:
    return np.clip(np.rint(dn), 0, 65535).astype(np.uint16)


class LandcoverScene:
    """Procedural land cover around a block origin (map metres); deterministic for a seed.

    Parameters
    ----------
    origin : (x, y) map coordinates of the block centre.
    seed : integer seed.
    urban_fraction, forest_fraction : approximate fractions of the area.
    river : draw a meandering river roughly north-south through the block.
    """

    FIELD_W, FIELD_H = 170.0, 330.0
    BLOCK_W, BLOCK_H = 115.0, 95.0
    STREET_HALF = 8.0

    def __init__(self, origin: tuple[float, float], seed: int, urban_fraction: float = 0.3,
                 forest_fraction: float = 0.15, river: bool = True) -> None:
        self.x0, self.y0 = float(origin[0]), float(origin[1])
        self.seed = int(seed) & 0x7FFFFFFF
        self.river = river
        rng = np.random.default_rng(self.seed)
        self.river_phase = rng.uniform(0, 2 * np.pi, 2)
        self.river_x = rng.uniform(-600.0, 600.0)
        probe = np.mgrid[-20000:20000:200.0, -20000:20000:200.0].reshape(2, -1)
        u = self._urbanness(probe[0], probe[1])
        f = self._forestness(probe[0], probe[1])
        self.urban_threshold = float(np.quantile(u, 1.0 - urban_fraction)) if urban_fraction > 0 else np.inf
        self.forest_threshold = float(np.quantile(f, 1.0 - forest_fraction)) if forest_fraction > 0 else np.inf

    def _urbanness(self, X, Y):
        return fbm(X, Y, 4000.0, self.seed + 11, octaves=3)

    def _forestness(self, X, Y):
        return fbm(X, Y, 2500.0, self.seed + 23, octaves=3)

    def classes(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Land-cover class ids (n,) at map points."""
        return self._evaluate(np.asarray(x, float) - self.x0, np.asarray(y, float) - self.y0)[0]

    def values(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Band values (n, 11): reflectance (bands 1-10), brightness temperature in K (band 11)."""
        X = np.ascontiguousarray(np.asarray(x, float).ravel() - self.x0)
        Y = np.ascontiguousarray(np.asarray(y, float).ravel() - self.y0)
        out = np.empty((X.size, N_BANDS))
        choose_threading_layer()
        _landcover_values(X, Y, self.seed, self._params(), _SPECTRA, _TEMPERATURE, out)
        return out

    def _params(self) -> np.ndarray:
        return np.array([self.urban_threshold, self.forest_threshold, self.river_x, self.river_phase[0],
                         self.river_phase[1], 1.0 if self.river else 0.0])

    def _evaluate(self, X: np.ndarray, Y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Class ids and brightness factors at block-relative coordinates (compiled, parallel)."""
        Xa = np.ascontiguousarray(np.asarray(X, float).ravel())
        Ya = np.ascontiguousarray(np.broadcast_to(np.asarray(Y, float), np.shape(X)).ravel())
        cls = np.empty(Xa.size, dtype=np.int64)
        bright = np.empty(Xa.size)
        choose_threading_layer()
        _landcover(Xa, Ya, self.seed, self._params(), cls, bright)
        return cls.reshape(np.shape(X)), bright.reshape(np.shape(X))


# class ids for the compiled kernel (the order of CLASSES)
_WATER, _ASPHALT, _CONCRETE, _ROOF_TILE, _ROOF_DARK, _GRASS, _CROP_GREEN, _CROP_RIPE, _SOIL, _FOREST, _TRACK = range(11)
_FIELD_W, _FIELD_H = LandcoverScene.FIELD_W, LandcoverScene.FIELD_H
_BLOCK_W, _BLOCK_H, _STREET = LandcoverScene.BLOCK_W, LandcoverScene.BLOCK_H, LandcoverScene.STREET_HALF


@nb.njit(cache=True)
def _landcover_point(X, Y, s, urban_thr, forest_thr, river_x, p1, p2, river):
    """(class id, brightness) of one block-relative point: see LandcoverScene."""
    cls = _GRASS
    bright = 1.0 + 0.06 * fbm_at(X, Y, 40.0, s + 1, 3, 0.5)
    urban = fbm_at(X, Y, 4000.0, s + 11, 3, 0.5) > urban_thr
    forest = (not urban) and fbm_at(X, Y, 2500.0, s + 23, 3, 0.5) > forest_thr
    crowns = fbm_at(X, Y, 12.0, s + 12, 2, 0.5)
    if urban:
        # perimeter blocks: streets, pavements, roofs in house segments, courtyards, parks
        ux = X + 6.0 * noise_at(X, Y, 900.0, s + 13)
        uy = Y + 6.0 * noise_at(X, Y, 900.0, s + 14)
        bi = math.floor(ux / _BLOCK_W)
        bj = math.floor(uy / _BLOCK_H)
        gx = ux - bi * _BLOCK_W
        gy = uy - bj * _BLOCK_H
        ex = min(gx, _BLOCK_W - gx)
        ey = min(gy, _BLOCK_H - gy)
        edge = min(ex, ey)
        along = gy if ex < ey else gx
        hb = hash01(bi, bj, s + 16)
        park = hb > 0.93
        bright = 1.0
        if edge < _STREET:
            cls = _ASPHALT
        elif edge < _STREET + 3.0:
            cls = _CONCRETE
        elif edge < _STREET + 17.0 and not park:
            cls = _ROOF_TILE if hb < 0.55 else (_ROOF_DARK if hb < 0.8 else _CONCRETE)
            bright = 0.8 + 0.4 * hash01(math.floor(along / 14.0) + 97 * bi, bj, s + 15)
        elif park:
            cls = _GRASS
        else:
            cls = _GRASS if hash01(bi, bj, s + 17) < 0.5 else _FOREST
            if cls == _FOREST:
                bright = 1.0 + 0.25 * crowns
        bright *= 1.0 + 0.04 * fbm_at(X, Y, 20.0, s + 18, 2, 0.5)
    elif forest:
        cls = _GRASS if crowns < -0.55 else _FOREST
        bright = 1.0 + 0.35 * crowns
    else:
        # staggered parcels on a gently warped grid: crops, rows, farm tracks and roads
        wx = X + 30.0 * noise_at(X, Y, 500.0, s + 2)
        wy = Y + 30.0 * noise_at(X, Y, 500.0, s + 3)
        i = math.floor(wx / _FIELD_W)
        shift = hash01(i, 0.0, s + 4) * _FIELD_H
        j = math.floor((wy + shift) / _FIELD_H)
        h = hash01(i, j, s + 5)
        fx = wx / _FIELD_W - i
        fy = (wy + shift) / _FIELD_H - j
        d_vertical = min(fx, 1 - fx) * _FIELD_W
        d_horizontal = min(fy, 1 - fy) * _FIELD_H
        if d_vertical < 4.0 and hash01(round(wx / _FIELD_W), 1.0, s + 8) < 0.25:
            cls = _ASPHALT
        elif d_horizontal < 2.5 and hash01(i, j, s + 9) < 0.35:
            cls = _TRACK
        else:
            cls = _CROP_GREEN if h < 0.3 else (_CROP_RIPE if h < 0.55 else (_GRASS if h < 0.75 else _SOIL))
            phase = wx if hash01(i, j, s + 6) < 0.5 else wy
            bright *= 0.85 + 0.3 * hash01(i, j, s + 7) + 0.05 * math.sin(2 * math.pi * phase / 18.0)
    # water: a meandering river and ponds, over everything else
    water = False
    if river:
        xr = river_x + 350.0 * math.sin(2 * math.pi * Y / 6000.0 + p1) + 120.0 * math.sin(2 * math.pi * Y / 1700.0 + p2)
        water = abs(X - xr) < 35.0 + 12.0 * noise_at(X, Y, 800.0, s + 19)
    if not water and not urban:
        water = fbm_at(X, Y, 700.0, s + 20, 2, 0.5) > 0.62
    if water:
        cls = _WATER
        bright = 1.0 + 0.1 * noise_at(X, Y, 150.0, s + 21)
    return cls, min(max(bright, 0.3), 2.0)


@nb.njit(parallel=True, cache=True)
def _landcover(X, Y, seed, params, cls_out, bright_out):
    for k in nb.prange(X.size):
        c, b = _landcover_point(X[k], Y[k], seed, params[0], params[1], params[2], params[3], params[4],
                                params[5] > 0.5)
        cls_out[k] = c
        bright_out[k] = b


@nb.njit(parallel=True, cache=True)
def _landcover_values(X, Y, seed, params, spectra, temperature, out):
    """Band values (n, 11) of block-relative points: class spectrum x brightness; thermal in K."""
    for k in nb.prange(X.size):
        c, b = _landcover_point(X[k], Y[k], seed, params[0], params[1], params[2], params[3], params[4],
                                params[5] > 0.5)
        for band in range(spectra.shape[1]):
            out[k, band] = spectra[c, band] * b
        out[k, spectra.shape[1]] = temperature[c] + 20.0 * (b - 1.0) + 0.8 * noise_at(X[k], Y[k], 60.0, seed + 5)


class TextureScene:
    """An RGB orthophoto mirrored-tiled over the block; 11 bands from a simple spectral model.

    Parameters
    ----------
    path : any raster rasterio reads with 3 bands (RGB, 8 bit); its pixel size comes from its
        georeference (world file) unless ``pixel_m`` is given.
    origin : (x, y) map coordinates where the texture's top-left corner is placed.
    pixel_m : ground size of a texture pixel, metres (0: from the file, converted to metres).
    resample_to_m : the texture is area-averaged to about this pixel size first.
    """

    def __init__(self, path: str, origin: tuple[float, float], pixel_m: float = 0.0,
                 resample_to_m: float = 1.0) -> None:
        import cv2
        import rasterio

        try:
            with rasterio.open(path) as src:
                rgb = src.read([1, 2, 3]).astype(np.float32) if src.count >= 3 else None
                size = abs(src.transform.a)
                unit = src.crs.linear_units_factor[1] if src.crs is not None and src.crs.is_projected else 1.0
        except rasterio.errors.RasterioIOError as exc:
            raise InputFileError(f"{path}: cannot read the texture image ({exc})") from exc
        if rgb is None:
            raise InputFileError(f"{path}: a texture needs 3 bands (RGB)")
        pixel = pixel_m or size * unit or 1.0
        factor = max(int(round(resample_to_m / pixel)), 1)
        image = np.moveaxis(rgb, 0, -1) / 255.0
        if factor > 1:
            h, w = image.shape[0] // factor, image.shape[1] // factor
            image = cv2.resize(image, (w, h), interpolation=cv2.INTER_AREA)
        self.image = image.astype(np.float32)
        self.pixel = pixel * factor
        self.x0, self.y0 = float(origin[0]), float(origin[1])

    def _rgb(self, x, y) -> np.ndarray:
        rows, cols = self.image.shape[:2]
        u = (np.asarray(x, float).ravel() - self.x0) / self.pixel - 0.5
        v = (self.y0 - np.asarray(y, float).ravel()) / self.pixel - 0.5
        u, v = _mirror(u, cols), _mirror(v, rows)
        c0 = np.clip(np.floor(u), 0, cols - 2).astype(np.intp)
        r0 = np.clip(np.floor(v), 0, rows - 2).astype(np.intp)
        fu, fv = (u - c0)[:, None], (v - r0)[:, None]
        im = self.image
        top = im[r0, c0] * (1 - fu) + im[r0, c0 + 1] * fu
        bottom = im[r0 + 1, c0] * (1 - fu) + im[r0 + 1, c0 + 1] * fu
        return top * (1 - fv) + bottom * fv

    def values(self, x, y) -> np.ndarray:
        """Band values (n, 11) from the texture's RGB."""
        rgb = self._rgb(x, y).astype(np.float64)
        r, g, b = rgb[:, 0], rgb[:, 1], rgb[:, 2]
        brightness = rgb.mean(axis=1)
        veg = np.clip(3.0 * (g - r) + 1.5 * (g - b), 0.0, 1.0)
        nir = 0.6 * brightness + 0.5 * veg
        out = np.empty((len(r), N_BANDS))
        out[:, 0], out[:, 1], out[:, 2] = 0.9 * b * 0.5, b * 0.5, g * 0.5
        out[:, 3], out[:, 4] = 0.5 * (0.6 * r + 0.4 * g), 0.5 * r
        out[:, 5] = 0.5 * (0.5 * r + 0.5 * nir)
        out[:, 6], out[:, 7] = 0.6 * nir, 0.62 * nir
        out[:, 8], out[:, 9] = 0.45 * brightness + 0.1 * (1 - veg), 0.35 * brightness + 0.05 * (1 - veg)
        out[:, 10] = 292.0 + 18.0 * brightness * (1.0 - veg) + 4.0 * (1.0 - veg)
        return out

    def classes(self, x, y) -> np.ndarray:
        """A coarse class: water where dark, grass where green, concrete otherwise."""
        rgb = self._rgb(x, y)
        brightness = rgb.mean(axis=1)
        veg = (rgb[:, 1] - rgb[:, 0]) > 0.03
        return np.where(brightness < 0.08, CLASS_ID["water"], np.where(veg, CLASS_ID["grass"], CLASS_ID["concrete"]))


def _mirror(u: np.ndarray, n: int) -> np.ndarray:
    """Mirror-repeat coordinates into [0, n - 1]."""
    period = 2.0 * (n - 1)
    m = np.mod(u, period)
    return np.where(m > n - 1, period - m, m)


def make_scene(config, origin: tuple[float, float], seed: int, texture: str | None = None):
    """The scene of a SceneConfig (``texture`` overrides the configured image)."""
    path = texture or (config.texture if config.kind == "texture" else None)
    if path:
        return TextureScene(path, origin, pixel_m=config.texture_pixel_m)
    return LandcoverScene(origin, seed, config.urban_fraction, config.forest_fraction, config.river)
