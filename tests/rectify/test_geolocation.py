"""The ENVI headers of the GLT and the IGM name the final file, not the temporary one GDAL wrote,
and the files read back with their georeferencing and values."""
import warnings
from pathlib import Path

import numpy as np
import rasterio
from rasterio.windows import Window

from scangeo.rectify.geolocation import IGM_NODATA, GltWriter, write_igm
from scangeo.rectify.output_grid import OutputGrid


def header_description(path: Path) -> str:
    text = path.read_text(encoding="latin-1")
    start = text.index("description = {") + len("description = {")
    return text[start:text.index("}", start)].strip()


def test_glt_header_names_the_final_file(tmp_path):
    grid = OutputGrid("EPSG:32633", 10.0, 500_000.0, 5_300_000.0, 4, 3)
    writer = GltWriter(tmp_path / ".work-glt", grid)
    line, pixel = np.meshgrid(np.arange(3.0), np.arange(4.0), indexing="ij")
    writer.write(Window(0, 0, 4, 3), line, pixel, pixel > 0)
    final = writer.commit(tmp_path / "07.glt")
    hdr = tmp_path / "07.glt.hdr"
    assert header_description(hdr) == "07.glt"
    assert ".work" not in hdr.read_text() and "glt.img" not in hdr.read_text()
    with rasterio.open(final) as src:
        assert src.crs.to_epsg() == 32633 and src.transform.c == 500_000.0
        glt = src.read()
    assert glt[0].tolist() == [[0, 2, 3, 4]] * 3  # 1-based samples, 0 where no pixel sees the cell
    assert glt[1][:, 1].tolist() == [1, 2, 3]


class _Flat:
    """A geometry whose pixel (line, pixel) sees the ground at (pixel, -line, 100)."""

    pixels, lines, crs = 5, 7, "EPSG:32633"

    def image_to_ground(self, line, pixel):
        return pixel, -line, np.full_like(line, 100.0)


def test_igm_header_names_the_final_file_and_no_partial_is_left(tmp_path):
    out = write_igm(_Flat(), tmp_path / "ortho" / "03.igm")
    folder = tmp_path / "ortho"
    assert sorted(p.name for p in folder.iterdir()) == ["03.igm", "03.igm.hdr"]
    assert header_description(folder / "03.igm.hdr") == "03.igm"
    assert "partial" not in (folder / "03.igm.hdr").read_text()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with rasterio.open(out) as src:
            xyz = src.read()
            assert src.nodata == IGM_NODATA
    assert xyz.shape == (3, 7, 5) and xyz[0, 6, 4] == 4.0 and xyz[1, 6, 4] == -6.0 and (xyz[2] == 100.0).all()
