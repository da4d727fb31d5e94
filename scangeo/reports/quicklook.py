"""The quicklook of the image report: the recommended variant's mosaic, the strips' footprints and the
check points on it (one figure).

The mosaic (``results/NAME/ortho/mosaic.tif``, written by ``scangeo rectify --mosaic`` or the rectify
stage of ``scangeo run``; of a platform, the first sensor's ``mosaic-<sensor>.tif`` by name) is read
decimated to at most :data:`SIZE` pixels on its longer side (its overviews serve when it has them),
three bands evenly spread over its bands as red, green and blue (one band: grey), each stretched
between its 2nd and 98th percentile; no-data is white.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from scangeo.reports import html
from scangeo.reports.figures import colour, png

#: Longer side of the decimated mosaic (pixels).
SIZE = 1000


def mosaic_path(results: Path, variant: str) -> Path:
    """``results/NAME/ortho/mosaic.tif``; of a platform (a mosaic per sensor) the first ``mosaic-<sensor>.tif``."""
    ortho = results / variant / "ortho"
    single = ortho / "mosaic.tif"
    per_sensor = sorted(ortho.glob("mosaic-*.tif")) if not single.exists() and ortho.is_dir() else []
    return per_sensor[0] if per_sensor else single


def _read(path: Path) -> tuple[np.ndarray, tuple[float, float, float, float]]:
    """The decimated mosaic as an (h, w, 3) float image in [0, 1] (NaN: no data) and its extent."""
    import rasterio  # start-up cost: GDAL loads only when the report is written
    from rasterio.enums import Resampling

    with rasterio.open(path) as src:
        scale = max(1.0, max(src.width, src.height) / SIZE)
        shape = (max(1, round(src.height / scale)), max(1, round(src.width / scale)))
        bands = sorted({int(b) for b in np.linspace(src.count, 1, 3).round()}, reverse=True) if src.count >= 3 \
            else [1]
        data = src.read(bands, out_shape=(len(bands), *shape), resampling=Resampling.average, masked=True)
        b = src.bounds
    rgb = np.empty((*shape, 3))
    for k in range(3):
        band = data[min(k, len(bands) - 1)].astype(float).filled(np.nan)
        lo, hi = np.nanpercentile(band, [2, 98]) if np.isfinite(band).any() else (0.0, 1.0)
        rgb[..., k] = np.clip((band - lo) / max(hi - lo, 1e-12), 0.0, 1.0)
    return rgb, (b.left, b.right, b.bottom, b.top)


def quicklook_figure(path: Path, footprints: dict[str, np.ndarray], checks: np.ndarray, variant: str) -> bytes:
    """The mosaic with the strips' footprints (closed polygons, map x, y) and the check points (n, 2)."""
    rgb, extent = _read(path)
    empty = ~np.isfinite(rgb).all(axis=2)
    rgb = np.where(empty[..., None], 1.0, np.nan_to_num(rgb))
    aspect = (extent[3] - extent[2]) / max(extent[1] - extent[0], 1e-9)  # height / width of the map
    fig = Figure(figsize=(min(9.0, 12.0 / aspect) + 1.0, min(12.0, 9.0 * aspect) + 0.5), layout="constrained")
    ax = fig.subplots()
    ax.imshow(rgb, extent=extent, interpolation="nearest")
    for i, (sid, poly) in enumerate(footprints.items()):
        ax.plot(poly[:, 0], poly[:, 1], color=colour(i), lw=1.2, label=f"strip {sid}")
    if checks.size:
        ax.scatter(checks[:, 0], checks[:, 1], s=28, marker="o", facecolors="none", edgecolors="yellow",
                   linewidths=1.5, label=f"check points ({len(checks)})")
    ax.set_xlim(extent[0], extent[1])
    ax.set_ylim(extent[2], extent[3])
    ax.set_aspect("equal")
    ax.ticklabel_format(useOffset=False, style="plain")
    ax.tick_params(labelsize=7)
    ax.legend(loc="upper right", fontsize=8)
    ax.set_title(f"mosaic of {variant}")
    return png(fig)


def quicklook_section(results: Path, variant: str, footprints: dict[str, np.ndarray],
                      checks: np.ndarray, images: bool = True) -> html.Section:
    """The report's quicklook section (one line saying why instead of the figure when the mosaic is not
    there; ``images``: whether any strip of the project has an image to rectify)."""
    path = mosaic_path(results, variant)
    if not path.exists():
        why = (f"no mosaic of {variant} yet (scangeo rectify PROJECT --variant {variant} --mosaic, or scangeo run)"
               if images else "no mosaic: no strip of the project has an image to rectify "
               "(project.toml [[strips]] image)")
        return html.Section("Quicklook", "quicklook", [html.paragraph(why)])
    return html.Section("Quicklook", "quicklook", [html.figure(
        quicklook_figure(path, footprints, checks, variant),
        f"the mosaic of the recommended variant {variant} ({path.relative_to(results.parent).as_posix()}), "
        "the strips' footprints and the check points", "quicklook-figure")])


__all__ = ["SIZE", "mosaic_path", "quicklook_figure", "quicklook_section"]
