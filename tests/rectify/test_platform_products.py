"""A platform's products line up: its sensors on one lattice at the finest sensor's resolution, a mosaic per
sensor, a VRT per flight line with both sensors' bands, the co-registration layer interpolated from
coregistration.json, every COG strictly valid, the STAC items and the report's table; a one-sensor project's
outputs as before (tests/rectify/platform_block.py: sensor b has pixels twice as large as a's both ways)."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
import rasterio
from scipy.interpolate import RegularGridInterpolator

import scangeo
from scangeo.adjustment.outputs import COREGISTRATION_FILE
from scangeo.errors import InputFileError
from scangeo.io.project import Project
from scangeo.orientation.file import load_orientation
from scangeo.rectify.batch import rectify_project
from scangeo.rectify.core_geometry import CoreStripGeometry
from scangeo.rectify.coregistration_layer import SCHEMA, CoregistrationGrid, read_coregistration
from scangeo.rectify.geometry import nadir_ground_pixel
from scangeo.rectify.options import RectifyOptions
from scangeo.rectify.output_grid import nice_resolution
from scangeo.rectify.platform_products import COREGISTRATION_FILE as READ_NAME
from scangeo.reports.coregistration_section import coregistration_section
from scangeo.reports.stac import write_stac_items
from scangeo.reports.stac_validation import validate_items
from tests.rectify.platform_block import B_BANDS, make_platform
from tests.rectify.test_cog_properties import check_written_cog
from tests.session_projects import copy_project

STRIPS = ("01", "b01", "02", "b02")
OPTIONS = RectifyOptions(layers=("image_line", "image_pixel"))


@pytest.fixture(scope="module")
def platform(small_block, tmp_path_factory):
    """The platform adjusted with SE_B (coregistration.json written) and rectified at the default resolution."""
    root = make_platform(small_block, tmp_path_factory.mktemp("platform") / "p")
    scangeo.adjust(root, "SE_B")
    return root, rectify_project(root, "SE_B", options=OPTIONS)


def _grid(path):
    with rasterio.open(path) as src:
        return src.crs, src.transform, src.shape


def test_the_sensors_are_rectified_onto_one_lattice_at_the_finest_sensors_pixel(platform):
    root, result = platform
    project = Project.load(root)
    source = load_orientation(project, "SE_B")
    nadir = {sid: nadir_ground_pixel(CoreStripGeometry(source.geometry(sid), project.dtm)) for sid in ("01", "b01")}
    assert 1.9 < nadir["b01"] / nadir["01"] < 2.1  # b's pixels are twice a's
    assert result.resolution == nice_resolution(nadir["01"]) and result.resolution_source == "finest sensor a"
    crs = None
    for sid in STRIPS:
        for path in (result.folder / f"{sid}.tif", result.folder / f"{sid}.layers.tif"):
            c, t, _ = _grid(path)
            crs = crs or c
            assert c == crs and t.a == -t.e == result.resolution and t.b == t.d == 0.0
            # every cell edge on a multiple of the resolution: the cells of all strips coincide
            for edge in (t.c, t.f):
                assert abs(edge / result.resolution - round(edge / result.resolution)) < 1e-9
    for sid in ("b01", "b02"):  # the layer on its orthoimage's grid
        assert _grid(result.folder / f"{sid}.coregistration.tif") == _grid(result.folder / f"{sid}.tif")
    assert result.mosaic is None and set(result.mosaics) == {"a", "b"}
    for sensor, bands in (("a", 11), ("b", len(B_BANDS))):
        path = result.folder / f"mosaic-{sensor}.tif"
        assert result.mosaics[sensor] == path
        with rasterio.open(path) as src:
            assert src.count == bands and src.tags()["sensor"] == sensor and src.transform.a == result.resolution
    assert not (result.folder / "mosaic.tif").exists()


def test_a_flight_lines_vrt_stacks_both_sensors_bands_cell_for_cell(platform):
    _, result = platform
    assert set(result.stacks) == {"L01", "L02"}
    for fid, (a, b) in (("L01", ("01", "b01")), ("L02", ("02", "b02"))):
        vrt = result.stacks[fid]
        assert vrt == result.folder / f"{fid}.vrt"
        with rasterio.open(vrt) as stack, rasterio.open(result.folder / f"{a}.tif") as sa, \
                rasterio.open(result.folder / f"{b}.tif") as sb:
            assert stack.count == sa.count + sb.count == 11 + len(B_BANDS)
            assert stack.crs == sa.crs == sb.crs and stack.res == sa.res == sb.res
            names = [f"a: {n}" for n in sa.descriptions] + [f"b: {n}" for n in B_BANDS]
            assert list(stack.descriptions) == names
            first_b = stack.tags(12)
            assert first_b["sensor"] == "b" and first_b["strip"] == b and first_b["band"] == "swir1"
            assert stack.tags(1)["wavelength"] == "435.0" and stack.tags()["flight_line"] == fid
            assert all(v == 0 for v in stack.nodatavals)
            # the union of the two grids
            left, bottom = min(sa.bounds.left, sb.bounds.left), min(sa.bounds.bottom, sb.bounds.bottom)
            right, top = max(sa.bounds.right, sb.bounds.right), max(sa.bounds.top, sb.bounds.top)
            assert np.allclose(stack.bounds, (left, bottom, right, top), atol=1e-6)
            cube = stack.read()
            assert cube.dtype == np.uint16  # uint8 and uint16 stacked in uint16
            for src, bands in ((sa, slice(0, sa.count)), (sb, slice(sa.count, None))):
                values = src.read()
                row0, col0 = stack.index(src.bounds.left + 0.5 * src.res[0], src.bounds.top - 0.5 * src.res[1])
                h, w = src.shape
                inside = cube[bands, row0:row0 + h, col0:col0 + w]
                assert np.array_equal(inside, values)  # every cell of the strip, at the same map position
                outside = cube[bands].copy()
                outside[:, row0:row0 + h, col0:col0 + w] = 0
                assert not outside.any()  # nodata beyond the strip's grid
            # one map position, looked up in each file by its coordinates
            x, y = sb.xy(sb.height // 2, sb.width // 3)
            r, c = stack.index(x, y)
            ra, ca = sa.index(x, y)
            rb, cb = sb.index(x, y)
            assert list(cube[:, r, c]) == list(sa.read()[:, ra, ca]) + list(sb.read()[:, rb, cb])


def test_the_coregistration_layer_is_the_grids_interpolation_at_each_cells_line_and_pixel(platform):
    root, result = platform
    entries = read_coregistration(root / "results" / "SE_B" / COREGISTRATION_FILE)
    assert set(entries) == {"b01", "b02"} and set(result.coregistration) == {"b01", "b02"}
    for sid in ("b01", "b02"):
        e = entries[sid]
        assert e["reference"] == sid[1:] and result.coregistration[sid]["reference"] == sid[1:]
        assert result.coregistration[sid]["median_m"] == e["median_m"] and e["median_m"] > 0
        rows, cols = e["grid"]
        assert len(e["sigma_m"]) == rows * cols  # every position propagated here (b sees what a sees)
        line_axis, pixel_axis = np.linspace(0, 99, rows), np.linspace(0, 49, cols)
        sigma = np.full((rows, cols), np.nan)
        sigma[np.round(np.array(e["line"]) / (99 / (rows - 1))).astype(int),
              np.round(np.array(e["pixel"]) / (49 / (cols - 1))).astype(int)] = e["sigma_m"]
        interpolate = RegularGridInterpolator((line_axis, pixel_axis), sigma)
        with rasterio.open(result.folder / f"{sid}.coregistration.tif") as co, \
                rasterio.open(result.folder / f"{sid}.layers.tif") as lay:
            assert co.count == 1 and co.dtypes[0] == "float32" and math.isnan(co.nodata)
            assert co.descriptions[0] == "coregistration_sigma_m" and co.tags()["coregistration_reference"] == sid[1:]
            layer = co.read(1)
            line, pixel = lay.read(1), lay.read(2)
        seen = np.isfinite(line)
        assert seen.sum() > 5000 and np.array_equal(np.isfinite(layer), seen)
        expected = interpolate(np.column_stack([np.clip(line[seen], 0, 99), np.clip(pixel[seen], 0, 49)]))
        assert np.allclose(layer[seen], expected, rtol=0, atol=1e-5)
        assert np.nanmin(sigma) - 1e-6 <= layer[seen].min() and layer[seen].max() <= np.nanmax(sigma) + 1e-6


def _entry(rows=3, cols=4, lines=21, pixels=31, drop=()):
    """A coregistration.json entry whose sigma is linear in line and pixel (bilinear interpolation: exact)."""
    L, X = np.meshgrid(np.linspace(0, lines - 1, rows), np.linspace(0, pixels - 1, cols), indexing="ij")
    keep = np.ones(L.size, bool)
    keep[list(drop)] = False
    s = 0.5 + 0.01 * L + 0.002 * X
    return {"strip": "s", "reference": "r", "flight_line": "L", "grid": [rows, cols], "line": L.ravel()[keep].tolist(),
            "pixel": X.ravel()[keep].tolist(), "sigma_m": s.ravel()[keep].tolist(), "median_m": 0.6, "max_m": 0.76}


def test_a_grid_cell_with_a_position_left_out_is_nan_and_the_others_exact():
    line, pixel = np.meshgrid(np.arange(-0.5, 20.6, 0.25), np.arange(-0.5, 30.6, 0.5), indexing="ij")
    full = CoregistrationGrid.from_entry(_entry(), 21, 31, "test")
    truth = 0.5 + 0.01 * np.clip(line, 0, 20) + 0.002 * np.clip(pixel, 0, 30)
    assert np.allclose(full.values(line, pixel), truth, atol=1e-6)  # outer half-pixels: the edge's values
    # position (1, 2) of the 3 x 4 grid (line 10, pixel 20) missing: the four grid cells around it are NaN
    holed = CoregistrationGrid.from_entry(_entry(drop=[1 * 4 + 2]), 21, 31, "test").values(line, pixel)
    around = (line > 0) & (line < 20) & (pixel > 10) & (pixel < 30)
    assert np.isnan(holed[around]).all()
    assert np.allclose(holed[~around & (pixel < 10)], truth[~around & (pixel < 10)], atol=1e-6)
    assert np.isnan(full.values(np.array([np.nan]), np.array([3.0]))).all()


@pytest.mark.parametrize("edit, message", [
    (lambda e: e.update(grid=[3]), "'grid': expected [rows, columns]"),
    (lambda e: e.update(line=e["line"][:-1]), "differ in length"),
    (lambda e: e["line"].__setitem__(0, 3.3), "position 0 (line 3.3, pixel 0) is not on the 3 x 4 grid"),
    (lambda e: e["sigma_m"].__setitem__(0, -1.0), "'sigma_m': expected finite numbers >= 0"),
    (lambda e: e.update(median_m="x"), "'median_m': expected a number"),
])
def test_a_bad_entry_is_refused_naming_the_key(edit, message):
    entry = _entry()
    edit(entry)
    with pytest.raises(InputFileError, match="coregistration.json strip s") as err:
        CoregistrationGrid.from_entry(entry, 21, 31, "coregistration.json strip s")
    assert message in str(err.value)


def test_a_coregistration_file_of_another_schema_is_refused(tmp_path):
    path = tmp_path / "coregistration.json"
    path.write_text(json.dumps({"schema": "scangeo.coregistration/9", "strips": []}))
    with pytest.raises(InputFileError, match=r"coregistration.json 'schema': expected 'scangeo.coregistration/1'"):
        read_coregistration(path)
    path.write_text(json.dumps({"schema": SCHEMA, "strips": [{"strip": "b01"}]}))
    with pytest.raises(InputFileError, match=r"strips\[0\]: expected a table with 'strip' and 'reference'"):
        read_coregistration(path)
    assert READ_NAME == COREGISTRATION_FILE  # the name rectify reads is the one the adjustment writes


def test_every_output_is_a_strictly_valid_cog_and_the_stac_items_carry_the_coregistration(platform, no_network):
    root, result = platform
    tifs = sorted(p for p in result.folder.glob("*.tif"))
    assert len(tifs) == 4 + 4 + 2 + 2  # orthoimages, layers, co-registration layers, mosaics
    for path in tifs:
        check_written_cog(path)
    rasters = [result.folder / f"{sid}.tif" for sid in STRIPS] + list(result.mosaics.values())
    items = write_stac_items(root, "SE_B", rasters, coregistration=result.coregistration)
    assert all(schemas for schemas in validate_items(items).values())
    doc = {p.name: json.loads(p.read_text()) for p in items}
    b01 = doc["b01.stac.json"]
    assert b01["properties"]["scangeo:sensor"] == "b" and b01["properties"]["scangeo:flight_line"] == "L01"
    assert b01["properties"]["scangeo:coregistration_reference"] == "01"
    co = result.coregistration["b01"]
    assert b01["properties"]["scangeo:coregistration_sigma_m"] == {"median": co["median_m"], "max": co["max_m"]}
    assert b01["assets"]["coregistration"]["href"] == "./b01.coregistration.tif"
    assert "scangeo:coregistration_sigma_m" not in doc["01.stac.json"]["properties"]  # the reference
    assert doc["mosaic-b.stac.json"]["properties"]["scangeo:sensor"] == "b"


def test_the_report_has_a_coregistration_table_per_flight_line(platform):
    root, result = platform
    section = coregistration_section(root / "results", "SE_B")
    text = "\n".join(section.parts)
    report = json.loads((root / "results" / "SE_B" / "report.json").read_text())["platform"]["strips"]
    for fid, sid in (("L01", "b01"), ("L02", "b02")):
        assert f'id="coregistration-{fid}"' in text
        co = report[sid]["coregistration"]
        row = (f"<td>{sid}</td><td class=\"text\">b</td><td class=\"text\">{sid[1:]}</td>"
               f"<td>{co['median_m']:.3f}</td><td>{co['max_m']:.3f}</td>")
        assert row.replace("<td>" + sid, '<td class="text">' + sid) in text
        assert f"results/SE_B/ortho/{sid}.coregistration.tif" in text
    assert coregistration_section(root / "results", "DG") is None


def test_direct_georeferencing_of_a_platform_has_the_grid_and_the_vrt_but_no_coregistration(platform, tmp_path):
    root, _ = platform
    copy = copy_project(root, tmp_path / "dg", truth=True)
    result = rectify_project(copy, "DG", strips=["01", "b01"], options=RectifyOptions(resolution=20.0, mosaic=False))
    assert result.coregistration == {} and set(result.stacks) == {"L01"} and result.resolution_source == "options"
    assert not list(result.folder.glob("*.coregistration.tif"))
    with rasterio.open(result.stacks["L01"]) as stack:
        assert stack.res == (20.0, 20.0) and stack.count == 15


def test_a_one_sensor_project_writes_the_files_it_wrote_before(small_block, tmp_path):
    """The names, bands and tags of a one-sensor run: no sensor tags, no VRT, no co-registration layer."""
    root = copy_project(small_block, tmp_path / "one")
    result = rectify_project(root, "DG", options=RectifyOptions(resolution=20.0))
    names = sorted(p.name for p in result.folder.iterdir() if not p.name.startswith("."))
    assert names == ["01.layers.tif", "01.tif", "02.layers.tif", "02.tif", "mosaic.tif"]
    assert result.mosaic == result.folder / "mosaic.tif" and result.mosaics == {"": result.mosaic}
    assert result.stacks == {} and result.coregistration == {}
    with rasterio.open(result.folder / "01.tif") as src:
        assert set(src.tags()) == {"AREA_OR_POINT", "TIFFTAG_SOFTWARE", "scangeo_version", "resampling",
                                   "inverse_map_max_error_px", "inverse_map_tolerance_px", "inverse_map_method",
                                   "occlusion", "variant", "strip", "orientation", "scangeo_fingerprint"}
    assert "coregistration" not in result.strips["01"]
