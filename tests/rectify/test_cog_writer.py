"""scangeo's own COG writer against GDAL's COG driver: the same file for every reader but the
compressed bytes (pixels, overviews, georeferencing, metadata, directories), and the COG layout."""
from __future__ import annotations

import struct

import numpy as np
import pytest
import rasterio
from affine import Affine
from rasterio.crs import CRS
from rasterio.windows import Window

import scangeo.rectify.cog_writer as cog_writer
from scangeo.rectify.cog_writer import CogWriter, read_directories
from scangeo.rectify.geotiff import BandInfo, GeoTiffProfile, describe, finalise, overview_factors

CRS_ = CRS.from_epsg(32633)
TRANSFORM = Affine(2.5, 0, 595640.0, 0, -2.5, 5351907.5)


def image(shape, dtype, seed=1):
    rng = np.random.default_rng(seed)
    info = np.iinfo(dtype) if np.issubdtype(dtype, np.integer) else None
    if info is None:
        a = rng.normal(100.0, 30.0, size=shape).astype(dtype)
    else:
        lo, hi = max(info.min, -3000), min(info.max, 4000)
        a = rng.integers(lo, hi, size=shape).astype(dtype)
    a[:, :40, :70] = 0  # a nodata corner
    return a


def by_gdal(tmp_path, data, nodata, profile, bands, tags):
    count, height, width = data.shape
    work = tmp_path / "work.tif"
    with rasterio.open(work, "w", driver="GTiff", width=width, height=height, count=count, dtype=data.dtype.name,
                       crs=CRS_, transform=TRANSFORM, nodata=nodata, tiled=True, blockxsize=256, blockysize=256) as d:
        d.write(data)
        describe(d, bands, tags)
    out = tmp_path / "gdal.tif"
    finalise(work, out, profile, data.dtype)
    return out


def by_scangeo(tmp_path, data, nodata, profile, bands, tags, tile=256, seed=0):
    """Tiles of ``tile`` cells written in a random order."""
    count, height, width = data.shape
    factors = overview_factors(width, height, profile.blocksize) if profile.wants_overviews(width, height) else []
    w = CogWriter(tmp_path / "spool", width=width, height=height, count=count, dtype=data.dtype, nodata=nodata,
                  crs=CRS_, transform=TRANSFORM, blocksize=profile.blocksize, factors=factors,
                  compress=profile.compress, predictor=profile.predictor, threads=2)
    windows = [Window(c, r, min(tile, width - c), min(tile, height - r))
               for r in range(0, height, tile) for c in range(0, width, tile)]
    for i in np.random.default_rng(seed).permutation(len(windows)):
        win = windows[i]
        r, c = int(win.row_off), int(win.col_off)
        w.write(data[:, r:r + int(win.height), c:c + int(win.width)].copy(), win)
    out = tmp_path / "own.tif"
    w.finish(out, tmp_path / ".own.tif.partial", lambda dst: describe(dst, bands, tags))
    assert not (tmp_path / "spool").exists()
    return out


def layout_problems(path) -> list[str]:
    """What keeps ``path`` from the COG layout GDAL's validator checks: directories before the
    data, the smallest level's blocks first, row-major blocks, each with its size before and its last
    4 bytes after."""
    raw = path.read_bytes()
    dirs = read_directories(raw)
    problems = []
    first_block = min(min(d[324].values()) for d in dirs)
    big = raw[2] == 43
    at = struct.unpack_from("<Q" if big else "<I", raw, 8 if big else 4)[0]
    ifd_offsets = []
    while at:
        ifd_offsets.append(at)
        n = struct.unpack_from("<Q" if big else "<H", raw, at)[0]
        at = struct.unpack_from("<Q" if big else "<I", raw, at + (8 + 20 * n if big else 2 + 12 * n))[0]
    if ifd_offsets != sorted(ifd_offsets) or max(ifd_offsets) > first_block:
        problems.append("directories not all before the data")
    previous_start = None
    for d in dirs:  # full resolution first: its blocks must come after every overview's
        offsets, counts = d[324].values(), d[325].values()
        if list(offsets) != sorted(offsets):
            problems.append("blocks of a level not in row-major order")
        if previous_start is not None and max(offsets) > previous_start:
            problems.append("a level's blocks after those of a finer level")
        previous_start = min(offsets)
        for o, n in zip(offsets, counts, strict=True):
            if struct.unpack_from("<I", raw, o - 4)[0] != n or raw[o + n:o + n + 4] != raw[o + n - 4:o + n]:
                problems.append(f"block at {o}: leader or trailer wrong")
                break
    return problems


def same_for_readers(a, b):
    with rasterio.open(a) as g, rasterio.open(b) as o:
        assert g.profile == o.profile
        assert g.tags() == o.tags()
        assert g.tags(ns="IMAGE_STRUCTURE") == o.tags(ns="IMAGE_STRUCTURE")
        assert o.tags(ns="IMAGE_STRUCTURE")["LAYOUT"] == "COG"
        assert g.descriptions == o.descriptions
        assert all(g.tags(i) == o.tags(i) for i in range(1, g.count + 1))
        assert g.overviews(1) == o.overviews(1)
        np.testing.assert_array_equal(g.read(), o.read())
        for f in g.overviews(1):
            shape = (g.count, -(-g.height // f), -(-g.width // f))
            np.testing.assert_array_equal(g.read(out_shape=shape), o.read(out_shape=shape))
    dg, do = read_directories(a.read_bytes()), read_directories(b.read_bytes())
    assert len(dg) == len(do)
    for x, y in zip(dg, do, strict=True):
        assert sorted(x) == sorted(y)
        layout = (324, 325)  # the blocks' offsets and sizes
        assert {c: t for c, t in x.items() if c not in layout} == {c: t for c, t in y.items() if c not in layout}


BANDS = [BandInfo("blue", 485.0, "nm"), BandInfo("green", 560.0, "nm"), BandInfo("thermal")]
TAGS = {"TIFFTAG_SOFTWARE": "scangeo test", "variant": "SE", "sigma0": 1.25}


@pytest.mark.parametrize("dtype, predictor, compress", [
    (np.uint16, True, "deflate"), (np.int16, True, "deflate"), (np.uint8, True, "deflate"),
    (np.float32, False, "deflate"), (np.float32, True, "deflate"), (np.float64, True, "deflate"),
    (np.uint16, False, "deflate"), (np.uint16, False, "none"),
])
def test_the_same_file_as_gdals_cog_driver_but_for_the_compressed_bytes(tmp_path, dtype, predictor, compress):
    data = image((3, 1100, 700), dtype)
    profile = GeoTiffProfile(blocksize=256, overviews=True, predictor=predictor, compress=compress, writer="gdal")
    ours = by_scangeo(tmp_path, data, 0, profile, BANDS, TAGS)
    gdal = by_gdal(tmp_path, data, 0, profile, BANDS, TAGS)
    same_for_readers(gdal, ours)
    assert layout_problems(ours) == []
    assert layout_problems(gdal) == []  # the check itself holds GDAL's own COG
    with rasterio.open(ours) as o:
        assert o.overviews(1) == [2, 4, 8]
        assert o.nodata == 0


def test_a_working_file_finalised_by_either_writer(tmp_path):
    """The mosaic's and GDAL-written working files' route (geotiff.finalise), with band tags beyond
    the wavelengths."""
    data = image((2, 1500, 900), np.uint16, seed=5)
    profile = GeoTiffProfile(blocksize=256, overviews=True, writer="gdal")
    gdal = by_gdal(tmp_path, data, 0, profile, [BandInfo("a", 1.0, "um"), BandInfo("b")], {"strip": "mosaic"})
    with rasterio.open(tmp_path / "work.tif", "r+") as d:
        d.update_tags(2, view="nadir")
    gdal.unlink()
    finalise(tmp_path / "work.tif", gdal, profile, np.uint16)
    ours = tmp_path / "ours.tif"
    finalise(tmp_path / "work.tif", ours, GeoTiffProfile(blocksize=256, overviews=True), np.uint16)
    same_for_readers(gdal, ours)
    assert layout_problems(ours) == []
    with rasterio.open(ours) as o:
        assert o.tags(2)["view"] == "nadir" and o.tags(1)["wavelength_units"] == "um"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["gdal.tif", "ours.tif", "work.tif"]


def test_tiles_smaller_and_larger_than_the_blocks_and_a_bigtiff(tmp_path, monkeypatch):
    data = image((2, 900, 1300), np.uint16, seed=3)
    profile = GeoTiffProfile(blocksize=256, overviews=True, writer="gdal")
    gdal = by_gdal(tmp_path, data, 0, profile, [], {})
    for tile in (64, 512):
        (tmp_path / str(tile)).mkdir()
        same_for_readers(gdal, by_scangeo(tmp_path / str(tile), data, 0, profile, [], {}, tile=tile, seed=tile))
    monkeypatch.setattr(cog_writer, "CLASSIC_LIMIT", 1000)
    (tmp_path / "big").mkdir()
    big = by_scangeo(tmp_path / "big", data, 0, profile, [], {})
    assert big.read_bytes()[2] == 43  # BigTIFF
    assert layout_problems(big) == []
    with rasterio.open(big) as o:
        np.testing.assert_array_equal(o.read(), data)
        assert o.overviews(1) == [2, 4, 8]


def test_blocks_no_tile_touched_are_nodata_and_a_block_cannot_be_written_twice(tmp_path):
    w = CogWriter(tmp_path / "spool", width=600, height=300, count=1, dtype=np.uint16, nodata=7, crs=CRS_,
                  transform=TRANSFORM, blocksize=256, threads=1)
    tile = np.full((1, 256, 256), 1000, np.uint16)
    w.write(tile, Window(0, 0, 256, 256))
    with pytest.raises(ValueError, match="written twice"):
        w.write(tile, Window(0, 0, 256, 256))
    w.write(tile[:, :44, :100], Window(0, 256, 100, 44))  # part of a block: the rest stays nodata
    w.finish(tmp_path / "o.tif", tmp_path / ".o.tif.partial")
    with rasterio.open(tmp_path / "o.tif") as o:
        a = o.read(1)
    assert (a[:256, :256] == 1000).all()
    assert (a[256:, :100] == 1000).all()
    assert (a[256:, 100:] == 7).all() and (a[:256, 256:] == 7).all()


def test_a_writer_that_fails_or_is_closed_leaves_nothing(tmp_path, monkeypatch):
    data = image((1, 300, 300), np.uint16)

    def broken(*args):
        raise OSError("disk full")

    monkeypatch.setattr(cog_writer, "_copy", broken)
    w = CogWriter(tmp_path / "spool", width=300, height=300, count=1, dtype=np.uint16, nodata=0, crs=CRS_,
                  transform=TRANSFORM, blocksize=256)
    w.write(data, Window(0, 0, 300, 300))
    with pytest.raises(OSError, match="disk full"):
        w.finish(tmp_path / "o.tif", tmp_path / ".o.tif.partial")
    assert sorted(p.name for p in tmp_path.iterdir()) == []
    w = CogWriter(tmp_path / "spool", width=300, height=300, count=1, dtype=np.uint16, nodata=0, crs=CRS_,
                  transform=TRANSFORM, blocksize=256)
    w.write(data, Window(0, 0, 300, 300))
    w.close()
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_which_outputs_scangeo_writes_itself():
    assert GeoTiffProfile().scangeo_writes(np.uint16)
    assert GeoTiffProfile(level=1).scangeo_writes(np.uint16)
    # the level is GDAL's on both routes: the own writer encodes level 1 only, GDAL's libdeflate the others
    assert not GeoTiffProfile(level=3).scangeo_writes(np.uint16)
    assert not GeoTiffProfile(level=6).scangeo_writes(np.uint16)
    assert GeoTiffProfile().scangeo_writes(np.float32)  # with the floating-point predictor (3)
    assert GeoTiffProfile(predictor=False).scangeo_writes(np.float32)
    assert not GeoTiffProfile(compress="zstd").scangeo_writes(np.uint16)
    assert not GeoTiffProfile(cog=False).scangeo_writes(np.uint16)
    assert not GeoTiffProfile(writer="gdal").scangeo_writes(np.uint16)
    assert GeoTiffProfile(threads="3").thread_count() == 3
    from scangeo.errors import RectifyOptionsError

    with pytest.raises(RectifyOptionsError, match="writer"):
        GeoTiffProfile(writer="tifffile")
    with pytest.raises(RectifyOptionsError, match="threads"):
        GeoTiffProfile(threads="many")


def test_blocks_of_a_cube_of_many_bands_stay_small():
    """A pixel-interleaved block holds every band: for 182 bands of float32 the 512-cell block would
    be 191 MB; the profile for such an image halves the block size until a block is 16 MiB at most."""
    profile = GeoTiffProfile()
    assert profile.for_image(11, np.uint16) is profile  # 5.8 MB blocks: unchanged
    cube = profile.for_image(182, np.float32)
    assert cube.blocksize == 128 and 182 * 128 * 128 * 4 <= 16 * 2**20
    assert GeoTiffProfile(blocksize=256).for_image(4000, np.float64).blocksize == 64  # never below 64


def test_lossy_lerc_is_named_lossy_and_keeps_its_error(tmp_path):
    """compress = "lerc-lossy" needs its max error and keeps every value within it; never the default."""
    from rio_cogeo.cogeo import cog_validate

    from scangeo.errors import RectifyOptionsError

    assert GeoTiffProfile().compress == "deflate" and GeoTiffProfile().lossy_max_error is None
    with pytest.raises(RectifyOptionsError, match="lossy_max_error"):
        GeoTiffProfile(compress="lerc-lossy")
    with pytest.raises(RectifyOptionsError, match="lerc-lossy"):
        GeoTiffProfile(lossy_max_error=0.01)
    profile = GeoTiffProfile(compress="lerc-lossy", lossy_max_error=0.05, blocksize=256, overviews=True)
    assert not profile.scangeo_writes(np.float32)  # GDAL's driver writes LERC
    assert profile.lossless().compress == "deflate"
    data = image((3, 700, 600), np.float32)
    out = by_gdal(tmp_path, data, 0.0, profile, [BandInfo(f"b{i}") for i in range(3)], {})
    valid, errors, _ = cog_validate(str(out), strict=True)
    assert valid, errors
    with rasterio.open(out) as src:
        back = src.read()
        assert src.compression is not None and src.compression.name.lower() == "lerc"
    worst = float(np.max(np.abs(back.astype(np.float64) - data)))
    ulp = float(np.spacing(np.abs(data).max()))  # LERC's bound, then the float32 rounding of its result
    assert 0.0 < worst <= 0.05 + ulp  # lossy, within the bound
    assert out.stat().st_size < 0.8 * data.nbytes
