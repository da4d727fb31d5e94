"""True terrain of a simulated block and the project's DTM (true terrain plus a smooth error).

The true terrain is a raster in the map CRS (orthometric heights, bilinear between posts): either
synthetic (``fractal`` hills or a flat ``urban`` surface) or a real DTM file reprojected with
rasterio. The project DTM handed to the adjustment is the true terrain plus a smooth, zero-mean
error field of a chosen sigma and wavelength, as a photogrammetric DTM would have.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from affine import Affine

from scangeo.errors import DTMError
from scangeo.grid import RasterGrid
from scangeo.simulate.config import TerrainConfig
from scangeo.simulate.fields import spectral_field


@dataclass(frozen=True)
class Extent:
    """A map rectangle (xmin, ymin, xmax, ymax), metres in the map CRS."""

    xmin: float
    ymin: float
    xmax: float
    ymax: float

    def grid(self, resolution_m: float) -> tuple[Affine, tuple[int, int]]:
        """North-up affine transform and (rows, cols) covering the extent at a resolution."""
        cols = int(np.ceil((self.xmax - self.xmin) / resolution_m)) + 1
        rows = int(np.ceil((self.ymax - self.ymin) / resolution_m)) + 1
        transform = Affine(resolution_m, 0.0, self.xmin - resolution_m / 2, 0.0, -resolution_m,
                           self.ymax + resolution_m / 2)
        return transform, (rows, cols)

    def grown(self, margin_m: float) -> Extent:
        return Extent(self.xmin - margin_m, self.ymin - margin_m, self.xmax + margin_m, self.ymax + margin_m)


@dataclass(frozen=True)
class Terrain:
    """The true terrain and the project DTM, both rasters in the map CRS (orthometric heights).

    ``dtm_error`` is the project DTM minus the true terrain on the DTM's own grid.
    """

    true: RasterGrid
    dtm: RasterGrid
    dtm_error: np.ndarray

    def height(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """True orthometric height (m) at map points (bilinear; NaN outside)."""
        return self.true.sample(x, y)

    def mean_height(self, extent: Extent) -> float:
        """Mean true height inside a map rectangle."""
        xs = np.linspace(extent.xmin, extent.xmax, 40)
        ys = np.linspace(extent.ymin, extent.ymax, 40)
        gx, gy = np.meshgrid(xs, ys)
        return float(np.nanmean(self.height(gx.ravel(), gy.ravel())))


def synthetic_heights(config: TerrainConfig, shape: tuple[int, int], rng: np.random.Generator) -> np.ndarray:
    """Heights (m) of a synthetic terrain on a grid: fractal hills, or a gently sloping urban plain."""
    if config.kind == "urban":
        field = spectral_field(shape, config.resolution_m, rng, max(config.min_wavelength_m, 1500.0),
                               config.max_wavelength_m, exponent=2.0)
        return config.mean_height_m + config.relief_m * field
    field = spectral_field(shape, config.resolution_m, rng, config.min_wavelength_m, config.max_wavelength_m,
                           exponent=1.3)
    # ridges a little sharper than valleys: a mild asymmetric warp, renormalised
    warped = field + 0.25 * (field - field.min()) ** 2 / max(field.max() - field.min(), 1e-9)
    warped = (warped - warped.mean()) / warped.std()
    return config.mean_height_m + config.relief_m * warped


def reproject_dtm(path: str, crs, transform: Affine, shape: tuple[int, int]) -> np.ndarray:
    """A DTM file resampled (cubic) onto a grid of the map CRS; DTMError if it does not cover it."""
    import rasterio
    from rasterio.warp import Resampling, reproject

    try:
        with rasterio.open(path) as src:
            if src.crs is None:
                raise DTMError(f"{path}: the DTM has no CRS (expected a georeferenced raster)")
            out = np.full(shape, np.nan, dtype=np.float64)
            nodata = src.nodata if src.nodata is not None else -32768.0
            reproject(
                source=rasterio.band(src, 1), destination=out, src_nodata=nodata, dst_nodata=np.nan,
                dst_transform=transform, dst_crs=crs, resampling=Resampling.cubic,
            )
    except rasterio.errors.RasterioIOError as exc:
        raise DTMError(f"{path}: cannot read the DTM ({exc})") from exc
    missing = np.isnan(out).mean()
    if missing > 0.0:
        raise DTMError(
            f"{path}: the DTM does not cover the simulated block ({100 * missing:.1f} % of the "
            f"block's terrain grid has no height); choose a smaller block or another centre"
        )
    return out


def dtm_centre_lonlat(path: str) -> tuple[float, float]:
    """Longitude, latitude (degrees) of a DTM file's centre."""
    import pyproj
    import rasterio

    try:
        with rasterio.open(path) as src:
            b = src.bounds
            crs = src.crs
    except rasterio.errors.RasterioIOError as exc:
        raise DTMError(f"{path}: cannot read the DTM ({exc})") from exc
    if crs is None:
        raise DTMError(f"{path}: the DTM has no CRS (expected a georeferenced raster)")
    cx, cy = (b.left + b.right) / 2, (b.bottom + b.top) / 2
    to_geo = pyproj.Transformer.from_crs(crs, "EPSG:4326", always_xy=True)
    lon, lat = to_geo.transform(cx, cy)
    return float(lon), float(lat)


def make_terrain(config: TerrainConfig, extent: Extent, crs, rng: np.random.Generator,
                 dtm_file: str | None = None) -> Terrain:
    """The true terrain over ``extent`` (grown by the configured margin) and the project DTM.

    Parameters
    ----------
    config : terrain configuration.
    extent : the block's map rectangle (map CRS metres).
    crs : the map CRS (WKT or anything rasterio accepts).
    rng : random generator (deterministic per seed).
    dtm_file : a real DTM to use instead of ``config.file`` (kind ``file``).
    """
    area = extent.grown(config.margin_m)
    transform, shape = area.grid(config.resolution_m)
    source = dtm_file or (config.file if config.kind == "file" else None)
    if source:
        heights = reproject_dtm(source, crs, transform, shape)
    else:
        heights = synthetic_heights(config, shape, rng)
    crs_text = crs if isinstance(crs, str) else crs.to_wkt()
    true = RasterGrid(heights, transform, crs_text)
    inner = extent.grown(max(config.margin_m - 2 * max(config.resolution_m, config.dtm_resolution_m), 0.0))
    dtm_transform, dtm_shape = inner.grid(config.dtm_resolution_m)
    # the DTM's cells form a lattice (north-up grid): sampled row by row, without the (cells,)
    # coordinate and index arrays of a point-wise sample (those made 96-strip blocks peak at 4 GB)
    xs = dtm_transform.c + dtm_transform.a * (np.arange(dtm_shape[1]) + 0.5)
    ys = dtm_transform.f + dtm_transform.e * (np.arange(dtm_shape[0]) + 0.5)
    true_on_dtm = true.sample_lattice(xs, ys)
    error = np.zeros(dtm_shape)
    if config.dtm_error_sigma_m > 0:
        wavelength = config.dtm_error_wavelength_m
        error = config.dtm_error_sigma_m * spectral_field(
            dtm_shape, config.dtm_resolution_m, rng, wavelength / 2.0, wavelength * 4.0)
    dtm_values = true_on_dtm + error
    return Terrain(true, RasterGrid(dtm_values, dtm_transform, crs_text), error)
