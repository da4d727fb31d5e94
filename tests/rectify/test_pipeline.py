"""Pipelined rectification (a Finaliser thread writes one strip while the next is computed) gives
byte-identical files to the sequential run, and a failure in the background step is raised."""
import hashlib

import pytest
from rectify_synthetic import AnalyticStrip, Texture, hills, make_dtm, render

from scangeo.rectify.geotiff import GeoTiffProfile
from scangeo.rectify.options import RectifyOptions
from scangeo.rectify.strip import Finaliser, rectify_strip

TEX = Texture()
OPTS = RectifyOptions(resolution=2.0, layers=("scan_angle", "image_line"), glt=True,
                      geotiff=GeoTiffProfile(blocksize=128, overviews=True))


def strips(tmp_path, n=2):
    dtm = make_dtm(hills, 499_000, 501_000, 4_999_700, 5_001_000, 2.0)
    out = []
    for i in range(n):
        strip = AnalyticStrip(dtm, roll_amp=0.002 * (i + 1))
        render(strip, TEX, tmp_path / f"img{i}.tif", bands=3, dtype="uint16")
        out.append(strip)
    return out


def digest(folder, names):
    out = {}
    for n in names:  # .hdr included: its description names the final file, not GDAL's working one
        out[n] = hashlib.sha256((folder / n).read_bytes()).hexdigest()
    return out


def test_pipelined_outputs_are_byte_identical_to_sequential(tmp_path):
    geoms = strips(tmp_path)
    names = [f"o{i}{suffix}" for i in range(len(geoms)) for suffix in (".tif", ".layers.tif", ".glt", ".glt.hdr")]
    (tmp_path / "seq").mkdir()
    (tmp_path / "pipe").mkdir()
    seq = [rectify_strip(g, tmp_path / f"img{i}.tif", tmp_path / "seq" / f"o{i}.tif", OPTS)
           for i, g in enumerate(geoms)]
    with Finaliser() as finaliser:
        pipe = [rectify_strip(g, tmp_path / f"img{i}.tif", tmp_path / "pipe" / f"o{i}.tif", OPTS,
                              finaliser=finaliser) for i, g in enumerate(geoms)]
    for a, b in zip(seq, pipe):
        assert b.wait() is b and b.pending is None
        assert a.valid_cells == b.valid_cells > 10_000 and a.hidden_cells == b.hidden_cells
    assert digest(tmp_path / "seq", names) == digest(tmp_path / "pipe", names)
    # nothing but the outputs is left (the working folders are removed by the background step)
    assert sorted(p.name for p in (tmp_path / "pipe").iterdir()) == sorted(names)


@pytest.mark.parametrize("writer", ["scangeo", "gdal"])
def test_a_failure_of_the_background_step_is_raised_by_wait_and_leaves_no_output(tmp_path, monkeypatch, writer):
    (geom,) = strips(tmp_path, 1)
    import scangeo.rectify.cog_writer as cog_module
    import scangeo.rectify.strip as strip_module

    def broken(*args, **kwargs):
        raise OSError("disk full")

    if writer == "gdal":
        monkeypatch.setattr(strip_module, "finalise", broken)
    else:  # the disk fills while the file is assembled from the spool
        monkeypatch.setattr(cog_module, "_copy", broken)
    options = RectifyOptions(resolution=2.0, geotiff=GeoTiffProfile(writer=writer))
    with Finaliser() as finaliser:
        r = rectify_strip(geom, tmp_path / "img0.tif", tmp_path / "o.tif", options, finaliser=finaliser)
        with pytest.raises(OSError, match="disk full"):
            r.wait()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["img0.tif"]


CONCURRENT = r"""
import sys, threading, time
import numpy as np, rasterio
from rasterio.transform import from_origin
from scangeo.rectify.geotiff import GeoTiffProfile, finalise
from scangeo.rectify.refined_map import _upsample

folder = sys.argv[1]
data = (np.arange(2300 * 300 * 3) % 4000).astype(np.uint16).reshape(3, 2300, 300)
with rasterio.open(f"{folder}/w.tif", "w", driver="GTiff", width=300, height=2300, count=3, dtype="uint16",
                   crs="EPSG:32633", transform=from_origin(5e5, 5.3e6, 2.5, 2.5), tiled=True) as dst:
    dst.write(data)
done = threading.Event()
def background():
    for i in range(6):
        finalise(f"{folder}/w.tif", f"{folder}/o{i}.tif", GeoTiffProfile(overviews=True), np.uint16)
    done.set()
ln = np.random.default_rng(0).random((60, 60))
gl, gp = np.empty((600, 600)), np.empty((600, 600))
_upsample(ln, ln, 10, gl, gp)  # compiled before the race
thread = threading.Thread(target=background)
thread.start()
while not done.is_set():  # the main thread's parallel kernels, as the next strip's pass 1
    _upsample(ln, ln, 10, gl, gp)
thread.join()
print("ok")
"""


def test_the_background_step_runs_no_parallel_kernel(tmp_path):
    """The finaliser's thread (overviews, compression) runs beside the next strip's parallel
    kernels: numba's workqueue layer aborts the process if both enter a parallel region."""
    import subprocess
    import sys

    proc = subprocess.run([sys.executable, "-c", CONCURRENT, str(tmp_path)], capture_output=True, text=True)
    assert proc.returncode == 0 and "ok" in proc.stdout, proc.stderr[-2000:]


def test_a_strip_rectified_in_memory_equals_the_file(tmp_path):
    import numpy as np
    import rasterio

    from scangeo.rectify.strip import rectify_strip_array

    (geom,) = strips(tmp_path, 1)
    opts = RectifyOptions(resolution=2.0)
    on_disk = rectify_strip(geom, tmp_path / "img0.tif", tmp_path / "o.tif", opts)
    mem = rectify_strip_array(geom, tmp_path / "img0.tif", opts)
    with rasterio.open(tmp_path / "o.tif") as src:
        np.testing.assert_array_equal(mem.values, src.read())
        assert mem.nodata == src.nodata and mem.grid == on_disk.grid
    assert mem.valid_cells == on_disk.valid_cells > 10_000 and mem.hidden_cells == on_disk.hidden_cells
    assert sorted(p.name for p in tmp_path.iterdir()) == ["img0.tif", "o.tif"]  # nothing else written
