"""rectify_strip on the analytic strip: geometry, nodata, occlusion, outputs, memory, atomicity."""
import tracemalloc

import cv2
import numpy as np
import pytest
import rasterio
from rectify_synthetic import AnalyticStrip, Texture, estimate_shift, flat, hills, make_dtm, render

from scangeo.errors import InputFileError, ScangeoError
from scangeo.rectify.geotiff import GeoTiffProfile
from scangeo.rectify.options import RectifyOptions
from scangeo.rectify.strip import rectify_strip
from scangeo.rectify.strip_run import choose_tile_size

TEX = Texture()


def strip_of(terrain=hills, **kw):
    dtm = make_dtm(terrain, 499_000, 501_000, 4_999_700, 5_001_000, 2.0)
    return AnalyticStrip(dtm, **kw)


def read(path, band=1):
    with rasterio.open(path) as d:
        return d.read(band).astype(float), d


@pytest.mark.parametrize("terrain, method", [(flat(300.0), "cubic"), (hills, "cubic"), (hills, "bilinear")])
def test_rectified_strip_matches_the_ground_texture(tmp_path, terrain, method):
    strip = strip_of(terrain, roll_amp=0.002)
    render(strip, TEX, tmp_path / "img.tif")
    r = rectify_strip(strip, tmp_path / "img.tif", tmp_path / "o.tif", RectifyOptions(resampling=method))
    o, _ = read(tmp_path / "o.tif")
    valid = np.isfinite(o)
    assert valid.sum() == r.valid_cells > 40_000
    mean, per = estimate_shift(o, r.grid, TEX, valid)
    assert np.all(np.abs(mean) < 0.02) and np.all(np.sqrt((per ** 2).mean(0)) < 0.05)
    assert r.stats.max_error_px <= 0.05
    # the analytic strip cannot refine: its ground_to_image is asked at every cell
    assert r.inverse_map_method == "exact" and r.stats.refined_cells == 0 and r.stats.exact_cells >= r.valid_cells


def test_nodata_outside_the_swath_where_the_dtm_has_none_and_at_source_nodata(tmp_path):
    strip = strip_of(flat(300.0))
    hole = (slice(200, 240), slice(440, 470))  # DTM rows/cols without heights (off nadir)
    strip.dtm.values[hole] = np.nan
    data = render(strip, TEX, tmp_path / "img.tif", dtype="uint16", nodata=0)
    data[:, 100:110, 50:60] = 0  # source nodata in all bands
    with rasterio.open(tmp_path / "img.tif", "r+") as d:
        d.write(data)
    r = rectify_strip(strip, tmp_path / "img.tif", tmp_path / "o.tif", RectifyOptions(resampling="bilinear"))
    o, d = read(tmp_path / "o.tif")
    assert d.nodata == 0
    rows, cols = np.indices(o.shape)
    x, y = r.grid.x_of_col(cols), r.grid.y_of_row(rows)
    line, pixel = strip.ground_to_image(x, y, strip.height(x, y))
    outside = ~((pixel >= -0.5) & (pixel <= strip.pixels - 0.5) & (line >= -0.5) & (line <= strip.lines - 0.5))
    assert outside.sum() > 1000 and (o[outside] == 0).all()
    no_dtm = np.isnan(strip.height(x, y))
    assert no_dtm.sum() > 100 and (o[no_dtm] == 0).all()
    hit = (line > 101) & (line < 108) & (pixel > 51) & (pixel < 58)
    assert hit.sum() > 10 and (o[hit] == 0).all()
    # the image has nodata where its rays fell into the DTM hole: cells next to it touch those
    near_hole = cv2.dilate(no_dtm.astype(np.uint8), np.ones((5, 5), np.uint8)).astype(bool)
    inside = ~outside & ~near_hole & ~((line > 98) & (line < 111) & (pixel > 48) & (pixel < 61))
    assert (o[inside & (pixel > 1) & (pixel < strip.pixels - 2) & (line > 1) & (line < strip.lines - 2)] > 0).all()


def mesa(X, Y):
    return np.where((X > 500_060) & (X < 500_100) & (Y > 5_000_100) & (Y < 5_000_500), 420.0, 300.0)


def test_ground_hidden_behind_a_cliff_is_nodata_not_smeared(tmp_path):
    strip = strip_of(mesa)
    render(strip, TEX, tmp_path / "img.tif")
    results = {}
    for occlusion in (True, False):
        r = rectify_strip(strip, tmp_path / "img.tif", tmp_path / f"o{occlusion}.tif",
                          RectifyOptions(occlusion=occlusion, resampling="bilinear"))
        results[occlusion] = (read(tmp_path / f"o{occlusion}.tif")[0], r)
    o, r = results[True]
    rows, cols = np.indices(o.shape)
    x, y = r.grid.x_of_col(cols), r.grid.y_of_row(rows)
    H = strip.height(x, y)
    hidden = np.zeros(o.shape, bool)  # truth: the ray to the sensor passes below the terrain
    for f in np.linspace(0.002, 1, 1500):
        hidden |= strip.height(x + f * (strip.xs - x), y) > H + f * (strip.Zs - H) + 1e-6
    line, pixel = strip.ground_to_image(x, y, H)
    seen = (pixel >= -0.5) & (pixel <= strip.pixels - 0.5) & (line >= -0.5) & (line <= strip.lines - 0.5)
    truth_visible = seen & ~hidden
    valid = np.isfinite(o)
    assert (seen & hidden).sum() > 1500 and r.hidden_cells >= (seen & hidden).sum()
    # nothing hidden is shown; a thin seam of visible cells at the mesa's ends is given up
    assert (valid & ~truth_visible).sum() == 0
    assert (~valid & truth_visible).sum() < 0.05 * (seen & hidden).sum()
    # without the occlusion test the hidden ground is filled with the mesa's texture (smeared)
    o_no, _ = results[False]
    smeared = np.abs(o_no - TEX(x, y))[seen & hidden]
    assert np.median(smeared) > 100 and np.isfinite(o_no[seen & hidden]).all()


def steep(X, Y):
    """Hills of +-150 m at a 380 m wavelength: slopes up to 68 deg, nothing hidden from the strip's rays."""
    return 300 + 150 * np.sin(X / 60.0) * np.cos(Y / 90.0)


@pytest.mark.parametrize("terrain", [steep, mesa])
def test_cells_finer_than_the_pixels_hide_only_hidden_ground(tmp_path, terrain):
    """A grid three times finer than the pixels (a coarse sensor on a platform's finest grid): the cells of one
    pixel on a slope differ in range by the pixel's range change; the z-buffer's tolerance covers it (it hid
    6.4 % of the visible ground of the whole strip on these hills when it covered two cells' change only)."""
    strip = strip_of(terrain)
    render(strip, TEX, tmp_path / "img.tif")
    bounds = (499_850.0, 5_000_050.0, 500_150.0, 5_000_550.0)
    r = rectify_strip(strip, tmp_path / "img.tif", tmp_path / "o.tif",
                      RectifyOptions(resolution=0.7, bounds=bounds, resampling="bilinear"))
    o, _ = read(tmp_path / "o.tif")
    rows, cols = np.indices(o.shape)
    x, y = r.grid.x_of_col(cols), r.grid.y_of_row(rows)
    H = strip.height(x, y)
    hidden = np.zeros(o.shape, bool)  # truth: the ray to the sensor passes below the terrain (all below 450 m)
    for f in np.linspace(0.001, (450.0 - 300.0) / (strip.Zs - 300.0), 600):
        hidden |= strip.height(x + f * (strip.xs - x), y) > H + f * (strip.Zs - H) + 1e-6
    line, pixel = strip.ground_to_image(x, y, H)
    seen = (pixel >= -0.5) & (pixel <= strip.pixels - 0.5) & (line >= -0.5) & (line <= strip.lines - 0.5)
    visible, valid = seen & ~hidden, np.isfinite(o)
    assert visible.sum() > 100_000
    if terrain is steep:
        assert hidden.sum() == 0 and (~valid & visible).sum() < 1e-4 * visible.sum()
    else:  # the mesa's shadows stay hidden; a thin seam at its ends is given up
        assert (seen & hidden).sum() > 5000 and (~valid & visible).sum() < 0.05 * (seen & hidden).sum()
        # shown though hidden: a handful of cells on the DTM's ramp at the mesa's corners (mixed pixels: the
        # ray passes a few decimetres below the corner), none farther than a DTM post from its outline
        shown = valid & ~visible
        corner = np.minimum(np.abs(x - 500_060) + np.abs(y - 5_000_100), np.abs(x - 500_100) + np.abs(y - 5_000_100))
        corner = np.minimum(corner, np.minimum(np.abs(x - 500_060) + np.abs(y - 5_000_500),
                                               np.abs(x - 500_100) + np.abs(y - 5_000_500)))
        assert shown.sum() <= 3 and (corner[shown] < 2.0).all()
    if terrain is steep:
        assert (valid & ~visible).sum() == 0


def test_outputs_layers_glt_metadata_and_cog_layout(tmp_path):
    strip = strip_of(hills, roll_amp=0.002)
    render(strip, TEX, tmp_path / "img.tif", bands=4, dtype="uint16")
    layers = ("scan_angle", "view_zenith", "time", "ground_pixel", "image_line", "image_pixel")
    opts = RectifyOptions(resolution=2.0, layers=layers, glt=True,
                          geotiff=GeoTiffProfile(blocksize=128, overviews=True))
    r = rectify_strip(strip, tmp_path / "img.tif", tmp_path / "o.tif", opts,
                      tags={"variant": "P4", "sigma0": "0.93"})
    with rasterio.open(tmp_path / "o.tif") as d:
        assert d.count == 4 and d.dtypes[0] == "uint16" and d.nodata == 0
        assert d.descriptions == ("channel 1", "channel 2", "channel 3", "channel 4")
        assert float(d.tags(2)["wavelength"]) == 500.0 and d.tags(2)["wavelength_units"] == "nm"
        tags = d.tags()
        assert tags["variant"] == "P4" and tags["sigma0"] == "0.93" and tags["scangeo_version"]
        assert float(tags["inverse_map_max_error_px"]) <= 0.05
        assert d.tags(ns="IMAGE_STRUCTURE").get("LAYOUT") == "COG"
        assert d.profile["compress"] == "deflate" and d.block_shapes[0] == (128, 128) and d.overviews(1)
        assert d.res == (2.0, 2.0) and d.transform.c % 2.0 == 0 and d.transform.f % 2.0 == 0
        o = d.read(1).astype(float)
    with rasterio.open(r.layers_path) as lay:
        assert lay.tags()["layers"].split() == list(layers)
        L = {n: lay.read(i + 1).astype(float) for i, n in enumerate(layers)}
        t0 = float(lay.tags()["time_origin_s"])
    valid = o != 0
    assert (np.isfinite(L["scan_angle"]) == valid).all()
    rows, cols = np.indices(o.shape)
    x, y = r.grid.x_of_col(cols), r.grid.y_of_row(rows)
    H = strip.height(x, y)
    el, ep = strip.ground_to_image(x, y, H)
    assert np.nanmax(np.abs(L["image_line"] - el)[valid]) < 0.05
    assert np.nanmax(np.abs(L["image_pixel"] - ep)[valid]) < 0.05
    assert np.allclose(L["scan_angle"][valid], np.degrees(strip.scan_angle(ep[valid])), atol=0.01)
    assert np.allclose(L["time"][valid] + t0, strip.time(el[valid], ep[valid]), atol=2e-3)
    vz = np.degrees(np.arctan2(np.abs(x - strip.xs), strip.Zs - H))
    dvz = np.abs(L["view_zenith"] - vz)[valid]
    assert np.nanmax(dvz) < 0.01, (np.nanmax(dvz), np.isnan(dvz).sum())
    # ground pixel: flat-ground size at nadir is (Zs - H) * step across, speed / rate along
    gp = L["ground_pixel"]
    nadir = valid & (np.abs(ep - (strip.pixels - 1) / 2) < 3)
    expect = np.sqrt((strip.Zs - H) * strip.step * strip.dy)
    assert np.nanmedian(np.abs(gp - expect)[nadir]) < 0.05 * np.nanmedian(expect[nadir])
    with rasterio.open(r.glt_path) as glt:
        sample, gline = glt.read(1), glt.read(2)
        assert glt.crs is not None and glt.transform == r.grid.transform
    assert (sample[valid] == np.rint(ep[valid]) + 1).mean() > 0.99 and (gline[~valid] == 0).all()
    assert (gline[valid] == np.rint(el[valid]) + 1).mean() > 0.99


def test_memory_stays_within_the_budget(tmp_path):
    """A strip whose image alone is larger than the budget, rectified in tiles (numpy allocations)."""
    dtm = make_dtm(flat(300.0), 498_000, 502_000, 4_999_000, 5_006_000, 4.0)
    strip = AnalyticStrip(dtm, lines=2400, pixels=400, Zs=1500.0, step=0.0017)
    render(strip, TEX, tmp_path / "img.tif", bands=8, dtype="float32")  # 2400 x 400 x 8 x 4 B = 31 MB
    budget_mb = 64
    opts = RectifyOptions(resolution=2.5, memory_budget_mb=budget_mb)
    tracemalloc.start()
    r = rectify_strip(strip, tmp_path / "img.tif", tmp_path / "o.tif", opts)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    print(f"tile {r.tile_size}, grid {r.grid.width} x {r.grid.height}, peak {peak / 2**20:.1f} MiB")
    assert r.tile_size < max(r.grid.width, r.grid.height)
    assert peak < budget_mb * 2**20


def test_a_failure_leaves_no_output_and_no_partial_file(tmp_path):
    strip = strip_of(flat(300.0))
    render(strip, TEX, tmp_path / "img.tif")
    calls = {"n": 0}
    original = strip.ground_to_image

    def failing(x, y, H):
        calls["n"] += 1
        if calls["n"] > 3:
            raise RuntimeError("killed")
        return original(x, y, H)

    strip.ground_to_image = failing
    with pytest.raises(RuntimeError):
        rectify_strip(strip, tmp_path / "img.tif", tmp_path / "o.tif", RectifyOptions(tile_size=64))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["img.tif"]


def test_bad_input_is_named(tmp_path):
    strip = strip_of(flat(300.0))
    render(strip, TEX, tmp_path / "img.tif")
    small = strip_of(flat(300.0), lines=100)
    with pytest.raises(InputFileError, match="img.tif: image has 300 lines x 200 pixels"):
        rectify_strip(small, tmp_path / "img.tif", tmp_path / "o.tif")
    with pytest.raises(InputFileError, match="missing.tif"):
        rectify_strip(strip, tmp_path / "missing.tif", tmp_path / "o.tif")
    with pytest.raises(ScangeoError, match="RectifyOptions.resampling: expected one of nearest, bilinear, cubic, "
                                           "found 'lanczos'"):
        RectifyOptions(resampling="lanczos")
    with pytest.raises(ScangeoError, match=r"RectifyOptions.layers: expected a list of strings \(one of scan_angle"):
        RectifyOptions(layers=("slope",))
    long = strip_of(flat(300.0), lines=5000, pixels=1000)  # its z-buffer alone needs 19 MiB
    with pytest.raises(ScangeoError, match="budget of 16 MiB is too small"):
        choose_tile_size(RectifyOptions(memory_budget_mb=16), long, bands=11, itemsize=2, resolution=2.5)
