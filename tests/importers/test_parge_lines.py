"""PARGE lines with their cubes and without surprises: ``--image``, an all-zero GCP row, no DTM, and the warnings.

The status files are the shared real SWIR line with bytes changed (IDL SAVE keeps names and descriptors in
the open): gcparr's descriptor cut to one row of zeros (PARGE's empty list), the sensor model's name turned
into the VNIR camera's, image.STARTTIME set to -1 h. The cubes are made here, of the status file's size,
with each cell's line and pixel as its values.
"""
from __future__ import annotations

import json

import numpy as np
import pytest
import rasterio
import scipy.io

from scangeo.cli import main
from scangeo.errors import ImportFileError
from scangeo.importers.parge import import_parge
from scangeo.io.project import Project
from scangeo.orientation.file import load_adjusted_geometry
from scangeo.reports.stac_validation import validate_items
from tests.conftest import shared_file
from tests.importers.sensor_files import write_cube
from tests.rectify.test_cog_properties import check_written_cog

SWIR = "hyspex/20200522_Husky_SWIR_boresight_IFSAR.gcs"


def _changed(tmp_path, change, name="line.gcs"):
    data = bytearray(shared_file(SWIR).read_bytes())
    change(data)
    path = tmp_path / name
    path.write_bytes(bytes(data))
    return path


def _one_zero_gcp_row(data: bytearray) -> None:
    """gcparr as PARGE writes an empty list: one row of six zeros (descriptor: 6 values, dims 6 x 1)."""
    g = scipy.io.readsav(str(shared_file(SWIR)), python_dict=True)["gcparr"]
    values = bytes(data).find(np.asarray(g, ">f8").tobytes())
    desc = bytes(data).find(np.array([g.size * 8, g.size, 2], ">i4").tobytes(), bytes(data).find(b"GCPARR"))
    assert values > 0 and desc > 0
    data[desc:desc + 12] = np.array([48, 6, 2], ">i4").tobytes()
    data[desc + 28:desc + 32] = np.array([1], ">i4").tobytes()
    data[values:values + 48] = bytes(48)


def test_an_all_zero_gcp_row_is_no_gcp_and_without_a_dtm_run_stops_at_its_check(tmp_path, capsys):
    status = _changed(tmp_path, _one_zero_gcp_row)
    assert scipy.io.readsav(str(status), python_dict=True)["gcparr"].tolist() == [[0.0] * 6]
    out = tmp_path / "project"
    assert main(["import", "parge", str(status), str(out)]) == 0
    printed = capsys.readouterr().out
    assert "note: gcparr holds 1 row of zeros: PARGE's empty list, not GCPs (left out)" in printed
    assert "warning: line.gcs: no GCPs and no DTM given" in printed
    assert not (out / "ground.csv").exists() and not (out / "dtm.tif").exists()
    record = json.loads((out / "import.json").read_text())
    assert any("no GCPs and no DTM" in w for w in record["warnings"])
    assert main(["run", str(out), "--no-progress"]) == 1
    err = capsys.readouterr().err
    assert "stage check failed" in err and "the project has no DTM" in err
    # with a plane for a DTM the line imports whole, still without GCPs
    with_dtm = tmp_path / "with_dtm"
    import_parge(status, with_dtm, dtm=150.0)
    nav = scipy.io.readsav(str(status), python_dict=True)["navarr"]
    heights = Project.load(with_dtm).dtm.height_at_map(nav[::100, 0], nav[::100, 1])
    assert np.all(heights == 150.0) and not (with_dtm / "ground.csv").exists()


def _vnir_sensor(data: bytearray) -> None:
    """The sensor's model file (and its description) named as the VNIR camera's; image.NAME stays SWIR's."""
    old, new = b"sensormodel_SWIR_384_sn3107", b"sensormodel_VNIR_384_sn0812"
    assert bytes(data).count(old) == 2
    data[:] = bytes(data).replace(old, new)


def test_an_image_of_another_camera_than_the_sensor_is_a_warning(tmp_path, capsys):
    status = _changed(tmp_path, _vnir_sensor)
    out = tmp_path / "project"
    assert main(["import", "parge", str(status), str(out)]) == 0
    printed = capsys.readouterr().out
    expected = ("warning: line.gcs: image.NAME names a SWIR SN3107 (20200522-cal_03_SWIR_384me_SN3107_FOVx2_raw_rad_"
                "bsq_float32.img), but the sensor's model file names a VNIR SN0812")
    assert expected in printed
    assert any("names a VNIR SN0812" in w for w in json.loads((out / "import.json").read_text())["warnings"])
    # the real file's names agree: no such warning
    clean = import_parge(shared_file(SWIR), tmp_path / "real")
    assert not any("image.NAME names" in w for w in clean.warnings)


def test_a_start_time_outside_the_lines_day_is_a_warning(tmp_path):
    start = np.array([13.176111221313477], ">f8").tobytes()

    def minus_one_hour(data: bytearray) -> None:
        assert bytes(data).count(start) == 1
        data[:] = bytes(data).replace(start, np.array([-1.0], ">f8").tobytes())

    result = import_parge(_changed(tmp_path, minus_one_hour), tmp_path / "project")
    assert any("the line's first navigation time is -3600.0 s (image.STARTTIME -1 h), not a time of its day "
               "2020-05-22" in w for w in result.warnings)
    assert Project.load(tmp_path / "project").stream(result.strip).time[0] == -3600.0
    real = import_parge(shared_file(SWIR), tmp_path / "real")
    assert not any("first navigation time" in w for w in real.warnings)


def test_a_line_rate_that_disagrees_with_the_navigations_spacing_is_a_warning(tmp_path):
    """The real line: the camera's frame period says 41.67 lines/s, PARGE's SCANFREQ (one navigation record
    a line) 25 Hz."""
    result = import_parge(shared_file(SWIR), tmp_path / "project")
    text = ("the camera's frame period (24000 us) says 41.6667 lines/s, PARGE's SCANFREQ (the spacing of its "
            "navigation records) 25 Hz")
    assert any(text in w for w in result.warnings)
    record = json.loads((tmp_path / "project" / "import.json").read_text())
    assert any(text in w for w in record["warnings"])
    rate = next(d for d in record["decisions"] if d["topic"] == "line_rate")
    assert rate["figures"]["duration_s_at_frame_period"] == pytest.approx(52.248, abs=0.01)


def test_a_cube_of_another_size_is_refused_and_of_other_bands_a_warning(tmp_path):
    status = shared_file(SWIR)
    wrong = write_cube(tmp_path / "wrong.img", np.zeros((2177, 380, 1), np.float32), interleave="bsq",
                       header="wrong.hdr")
    with pytest.raises(ImportFileError, match=r"wrong.hdr: 380 samples x 2177 lines, but the status file "
                                              r"20200522_Husky_SWIR_boresight_IFSAR.gcs has 384 pixels x 2177 lines"):
        import_parge(status, tmp_path / "p", image=wrong)
    assert not (tmp_path / "p").exists()
    cube = write_cube(tmp_path / "cube.img", np.zeros((2177, 384, 2), np.float32), interleave="bsq", header="cube.hdr")
    result = import_parge(status, tmp_path / "q", image=cube)
    assert any("cube.hdr: 2 bands, the status file says 288" in w for w in result.warnings)
    assert Project.load(tmp_path / "q").strip(result.strip).image == cube.resolve()


@pytest.fixture(scope="module")
def rectified(tmp_path_factory):
    """The SWIR line imported with a cube of its size (band 1: each cell's line, band 2: its pixel), then run."""
    root = tmp_path_factory.mktemp("parge_cube")
    lines, pixels = 2177, 384
    cube = np.empty((lines, pixels, 2), np.float32)
    cube[:, :, 0] = np.arange(lines)[:, None]
    cube[:, :, 1] = np.arange(pixels)[None, :]
    path = write_cube(root / "cube.img", cube, interleave="bsq", header="cube.hdr")
    out = root / "project"
    import_parge(shared_file(SWIR), out, image=path)
    (out / "run.toml").write_text("[rectify]\nresolution = 4.0\nmosaic = false\n")  # 4 m cells: a quicker test
    assert main(["run", str(out), "--no-progress"]) == 0
    return out


def test_run_rectifies_the_cube_at_the_positions_the_adjusted_orientation_gives(rectified):
    """Every orthoimage cell carries the cube's line and pixel where the recommended variant's orientation
    sees the cell's ground point (bilinear resampling of a linear field: exact to the interpolation of the
    inverse map, here within 0.1 line and pixel)."""
    out = rectified
    manifest = json.loads((out / "results" / "run.json").read_text())
    variant = manifest["recommended"]["variant"]
    assert manifest["stages"]["rectify"]["status"] == "ran" and variant in ("PARGE", "BORESIGHT", "CALIBRATED")
    project = Project.load(out)
    strip = project.strips[0].id
    with rasterio.open(out / "results" / variant / "ortho" / f"{strip}.tif") as src:
        values = src.read(masked=True)
        rows, cols = np.nonzero(~values[0].mask)
        pick = np.random.default_rng(3).choice(len(rows), 400, replace=False)
        r, c = rows[pick], cols[pick]
        x, y = rasterio.transform.xy(src.transform, r, c)
    x, y = np.asarray(x), np.asarray(y)
    H = project.dtm.height_at_map(x, y)
    geometry = load_adjusted_geometry(project, variant, strip)
    line, pixel, status = geometry.ground_to_image(project.map_frame.map_to_project(x, y, H))
    ok = status == 0
    assert ok.sum() > 380
    ok &= (line >= 0) & (line <= project.n_lines(strip) - 1) & (pixel >= 0) & (pixel <= 383)  # edges: clamped
    np.testing.assert_allclose(values[0].data[r, c][ok], line[ok], atol=0.1)
    np.testing.assert_allclose(values[1].data[r, c][ok], pixel[ok], atol=0.1)


def test_the_imported_lines_cogs_and_stac_items_are_valid_with_the_network_blocked(rectified, no_network):
    """What an imported line writes: every GeoTIFF under results/ (the orthoimage and its layers, default
    GeoTIFF settings) passes rio-cogeo's strict validation, every STAC item its schemas, offline."""
    rasters = sorted((rectified / "results").rglob("*.tif"))
    items = sorted((rectified / "results").rglob("*.stac.json"))
    assert rasters and items
    for path in rasters:
        check_written_cog(path)
    validate_items(items)
    assert no_network == []
