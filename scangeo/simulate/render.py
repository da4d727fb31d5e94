"""Rendering a strip's image through the sensor model from the true trajectory over the true terrain.

For every pixel (line, pixel) of the image: the ray of the true sensor pose (true trajectory,
true lever arm and boresight, mirror timing) is intersected with the true terrain
(``StripGeometry.image_to_ground``), the ground point is converted to map coordinates, and the
scene is sampled there. Optional sensor noise (Gaussian, in digital numbers) is added. The result
is a (lines, pixels, bands) uint16 array, written band-sequential as a GeoTIFF (no
georeference: it is a raw scanner image) or ENVI file.
"""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from scangeo.atomic import atomic_files
from scangeo.dtm import DTM
from scangeo.progress import no_progress
from scangeo.sensors import StripGeometry
from scangeo.simulate.scene import BANDS, N_BANDS, dn_to_uint16, to_dn


def render_strip(geometry: StripGeometry, true_dtm: DTM, scene, noise_dn: float, rng: np.random.Generator,
                 line_chunk: int = 256, progress=no_progress, message: str = "render",
                 bands: tuple[int, ...] = ()) -> np.ndarray:
    """The image (lines, pixels, bands) uint16 of a strip.

    Parameters
    ----------
    geometry : the strip's true geometry (true spline, true mounting).
    true_dtm : the true terrain.
    scene : a scene with ``values(x, y) -> (n, 11)``.
    noise_dn : standard deviation of the sensor noise in digital numbers (0: none).
    bands : the scene's bands (1-based) the sensor records, in this order; empty: all 11.
    """
    n_lines, n_pix = geometry.n_lines, geometry.sensor.pixels
    chosen = np.array(bands, int) - 1 if bands else np.arange(N_BANDS)
    n_bands = chosen.size
    image = np.zeros((n_lines, n_pix, n_bands), dtype=np.uint16)
    pixels = np.arange(n_pix, dtype=float)
    for start in range(0, n_lines, line_chunk):
        stop = min(start + line_chunk, n_lines)
        L, J = np.meshgrid(np.arange(start, stop, dtype=float), pixels, indexing="ij")
        ground, status = geometry.image_to_ground(L.ravel(), J.ravel(), true_dtm)
        ok = status == 0
        dn = np.zeros((ground.shape[0], n_bands))
        if ok.any():
            x, y, _ = true_dtm.map_frame.project_to_map(ground[ok])  # pyproj: faster here than a local polynomial
            dn[ok] = to_dn(scene.values(x, y))[:, chosen]
        if noise_dn > 0:
            dn[ok] += rng.standard_normal((int(ok.sum()), n_bands)) * noise_dn
        image[start:stop] = dn_to_uint16(dn).reshape(stop - start, n_pix, n_bands)
        progress(stop, n_lines, message)
    return image


def write_image(path: Path, image: np.ndarray, image_format: str = "GTiff", bands: tuple[int, ...] = ()) -> None:
    """Write a (lines, pixels, bands) image band-sequential, via a temporary name, with band names (of the
    scene's ``bands``, 1-based; empty: the first ones in order).

    GeoTIFF: tiled, deflate-compressed, no georeference. ENVI: BSQ with a .hdr.
    """
    import rasterio
    from rasterio.errors import NotGeoreferencedWarning

    path = Path(path)
    lines, pixels, count = image.shape
    profile = dict(driver=image_format, width=pixels, height=lines, count=count, dtype="uint16")
    if image_format == "GTiff":
        profile.update(tiled=True, blockxsize=256, blockysize=256, compress="deflate", predictor=2,
                       interleave="band")
    else:
        profile.update(interleave="bsq")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NotGeoreferencedWarning)
        with atomic_files(path) as staged, rasterio.open(staged, "w", **profile) as dst:
            dst.write(np.moveaxis(image, -1, 0))
            for b, (name, lo, hi) in enumerate([BANDS[k - 1] for k in bands] or BANDS[:count], start=1):
                dst.set_band_description(b, f"{name} {lo}-{hi} um")
            dst.update_tags(kind="scanner image (lines x pixels)", gains=_gains(bands))


def _gains(bands: tuple[int, ...]) -> str:
    """The digital numbers' meaning (the ``gains`` tag) of an image of the scene's ``bands`` (empty: all 11)."""
    if not bands:
        return "bands 1-10: reflectance*10000; band 11: (brightness temperature K - 200)*100"
    return "; ".join(f"band {b}: " + ("(brightness temperature K - 200)*100" if k == N_BANDS else "reflectance*10000")
                     for b, k in enumerate(bands, start=1))
