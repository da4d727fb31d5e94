"""The image report's quicklook: the recommended mosaic, decimated, with footprints and check points."""
from __future__ import annotations

import io

import numpy as np
import rasterio
from affine import Affine
from PIL import Image

from scangeo.reports import quicklook


def _mosaic(path, width=2500, height=1200, bands=4):
    """A mosaic of ``bands`` bands whose band k is k * 10 + column // 250, the left 500 columns no data."""
    data = np.zeros((bands, height, width), np.float32)
    for k in range(bands):
        data[k] = k * 10 + (np.arange(width) // 250)[None, :]
    data[:, :, :500] = np.nan
    path.parent.mkdir(parents=True, exist_ok=True)
    with rasterio.open(path, "w", driver="GTiff", width=width, height=height, count=bands, dtype="float32",
                       crs="EPSG:32633", transform=Affine(0.5, 0, 500000.0, 0, -0.5, 5300000.0), nodata=np.nan) as dst:
        dst.write(data)


def test_the_mosaic_is_read_decimated_stretched_with_its_extent(tmp_path):
    path = quicklook.mosaic_path(tmp_path / "results", "S4")
    _mosaic(path)
    rgb, extent = quicklook._read(path)
    assert rgb.shape == (480, 1000, 3)  # 2500 x 1200 px at 2.5x: the longer side SIZE
    assert extent == (500000.0, 501250.0, 5299400.0, 5300000.0)
    assert np.isnan(rgb[:, :200]).all() and np.isfinite(rgb[:, 200:]).all()  # the no-data columns
    # columns grow left to right in every band: the stretch keeps the order, 2nd..98th percentile to 0..1
    row = rgb[10, 200:, 0]
    assert np.all(np.diff(row) >= 0) and row[0] == 0.0 and row[-1] == 1.0


def test_the_section_holds_the_figure_or_says_the_mosaic_is_missing(tmp_path):
    results = tmp_path / "results"
    missing = quicklook.quicklook_section(results, "S4", {}, np.zeros((0, 2)))
    assert "no mosaic of S4 yet" in missing.parts[0]
    _mosaic(quicklook.mosaic_path(results, "S4"))
    footprint = np.array([[500300.0, 5299500.0], [501200.0, 5299500.0], [501200.0, 5299900.0], [500300.0, 5299900.0],
                          [500300.0, 5299500.0]])
    section = quicklook.quicklook_section(results, "S4", {"01": footprint}, np.array([[500800.0, 5299700.0]]))
    assert 'id="quicklook-figure"' in section.parts[0] and "S4/ortho/mosaic.tif" in section.parts[0]
    png = quicklook.quicklook_figure(quicklook.mosaic_path(results, "S4"), {"01": footprint},
                                     np.array([[500800.0, 5299700.0]]), "S4")
    with Image.open(io.BytesIO(png)) as im:
        w, h = im.size
    assert w > 1.5 * h  # the map is twice as wide as high
