"""Strip images as raw ENVI cubes (BSQ, BIL, BIP; either byte order): read directly, rectified
identically to the same data as a GeoTIFF."""
import numpy as np
import pytest
import rasterio
from rasterio.windows import Window
from rectify_synthetic import AnalyticStrip, Texture, hills, make_dtm, render

from scangeo.rectify.options import RectifyOptions
from scangeo.rectify.raw_image import RawCube, image_reader, raw_cube, read_envi_header
from scangeo.rectify.strip import rectify_strip

BANDS = 13


def write_envi(path, data: np.ndarray, interleave: str, byte_order: str = "<", header_offset: int = 0) -> None:
    """``data`` (bands, lines, pixels) as a raw ENVI cube with its ``.hdr``."""
    bands, lines, pixels = data.shape
    layout = {"bsq": (0, 1, 2), "bil": (1, 0, 2), "bip": (1, 2, 0)}[interleave]
    raw = np.ascontiguousarray(data.transpose(layout)).astype(data.dtype.newbyteorder(byte_order))
    with open(path, "wb") as f:
        f.write(b"\0" * header_offset)
        f.write(raw.tobytes())
    code = {"float32": 4, "uint16": 12, "int16": 2}[data.dtype.name]
    path.with_suffix(".hdr").write_text(
        f"ENVI\ndescription = {{test cube,\n  {interleave}}}\nsamples = {pixels}\nlines = {lines}\nbands = {bands}\n"
        f"header offset = {header_offset}\nfile type = ENVI Standard\ndata type = {code}\n"
        f"interleave = {interleave}\nbyte order = {0 if byte_order == '<' else 1}\n")


@pytest.fixture(scope="module")
def cube(tmp_path_factory):
    """An analytic strip, its 13-band float32 image as a GeoTIFF, and the same data as an array."""
    root = tmp_path_factory.mktemp("envi")
    dtm = make_dtm(hills, 499_000, 501_000, 4_999_700, 5_001_000, 2.0)
    strip = AnalyticStrip(dtm, roll_amp=0.002)
    data = render(strip, Texture(), root / "img.tif", bands=BANDS)
    return root, strip, data


@pytest.mark.parametrize("interleave, order", [("bsq", "<"), ("bil", "<"), ("bip", "<"), ("bil", ">")])
def test_raw_reader_reads_what_gdal_reads(cube, tmp_path, interleave, order):
    _, _, data = cube
    path = tmp_path / f"cube.{interleave}"
    write_envi(path, data, interleave, order, header_offset=128)
    with rasterio.open(path) as src:
        raw = raw_cube(src)
        assert isinstance(raw, RawCube) and raw.interleave == interleave and raw.offset == 128
        assert image_reader(src) == raw
        for window in (Window(0, 0, data.shape[2], data.shape[1]), Window(17, 40, 31, 9), Window(199, 299, 1, 1)):
            got = raw.read(window)
            assert got.dtype == np.dtype("float32") and got.dtype.isnative
            np.testing.assert_array_equal(got, src.read(window=window))
            np.testing.assert_array_equal(got, data[:, window.row_off:window.row_off + window.height,
                                                   window.col_off:window.col_off + window.width])
        with pytest.raises(ValueError, match="outside"):
            raw.read(Window(0, 295, 10, 10))


def test_a_cube_the_raw_reader_does_not_understand_is_read_by_gdal(cube, tmp_path):
    root, _, data = cube
    path = tmp_path / "cube.bil"
    write_envi(path, data, "bil")
    hdr = path.with_suffix(".hdr")
    assert read_envi_header(hdr)["description"] == "{test cube, bil}"
    # complex values (ENVI data type 6): GDAL reads them, the raw reader leaves them to it
    complex_data = (data[:, :, :100] + 1j * data[:, :, 100:]).astype(np.complex64)
    write_envi(path, complex_data.view(np.float32).reshape(BANDS, 300, 200), "bil")
    hdr.write_text(hdr.read_text().replace("samples = 200", "samples = 100").replace("data type = 4", "data type = 6"))
    with rasterio.open(path) as src:
        assert src.dtypes[0] == "complex64" and raw_cube(src) is None
        reader = image_reader(src)
        np.testing.assert_array_equal(reader.read(Window(3, 5, 7, 11)), complex_data[:, 5:16, 3:10])
    with rasterio.open(root / "img.tif") as src:  # not ENVI
        assert raw_cube(src) is None


@pytest.mark.parametrize("interleave", ["bsq", "bil"])
def test_an_envi_cube_rectifies_as_the_same_data_in_a_geotiff(cube, tmp_path, interleave):
    root, strip, data = cube
    path = tmp_path / f"cube.{interleave}"
    write_envi(path, data, interleave)
    options = RectifyOptions(resampling="bilinear", tile_size=64)  # many tiles: windows of lines and pixels
    ref = rectify_strip(strip, root / "img.tif", tmp_path / "from_tif.tif", options)
    got = rectify_strip(strip, path, tmp_path / "from_envi.tif", options)
    assert ref.valid_cells == got.valid_cells > 40_000
    with rasterio.open(tmp_path / "from_tif.tif") as a, rasterio.open(tmp_path / "from_envi.tif") as b:
        assert (a.count, a.dtypes[0]) == (b.count, b.dtypes[0]) == (BANDS, "float32")
        assert b.tags(ns="IMAGE_STRUCTURE")["PREDICTOR"] == "3"  # floats through scangeo's COG writer
        va, vb = a.read(), b.read()
    np.testing.assert_array_equal(va, vb)
    assert np.isfinite(va).mean() > 0.3
