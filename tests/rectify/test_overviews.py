"""Internal overviews: on by default above OVERVIEW_MIN_SIZE cells, forced on or off by the option."""
from __future__ import annotations

import argparse

import numpy as np
import pytest
import rasterio
from rasterio.transform import from_origin

from scangeo.errors import RectifyOptionsError
from scangeo.rectify.geotiff import OVERVIEW_MIN_SIZE, GeoTiffProfile, finalise, overview_factors
from scangeo.rectify.options import RectifyOptions


def _working(path, height, width):
    data = (np.arange(height * width, dtype=np.uint32) % 4000).astype(np.uint16).reshape(1, height, width)
    with rasterio.open(path, "w", driver="GTiff", width=width, height=height, count=1, dtype="uint16",
                       crs="EPSG:32633", transform=from_origin(500000, 5300000, 2.5, 2.5), tiled=True,
                       blockxsize=256, blockysize=256) as dst:
        dst.write(data)
    return data[0]


@pytest.mark.parametrize("cog", [True, False])
@pytest.mark.parametrize("overviews, height, expected", [
    ("auto", OVERVIEW_MIN_SIZE + 100, [2, 4, 8]),   # a long strip: 2148 x 300 cells
    ("auto", OVERVIEW_MIN_SIZE, []),               # at the threshold: none
    (False, OVERVIEW_MIN_SIZE + 100, []),
    (True, 600, [2]),
])
def test_overviews_present_or_absent(tmp_path, cog, overviews, height, expected):
    data = _working(tmp_path / "w.tif", height, 300)
    profile = GeoTiffProfile(overviews=overviews, cog=cog)
    finalise(tmp_path / "w.tif", tmp_path / "out.tif", profile, np.uint16)
    with rasterio.open(tmp_path / "out.tif") as src:
        assert src.overviews(1) == expected
        assert np.array_equal(src.read(1), data)  # full resolution untouched
        if expected:
            level = src.read(1, out_shape=(height // 2, 150))  # read from the first overview
            assert abs(float(level.mean()) - float(data.mean())) < 0.01 * float(data.mean())
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.tif", "w.tif"]


def test_factors_stop_when_a_level_fits_one_block():
    assert overview_factors(7000, 900, 512) == [2, 4, 8, 16]  # 7000 / 16 = 437 <= 512
    assert overview_factors(512, 100, 512) == []


def test_the_option_from_files_and_the_command_line():
    assert RectifyOptions().geotiff.overviews == "auto"
    assert RectifyOptions.from_dict({"geotiff": {"overviews": False}}).geotiff.overviews is False
    with pytest.raises(RectifyOptionsError, match=r"\[rectify.geotiff.overviews\]: expected true or false or one of"):
        RectifyOptions.from_dict({"geotiff": {"overviews": "yes"}})
    with pytest.raises(RectifyOptionsError, match="overviews must be 'auto'"):
        GeoTiffProfile(overviews="always")
    from scangeo.cli.rectify import options_of

    base = dict.fromkeys(("resolution", "bounds", "resampling", "layers", "igm", "glt", "mosaic", "occlusion",
                          "max_error_px", "memory_budget_mb"))
    for flag, expected in ((None, "auto"), (True, True), (False, False)):
        args = argparse.Namespace(config=None, overviews=flag, **base)
        assert options_of(args).geotiff.overviews == expected
