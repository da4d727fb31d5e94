"""scangeo's COG writer validated independently of itself: for any dtype, band count, size, nodata and
number of overview levels (hypothesis), the file it writes and the file GDAL's COG driver writes from the
same array, with GDAL computing its own AVERAGE overviews, are compared.

On each case: rio-cogeo's strict validation of both files; the full resolution equal cell by cell; the
same overview factors; the first level equal to the 2 x 2 mean of the valid cells computed here in
numpy; the tags (dataset, band, descriptions, image structure) and every directory's tags but the
blocks' offsets and sizes equal. Where the size is a multiple of the coarsest factor every level equals
GDAL's AVERAGE to rounding, and the directories' sizes are the same. Elsewhere GDAL's COG driver, making
the levels itself, halves each size rounding down (700, 350, 175, 87) and averages on that grid; the
levels scangeo writes have ``ceil(size / 2**k)`` cells of whole 2 x 2 blocks, the sizes gdaladdo gives
and GDAL's COG driver keeps when handed the levels (tests/rectify/test_cog_writer.py). The GDAL these
run on must lie within ``cog_writer.TESTED_GDAL``.
"""
from __future__ import annotations

import warnings

import numpy as np
import pytest
import rasterio
import rasterio.shutil
from affine import Affine
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from rasterio.crs import CRS
from rasterio.windows import Window

from scangeo.rectify.cog_writer import CogWriter, gdal_in_tested_range, read_directories
from scangeo.rectify.geotiff import overview_factors

cogeo = pytest.importorskip("rio_cogeo.cogeo")

CRS_ = CRS.from_epsg(32633)
TRANSFORM = Affine(2.5, 0, 595640.0, 0, -2.5, 5351907.5)
DTYPES = ["uint8", "uint16", "int16", "float32", "float64"]


def _data(dtype: str, bands: int, height: int, width: int, nodata, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    if np.dtype(dtype).kind == "f":
        a = rng.normal(100.0, 30.0, (bands, height, width)).astype(dtype)
    else:
        info = np.iinfo(dtype)
        low = 1 if nodata == 0 else max(info.min, -3000)  # values on one side of nodata, as an image's DNs
        a = rng.integers(low, min(info.max, 4000), (bands, height, width)).astype(dtype)
    if nodata is not None:  # holes of nodata, some 2 x 2 blocks wholly
        holes = rng.random((height, width)) < 0.2
        holes[: height // 3, : width // 4] = True
        a[:, holes] = nodata
    return a


def _annotate(dst, bands: int) -> None:
    for b in range(1, min(bands, 3) + 1):
        dst.set_band_description(b, f"band {b}")
        dst.update_tags(b, wavelength=str(400 + 10 * b), wavelength_units="nm")
    dst.update_tags(variant="SE", sigma0="1.25", TIFFTAG_SOFTWARE="scangeo test")


def by_scangeo(path, data: np.ndarray, nodata, blocksize: int, factors: list[int], tile: int, seed: int):
    """The writer fed tiles of ``tile`` cells in a random order."""
    bands, height, width = data.shape
    w = CogWriter(path.with_suffix(".spool"), width=width, height=height, count=bands, dtype=data.dtype,
                  nodata=nodata, crs=CRS_, transform=TRANSFORM, blocksize=blocksize, factors=factors, threads=2)
    windows = [Window(c, r, min(tile, width - c), min(tile, height - r))
               for r in range(0, height, tile) for c in range(0, width, tile)]
    for i in np.random.default_rng(seed).permutation(len(windows)):
        r, c = int(windows[i].row_off), int(windows[i].col_off)
        w.write(data[:, r:r + int(windows[i].height), c:c + int(windows[i].width)], windows[i])
    w.finish(path, path.with_name("." + path.name + ".partial"), lambda dst: _annotate(dst, bands))
    return path


def by_gdal(path, data: np.ndarray, nodata, blocksize: int, overviews: bool):
    """GDAL's COG driver from the same array, computing its own AVERAGE overviews."""
    bands, height, width = data.shape
    floating = data.dtype.kind == "f"
    with rasterio.MemoryFile() as mem:
        with mem.open(driver="GTiff", width=width, height=height, count=bands, dtype=data.dtype.name, crs=CRS_,
                      transform=TRANSFORM, nodata=nodata, interleave="pixel") as dst:
            dst.write(data)
            _annotate(dst, bands)
        with mem.open() as src:
            rasterio.shutil.copy(src, str(path), driver="COG", BLOCKSIZE=str(blocksize), COMPRESS="DEFLATE", LEVEL="1",
                                 PREDICTOR="FLOATING_POINT" if floating else "STANDARD", NUM_THREADS="1",
                                 BIGTIFF="IF_SAFER", OVERVIEWS="AUTO" if overviews else "NONE",
                                 OVERVIEW_RESAMPLING="AVERAGE")
    return path


def mean_2x2(level: np.ndarray, nodata) -> np.ndarray:
    """The mean of the valid cells (not nodata, not NaN) of each 2 x 2 block; nodata where none is."""
    bands, h, w = level.shape
    x = np.full((bands, h + h % 2, w + w % 2), np.nan)
    x[:, :h, :w] = level
    if nodata is not None and not np.isnan(nodata):
        x[x == nodata] = np.nan
    blocks = x.reshape(bands, x.shape[1] // 2, 2, x.shape[2] // 2, 2)
    n = np.sum(~np.isnan(blocks), axis=(2, 4))
    with np.errstate(invalid="ignore"):
        mean = np.nansum(blocks, axis=(2, 4)) / n
    fill = np.nan if nodata is None or np.isnan(nodata) else nodata
    return np.where(n > 0, mean, fill)


def _empty(data: np.ndarray, nodata, f: int) -> np.ndarray:
    """Whether each cell of the overview of factor ``f`` covers no valid cell of ``data``."""
    bands, h, w = data.shape
    valid = ~np.isnan(data.astype(float))
    if nodata is not None and not np.isnan(nodata):
        valid &= data != nodata
    padded = np.zeros((bands, -(-h // f) * f, -(-w // f) * f), bool)
    padded[:, :h, :w] = valid
    return ~padded.reshape(bands, padded.shape[1] // f, f, padded.shape[2] // f, f).any(axis=(2, 4))


def _close(ours: np.ndarray, reference: np.ndarray, empty: np.ndarray, nodata, dtype, steps: int, what: str) -> None:
    """Equal to rounding: nodata where no valid cell is; elsewhere integers within ``steps`` (one rounding
    per level made from the one before; a mean that rounds to the nodata value counts as that number),
    floats within the type's precision."""
    ours, reference = ours.astype(float), reference.astype(float)
    for x in (ours, reference):
        assert np.all(np.isnan(x[empty]) if nodata is None or np.isnan(nodata) else x[empty] == nodata), what
    ok = ~empty
    assert np.isfinite(ours[ok]).all() and np.isfinite(reference[ok]).all(), what
    if np.dtype(dtype).kind == "f":
        np.testing.assert_allclose(ours[ok], reference[ok], rtol=8 * np.finfo(dtype).eps, atol=0, err_msg=what)
    else:
        assert np.max(np.abs(ours[ok] - reference[ok]), initial=0.0) <= steps, what


def check_case(tmp, dtype: str, bands: int, height: int, width: int, nodata, blocksize: int, overviews: bool,
               tile_blocks: int, seed: int) -> None:
    data = _data(dtype, bands, height, width, nodata, seed)
    factors = overview_factors(width, height, blocksize) if overviews else []
    tile = blocksize * tile_blocks
    ours = by_scangeo(tmp / "ours.tif", data, nodata, blocksize, factors, tile, seed)
    gdal = by_gdal(tmp / "gdal.tif", data, nodata, blocksize, bool(factors))
    for path in (ours, gdal):
        valid, errors, warns = cogeo.cog_validate(str(path), strict=True, quiet=True)
        assert valid and not errors and not warns, (path.name, errors, warns)
    with rasterio.open(ours) as o, rasterio.open(gdal) as g:
        assert o.overviews(1) == g.overviews(1) == factors
        po, pg = dict(o.profile), dict(g.profile)
        no, ng = po.pop("nodata"), pg.pop("nodata")
        assert po == pg and (no == ng or (no is not None and ng is not None and np.isnan(no) and np.isnan(ng)))
        assert o.tags() == g.tags() and o.descriptions == g.descriptions
        assert o.tags(ns="IMAGE_STRUCTURE") == g.tags(ns="IMAGE_STRUCTURE")
        assert o.tags(ns="IMAGE_STRUCTURE")["LAYOUT"] == "COG"
        assert all(o.tags(b) == g.tags(b) for b in range(1, bands + 1))
        np.testing.assert_array_equal(o.read(), data)
        np.testing.assert_array_equal(g.read(), data)
        aligned = not factors or (height % factors[-1] == 0 and width % factors[-1] == 0)
        for k, f in enumerate(factors, start=1):
            shape = (bands, -(-height // f), -(-width // f))
            mine, empty = o.read(out_shape=shape), _empty(data, nodata, f)
            if aligned:
                _close(mine, g.read(out_shape=shape), empty, nodata, data.dtype, k, f"overview {f} against GDAL's")
            if k == 1:
                reference = mean_2x2(data.astype(float), nodata)
                if data.dtype.kind != "f":
                    reference = np.floor(reference + 0.5)  # integers rounded half up
                _close(mine, reference, empty, nodata, data.dtype, 0, "first overview against the 2 x 2 mean")
    dirs_o, dirs_g = read_directories(ours.read_bytes()), read_directories(gdal.read_bytes())
    assert len(dirs_o) == len(dirs_g) == len(factors) + 1
    for x, y in zip(dirs_o, dirs_g, strict=True):
        layout = (324, 325) if aligned or x is dirs_o[0] else (256, 257, 324, 325)  # the blocks; the sizes
        assert {c: t for c, t in x.items() if c not in layout} == {c: t for c, t in y.items() if c not in layout}


def check_strict_cog(path) -> None:
    """rio-cogeo's strict validation of a COG scangeo wrote with the default settings (warnings are errors:
    internal overviews above 512 cells among them)."""
    valid, errors, warns = cogeo.cog_validate(str(path), strict=True, quiet=True)
    assert valid and not errors and not warns, (path, errors, warns)


def check_written_cog(path) -> None:
    """An orthoimage, its layers or a mosaic scangeo wrote with the default settings: rio-cogeo's strict
    validation (:func:`check_strict_cog`), and its first overview level, if any, the 2 x 2 mean of the full
    resolution's valid cells (integers rounded half up, a valid mean never the nodata value)."""
    check_strict_cog(path)
    with rasterio.open(path) as src:
        if not src.overviews(1):
            return
        data, nodata = src.read(), src.nodata
        shape = (src.count, -(-src.height // 2), -(-src.width // 2))
        first = src.read(out_shape=shape)
    reference = mean_2x2(data.astype(float), nodata)
    empty = _empty(data, nodata, 2)
    if data.dtype.kind != "f":
        reference = np.floor(reference + 0.5)
        if nodata is not None:
            mean = mean_2x2(data.astype(float), nodata)
            hit = ~empty & (reference == nodata)
            reference[hit] = np.where(mean[hit] < nodata, nodata - 1, nodata + 1)
    _close(first, reference, empty, nodata, data.dtype, 0, f"{path}: first overview against the 2 x 2 mean")


def _nodata(dtype: str):
    if np.dtype(dtype).kind == "f":
        return st.sampled_from([None, -9999.0, float("nan")])
    return st.sampled_from([None, 0, int(np.iinfo(dtype).max)])


@st.composite
def cases(draw):
    dtype = draw(st.sampled_from(DTYPES))
    many = draw(st.booleans())
    bands = draw(st.integers(1, 224) if many else st.integers(1, 4))
    # GDAL's COG driver takes blocks of 128 cells and more
    blocksize = 128 if bands > 16 else draw(st.sampled_from([128, 256]))
    side = 160 if bands > 16 else 600  # a cube of many bands stays small (the suite's time budget)
    height, width = draw(st.integers(1, side)), draw(st.integers(1, side))
    if draw(st.booleans()):  # sizes multiples of the coarsest factor (8 at most here): GDAL's levels are ours
        height, width = -(-height // 8) * 8, -(-width // 8) * 8
    return dict(dtype=dtype, bands=bands, height=height, width=width,
                nodata=draw(_nodata(dtype)), blocksize=blocksize, overviews=draw(st.booleans()),
                tile_blocks=draw(st.sampled_from([1, 2, 4])), seed=draw(st.integers(0, 2**16)))


@settings(max_examples=25, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(case=cases())
@example(case=dict(dtype="uint16", bands=11, height=1100, width=700, nodata=0, blocksize=256, overviews=True,
                   tile_blocks=1, seed=1))  # the one larger case: three levels of 256-cell blocks
@example(case=dict(dtype="float32", bands=224, height=160, width=136, nodata=float("nan"), blocksize=128,
                   overviews=True, tile_blocks=1, seed=2))  # a cube: 224 bands, an overview level
@example(case=dict(dtype="int16", bands=3, height=512, width=384, nodata=0, blocksize=128, overviews=True,
                   tile_blocks=2, seed=4))  # sizes multiples of the coarsest factor: GDAL's AVERAGE levels
@example(case=dict(dtype="uint8", bands=1, height=1, width=1, nodata=None, blocksize=128, overviews=True,
                   tile_blocks=1, seed=3))  # one cell
def test_the_own_writer_agrees_with_gdals_cog_driver(tmp_path_factory, case):
    assert gdal_in_tested_range(), rasterio.__gdal_version__
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)
        check_case(tmp_path_factory.mktemp("cog"), **case)


def test_outside_the_tested_gdal_the_cog_driver_writes(monkeypatch, caplog):
    from scangeo.rectify import cog_writer
    from scangeo.rectify.geotiff import GeoTiffProfile

    assert gdal_in_tested_range()
    assert gdal_in_tested_range("3.9.3") and gdal_in_tested_range("3.10.0")
    assert not gdal_in_tested_range("3.11.0") and not gdal_in_tested_range("3.8.5")
    monkeypatch.setattr(cog_writer, "_noted", False)
    monkeypatch.setattr(rasterio, "__gdal_version__", "3.12.1")
    with caplog.at_level("INFO", logger="scangeo.rectify.cog_writer"):
        assert not GeoTiffProfile().scangeo_writes(np.uint16)
        assert not GeoTiffProfile().scangeo_writes(np.uint16)
    notes = [r.getMessage() for r in caplog.records if "outside the versions" in r.getMessage()]
    assert len(notes) == 1 and "GDAL 3.12.1" in notes[0] and "COG driver writes" in notes[0]


def test_a_layout_that_does_not_add_up_is_an_error_not_a_file(tmp_path, monkeypatch):
    from scangeo.rectify import cog_writer

    w = CogWriter(tmp_path / "spool", width=40, height=30, count=1, dtype=np.uint16, nodata=0, crs=CRS_,
                  transform=TRANSFORM, blocksize=16)
    w.write(np.ones((1, 30, 40), np.uint16), Window(0, 0, 40, 30))
    real = cog_writer._ifd_size
    monkeypatch.setattr(cog_writer, "_ifd_size", lambda tags, big: real(tags, big) + 2)
    with pytest.raises(cog_writer.CogLayoutError, match="a bug in scangeo's COG writer"):
        w.finish(tmp_path / "o.tif", tmp_path / ".o.tif.partial")
    assert sorted(p.name for p in tmp_path.iterdir()) == []
