"""Internal overviews: on by default above OVERVIEW_MIN_SIZE cells, forced on or off by the option."""
from __future__ import annotations

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
    ("auto", 2148, [2, 4, 8]),                # a long strip: 2148 x 300 cells
    ("auto", OVERVIEW_MIN_SIZE + 88, [2]),    # 600 x 300: above 512 cells, as strict COG validation asks
    ("auto", OVERVIEW_MIN_SIZE, []),          # at the threshold (one block): none
    (False, 2148, []),
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
    with pytest.raises(RectifyOptionsError, match=r"GeoTiffProfile.overviews: expected true or false or one of auto"):
        GeoTiffProfile(overviews="always")
    from scangeo.cli import build_parser
    from scangeo.cli.rectify import options_of

    for flags, expected in (([], "auto"), (["--overviews"], True), (["--no-overviews"], False)):
        args = build_parser().parse_args(["rectify", "nowhere", "--variant", "DG", *flags])
        assert options_of(args).geotiff.overviews == expected


def _reference_halve(a: np.ndarray, valid: np.ndarray, integer: bool) -> np.ndarray:
    """Mean of the valid cells of each 2 x 2 block (odd edges: the cells there are), plain numpy."""
    h, w = a.shape
    out = np.full(((h + 1) // 2, (w + 1) // 2), np.nan)
    for r in range(out.shape[0]):
        for c in range(out.shape[1]):
            block, ok = a[2 * r:2 * r + 2, 2 * c:2 * c + 2], valid[2 * r:2 * r + 2, 2 * c:2 * c + 2]
            if ok.any():
                m = float(block[ok].astype(float).mean())
                out[r, c] = np.floor(m + 0.5) if integer else m
    return out


@pytest.mark.parametrize("dtype, nodata", [("uint16", 0), ("int16", -9999), ("float32", None)])
def test_levels_average_the_valid_cells(dtype, nodata):
    from scangeo.rectify.overviews import halve

    rng = np.random.default_rng(4)
    a = rng.integers(1, 3000, size=(2, 37, 23)).astype(dtype)
    invalid = rng.random(a.shape) < 0.3
    invalid[:, :4, :4] = True  # whole blocks without a valid cell
    a[invalid] = np.nan if nodata is None else nodata
    got = halve(a, nodata)
    assert got.shape == (2, 19, 12) and got.dtype == a.dtype
    for b in range(2):
        ref = _reference_halve(a[b], ~invalid[b], dtype != "float32")
        empty = np.isnan(ref)
        assert empty[:2, :2].all()
        if nodata is None:
            assert np.isnan(got[b][empty]).all()
        else:
            assert (got[b][empty] == nodata).all()
        assert np.allclose(got[b][~empty].astype(float), ref[~empty], rtol=1e-6, atol=0)


@pytest.mark.parametrize("dtype, nodata, cells, expected", [
    ("int16", 0, [[-1, 1], [0, 0]], 1),  # a mean of 0 from valid cells is not nodata
    ("int16", 0, [[-1, 0], [0, 0]], -1),  # -1 rounds half up to 0: one step towards the mean
    ("uint16", 65535, [[65534, 65534], [65535, 65533]], 65534),
    ("uint8", 0, [[0, 0], [0, 0]], 0),  # no valid cell: nodata
])
def test_valid_cells_never_average_to_nodata(dtype, nodata, cells, expected):
    from scangeo.rectify.overviews import halve

    got = halve(np.array([cells], dtype), nodata)
    assert got.shape == (1, 1, 1) and int(got[0, 0, 0]) == expected


def test_the_final_file_carries_every_level_in_chunks_with_its_metadata(tmp_path, monkeypatch):
    from scangeo.rectify import overviews

    monkeypatch.setattr(overviews, "CHUNK_BYTES", 4 * 300 * 2 * 3)  # 12 rows per chunk: many chunks
    height, width = 2300, 300
    data = _working(tmp_path / "w.tif", height, width)
    data[:100] = 0  # nodata rows
    with rasterio.open(tmp_path / "w.tif", "r+") as dst:
        dst.nodata = 0
        dst.write(data, 1)
        dst.set_band_description(1, "blue <&> band")
        dst.update_tags(1, wavelength="0.485")
        dst.update_tags(scangeo_fingerprint="abc")
    finalise(tmp_path / "w.tif", tmp_path / "out.tif", GeoTiffProfile(overviews=True), np.uint16)
    with rasterio.open(tmp_path / "out.tif") as src:
        assert src.overviews(1) == [2, 4, 8]
        assert src.descriptions[0] == "blue <&> band" and src.tags(1)["wavelength"] == "0.485"
        assert src.tags()["scangeo_fingerprint"] == "abc" and src.nodata == 0
        level = data.astype(np.uint16)[None]
        for factor in (2, 4, 8):
            level = overviews.halve(level, 0)
            read = src.read(1, out_shape=level.shape[1:])  # GDAL picks the level of that size
            assert np.array_equal(read, level[0]), factor
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.tif", "w.tif"]


@pytest.mark.parametrize("dtype, nodata", [("uint16", 0), ("float32", None)])
def test_levels_from_the_tiles_equal_the_levels_from_the_file(tmp_path, dtype, nodata):
    """LevelTiles (levels written with each tile of pass 2) gives the levels write_level reads back
    from the whole working file, odd last rows and columns and empty blocks included."""
    from rasterio.windows import Window

    from scangeo.rectify.overviews import LevelTiles, level_path, write_level

    rng = np.random.default_rng(7)
    height, width, tile, factors = 301, 203, 64, [2, 4, 8]
    data = rng.integers(1, 3000, size=(2, height, width)).astype(dtype)
    data[:, rng.random((height, width)) < 0.2] = np.nan if nodata is None else nodata
    data[:, 64:80, :] = np.nan if nodata is None else nodata
    profile = {"driver": "GTiff", "width": width, "height": height, "count": 2, "dtype": dtype, "nodata": nodata,
               "crs": "EPSG:32633", "transform": from_origin(500000, 5300000, 2.5, 2.5), "tiled": True,
               "blockxsize": 64, "blockysize": 64}
    assert LevelTiles.aligned(tile, factors) and not LevelTiles.aligned(36, factors)
    tiled = tmp_path / "tiled" / "w.tif"
    tiled.parent.mkdir()
    levels = LevelTiles(tiled, profile, factors)
    with rasterio.open(tmp_path / "w.tif", "w", **profile) as dst:
        dst.write(data)
    for r in range(0, height, tile):
        for c in range(0, width, tile):
            h, w = min(tile, height - r), min(tile, width - c)
            levels.write(data[:, r:r + h, c:c + w], Window(c, r, w, h))
    levels.close()
    finer = tmp_path / "w.tif"
    for factor, made in zip(factors, levels.paths):
        assert made == level_path(tiled, factor)
        coarser = level_path(tmp_path / "w.tif", factor)
        write_level(finer, coarser)
        with rasterio.open(made) as a, rasterio.open(coarser) as b:
            assert (a.width, a.height) == (b.width, b.height) == (-(-width // factor), -(-height // factor))
            assert a.transform == b.transform
            assert np.array_equal(a.read(), b.read(), equal_nan=True), factor
        finer = coarser
