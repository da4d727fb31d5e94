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

import numpy as np

from scangeo.simulate.fields import fbm, hash_uniform, value_noise

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
        X = np.asarray(x, float).ravel() - self.x0
        Y = np.asarray(y, float).ravel() - self.y0
        cls, brightness = self._evaluate(X, Y)
        out = np.empty((X.size, N_BANDS))
        out[:, :10] = _SPECTRA[cls] * brightness[:, None]
        out[:, 10] = _TEMPERATURE[cls] + 2.0 * (brightness - 1.0) * 10.0 + 0.8 * value_noise(X, Y, 60.0, self.seed + 5)
        return out

    def _evaluate(self, X: np.ndarray, Y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        s = self.seed
        cls = np.full(X.shape, CLASS_ID["grass"], dtype=np.intp)
        bright = 1.0 + 0.06 * fbm(X, Y, 40.0, s + 1, octaves=3)
        urban = self._urbanness(X, Y) > self.urban_threshold
        forest = ~urban & (self._forestness(X, Y) > self.forest_threshold)
        rural = ~urban & ~forest

        # rural: staggered parcels on a gently warped grid, crops by parcel, farm tracks and roads
        wx = X + 30.0 * value_noise(X, Y, 500.0, s + 2)
        wy = Y + 30.0 * value_noise(X, Y, 500.0, s + 3)
        i = np.floor(wx / self.FIELD_W)
        shift = hash_uniform(i, 0, s + 4) * self.FIELD_H
        j = np.floor((wy + shift) / self.FIELD_H)
        h = hash_uniform(i, j, s + 5)
        crop = np.select([h < 0.3, h < 0.55, h < 0.75], [CLASS_ID["crop_green"], CLASS_ID["crop_ripe"],
                                                         CLASS_ID["grass"]], CLASS_ID["soil"])
        fx = wx / self.FIELD_W - i
        fy = (wy + shift) / self.FIELD_H - j
        d_vertical = np.minimum(fx, 1 - fx) * self.FIELD_W
        d_horizontal = np.minimum(fy, 1 - fy) * self.FIELD_H
        rows_dir = hash_uniform(i, j, s + 6) < 0.5
        phase = np.where(rows_dir, wx, wy)
        field_bright = 0.85 + 0.3 * hash_uniform(i, j, s + 7) + 0.05 * np.sin(2 * np.pi * phase / 18.0)
        road = (d_vertical < 4.0) & (hash_uniform(np.round(wx / self.FIELD_W), 1, s + 8) < 0.25)
        track = (d_horizontal < 2.5) & (hash_uniform(i, j, s + 9) < 0.35)
        rural_cls = np.where(road, CLASS_ID["asphalt"], np.where(track, CLASS_ID["track"], crop))
        cls = np.where(rural, rural_cls, cls)
        bright = np.where(rural & ~road & ~track, bright * field_bright, bright)

        # forest: crowns as strong small-scale texture, clearings of grass
        crowns = fbm(X, Y, 12.0, s + 12, octaves=2)
        cls = np.where(forest, np.where(crowns < -0.55, CLASS_ID["grass"], CLASS_ID["forest"]), cls)
        bright = np.where(forest, 1.0 + 0.35 * crowns, bright)

        # urban: perimeter blocks with streets, sidewalks, roofs in house segments, courtyards, parks
        ux = X + 6.0 * value_noise(X, Y, 900.0, s + 13)
        uy = Y + 6.0 * value_noise(X, Y, 900.0, s + 14)
        bi, bj = np.floor(ux / self.BLOCK_W), np.floor(uy / self.BLOCK_H)
        gx, gy = (ux / self.BLOCK_W - bi) * self.BLOCK_W, (uy / self.BLOCK_H - bj) * self.BLOCK_H
        edge = np.minimum.reduce([gx, self.BLOCK_W - gx, gy, self.BLOCK_H - gy])
        along = np.where(np.minimum(gx, self.BLOCK_W - gx) < np.minimum(gy, self.BLOCK_H - gy), gy, gx)
        house = hash_uniform(np.floor(along / 14.0) + 97 * bi, bj, s + 15)
        hb = hash_uniform(bi, bj, s + 16)
        roof = np.where(hb < 0.55, CLASS_ID["roof_tile"], np.where(hb < 0.8, CLASS_ID["roof_dark"], CLASS_ID["concrete"]))
        court = np.where(hash_uniform(bi, bj, s + 17) < 0.5, CLASS_ID["grass"], CLASS_ID["forest"])
        park = hb > 0.93
        urban_cls = np.select(
            [edge < self.STREET_HALF, edge < self.STREET_HALF + 3.0, (edge < self.STREET_HALF + 17.0) & ~park],
            [CLASS_ID["asphalt"], CLASS_ID["concrete"], roof],
            np.where(park, CLASS_ID["grass"], court),
        )
        urban_bright = np.where((edge >= self.STREET_HALF + 3.0) & (edge < self.STREET_HALF + 17.0) & ~park,
                                0.8 + 0.4 * house, 1.0 + 0.25 * crowns * (urban_cls == CLASS_ID["forest"]))
        cls = np.where(urban, urban_cls, cls)
        bright = np.where(urban, urban_bright * (1.0 + 0.04 * fbm(X, Y, 20.0, s + 18, octaves=2)), bright)

        # water: a meandering river and ponds, over everything else
        if self.river:
            p1, p2 = self.river_phase
            xr = self.river_x + 350.0 * np.sin(2 * np.pi * Y / 6000.0 + p1) + 120.0 * np.sin(2 * np.pi * Y / 1700.0 + p2)
            width = 35.0 + 12.0 * value_noise(X, Y, 800.0, s + 19)
            water = np.abs(X - xr) < width
        else:
            water = np.zeros(X.shape, bool)
        water |= ~urban & (fbm(X, Y, 700.0, s + 20, octaves=2) > 0.62)
        cls = np.where(water, CLASS_ID["water"], cls)
        bright = np.where(water, 1.0 + 0.1 * value_noise(X, Y, 150.0, s + 21), bright)
        return cls, np.clip(bright, 0.3, 2.0)


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

        from scangeo.errors import InputFileError

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
