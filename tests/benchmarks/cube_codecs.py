"""Benchmark: the codec, predictor and level of a rectified cube's COG blocks, chosen by measurement.

Set-up (not timed): the cube benchmark's project and ENVI BSQ cube (``tests/benchmarks/cube.py``: a
HySpex-VNIR-1800-like pushbroom strip, ``--pixels`` x ``--lines`` x ``--bands`` float32; with
``--noise F`` the cube's values carry a relative Gaussian sensor noise F, as a real radiance does),
rectified once at 0.6 m into an uncompressed COG by scangeo's writer (``compress = "none"``). Its
full-resolution blocks (``bands`` x 128 x 128 float32, 12 MB each at 182 bands, nodata margins
included) are what every codec gets.

Side by side in this process, each block through every codec in turn (so that the machine's load
hits them alike), CPU seconds of the encoding thread and bytes out, every encoding decoded and
compared with the block bit for bit:

* ``deflate 1, ISA-L``: scangeo's writer, with the compiled floating-point predictor
  (``scangeo.rectify.predictors``) and with the numpy one it had before;
* ``zstd 1`` and ``zstd -1`` (the ``zstandard`` binding, when installed) behind the compiled predictor:
  what scangeo's writer would do with a zstd binding;
* ``LERC, max error 0`` (the ``lerc`` binding, when installed): LERC 4's lossless float coding.

Then GDAL's COG driver (rasterio's GDAL; its libtiff deflates with libdeflate) copies the whole
uncompressed COG with one compression thread, once per codec: deflate 1 and 6 with the floating-point
predictor, zstd 1 and 3 with it, LERC at zero error (alone, then deflate, then zstd), and the lossy
LERC at ``--lossy`` (max error, the cube's units); ``none`` gives the copy's own cost. CPU seconds of
the process, bytes, and for the lossless ones a check that the file reads back equal; for the lossy
one the largest error.

Run: python tests/benchmarks/cube_codecs.py [--lines 600] [--pixels 1800] [--bands 182] [--noise 0.005]
[--lossy 0.01] [--keep DIR]
"""
from __future__ import annotations

import argparse
import os
import shutil
import sys
import tempfile
import time
import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np

warnings.simplefilter("ignore")
sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from cube import make_cube_project, write_envi  # noqa: E402  (the cube benchmark)


def uncompressed_cube(root: Path, lines: int, pixels: int, bands: int, noise: float) -> Path:
    """The cube rectified at 0.6 m into an uncompressed COG (made once)."""
    from scangeo.io.project import Project
    from scangeo.rectify.core_geometry import CoreStripGeometry
    from scangeo.rectify.geotiff import GeoTiffProfile
    from scangeo.rectify.options import RectifyOptions
    from scangeo.rectify.strip import rectify_strip

    out = root / f"raw{bands}_{noise:g}.tif"
    if out.exists():
        return out
    if not (root / "project.toml").exists():
        make_cube_project(root, lines, pixels)
    image = root / "images" / f"cube{bands}_{noise:g}.bsq"
    image.parent.mkdir(exist_ok=True)
    if not image.exists():
        write_envi(image, lines, pixels, bands, "bsq", noise=noise)
    project = Project.load(root)
    geometry = CoreStripGeometry(project.geometry("01"), project.dtm)
    options = RectifyOptions(resolution=0.6, mosaic=False, geotiff=GeoTiffProfile(compress="none"))
    rectify_strip(geometry, image, out, options).wait()
    return out


def blocks(path: Path):
    """The full-resolution blocks of a COG, (bands, rows, cols) each."""
    import rasterio

    with rasterio.open(path) as src:
        for _, window in src.block_windows(1):
            yield src.read(window=window)


def block_codecs() -> dict[str, tuple[Callable[[np.ndarray], bytes], Callable[[bytes, np.ndarray], np.ndarray]]]:
    """name -> (encode a block, decode to the block's shape)."""
    from isal import isal_zlib

    from scangeo.rectify import predictors

    def unpredict(data: bytes, like: np.ndarray) -> np.ndarray:
        """Undo predictor 3 (libtiff's fpAcc) of rows of (cols, bands) floats."""
        bands, rows, cols = like.shape
        size = like.dtype.itemsize
        b = np.frombuffer(data, np.uint8).reshape(rows, size * cols * bands).copy()
        for i in range(bands, b.shape[1], bands):  # cumulative sums modulo 256, bands apart
            b[:, i:i + bands] += b[:, i - bands:i]
        planes = b.reshape(rows, size, cols * bands).transpose(0, 2, 1)[:, :, ::-1]
        values = np.ascontiguousarray(planes).view(like.dtype.newbyteorder("<")).reshape(rows, cols, bands)
        return values.transpose(2, 0, 1)

    def numpy_predictor(block: np.ndarray) -> np.ndarray:
        return predictors.floating_point_reference(block.transpose(1, 2, 0))

    out = {
        "deflate 1, ISA-L, compiled predictor": (lambda b: isal_zlib.compress(predictors.floating_point(b), 1),
                                                 lambda d, b: unpredict(isal_zlib.decompress(d), b)),
        "deflate 1, ISA-L, numpy predictor": (lambda b: isal_zlib.compress(numpy_predictor(b), 1),
                                              lambda d, b: unpredict(isal_zlib.decompress(d), b)),
    }
    try:
        import zstandard

        for level in (1, -1):
            comp, dec = zstandard.ZstdCompressor(level=level), zstandard.ZstdDecompressor()
            out[f"zstd {level}, compiled predictor"] = (
                lambda b, c=comp: c.compress(predictors.floating_point(b)),
                lambda d, b, z=dec: unpredict(z.decompress(d), b))
    except ImportError:
        print("zstandard not installed: the writer's zstd left out (pip install zstandard)")
    try:
        import lerc

        def lerc_encode(b: np.ndarray) -> bytes:
            pixels = np.ascontiguousarray(b.transpose(1, 2, 0))
            return bytes(lerc.encode(pixels, b.shape[0], False, None, 0.0, 1)[-1])

        def lerc_decode(d: bytes, b: np.ndarray) -> np.ndarray:
            return np.asarray(lerc.decode(d)[1]).reshape(b.shape[1], b.shape[2], b.shape[0]).transpose(2, 0, 1)

        out["LERC 4, max error 0"] = (lerc_encode, lerc_decode)
    except ImportError:
        print("lerc not installed: LERC 4's lossless float coding left out (pip install pylerc)")
    return out


def gdal_copies(raw: Path, work: Path, lossy: float) -> list[tuple[str, dict, bool]]:
    """(name, creation options, lossless) of GDAL's COG driver."""
    fp = {"PREDICTOR": "FLOATING_POINT"}
    return [
        ("none (the copy's own cost)", {"COMPRESS": "NONE"}, True),
        ("deflate 1 (libdeflate), float predictor", {"COMPRESS": "DEFLATE", "LEVEL": "1", **fp}, True),
        ("deflate 6 (libdeflate), float predictor", {"COMPRESS": "DEFLATE", "LEVEL": "6", **fp}, True),
        ("zstd 1, float predictor", {"COMPRESS": "ZSTD", "LEVEL": "1", **fp}, True),
        ("zstd 3, float predictor", {"COMPRESS": "ZSTD", "LEVEL": "3", **fp}, True),
        ("LERC, max error 0", {"COMPRESS": "LERC", "MAX_Z_ERROR": "0"}, True),
        ("LERC + deflate, max error 0", {"COMPRESS": "LERC_DEFLATE", "MAX_Z_ERROR": "0"}, True),
        ("LERC + zstd, max error 0", {"COMPRESS": "LERC_ZSTD", "MAX_Z_ERROR": "0"}, True),
        (f"LERC, max error {lossy:g} (lossy)", {"COMPRESS": "LERC", "MAX_Z_ERROR": f"{lossy:g}"}, False),
        (f"LERC + zstd, max error {lossy:g} (lossy)", {"COMPRESS": "LERC_ZSTD", "MAX_Z_ERROR": f"{lossy:g}"}, False),
    ]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lines", type=int, default=600)
    ap.add_argument("--pixels", type=int, default=1800)
    ap.add_argument("--bands", type=int, default=182)
    ap.add_argument("--noise", type=float, default=0.005, help="relative sensor noise of the cube's values")
    ap.add_argument("--lossy", type=float, default=0.01, help="the lossy LERC's max error, the cube's units")
    ap.add_argument("--keep", default=None, help="keep (and reuse) the project, cube and raw COG here")
    args = ap.parse_args()

    import rasterio
    import rasterio.shutil

    work = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="scangeo-bench-codecs-"))
    work.mkdir(parents=True, exist_ok=True)
    raw = uncompressed_cube(work / f"cube{args.lines}x{args.pixels}", args.lines, args.pixels, args.bands, args.noise)
    codecs = block_codecs()
    for block in blocks(raw):  # warm-up: numba's kernels compiled or loaded
        for encode, _ in codecs.values():
            encode(block[:, :16, :16].copy())
        break
    cpu = dict.fromkeys(codecs, 0.0)
    size = dict.fromkeys(codecs, 0)
    raw_bytes, n = 0, 0
    for block in blocks(raw):
        raw_bytes += block.nbytes
        n += 1
        for name, (encode, decode) in codecs.items():
            c = time.thread_time()
            data = encode(block)
            cpu[name] += time.thread_time() - c
            size[name] += len(data)
            back = np.ascontiguousarray(decode(data, block), dtype=block.dtype)
            if not np.array_equal(back.view(np.uint8), block.view(np.uint8)):
                raise SystemExit(f"{name}: a block does not decode to itself")
    print(f"\n{raw.name}: {n} blocks, {raw_bytes / 1e6:.0f} MB; noise {args.noise:g}; load average "
          f"{os.getloadavg()[0]:.1f}; one thread each, side by side")
    print(f"{'block codec':44s}{'CPU s':>8}{'MB/s':>8}{'size':>8}   every block decodes to itself")
    for name in codecs:
        print(f"{name:44s}{cpu[name]:8.2f}{raw_bytes / cpu[name] / 1e6:8.0f}{size[name] / raw_bytes:8.3f}   yes")

    with rasterio.open(raw) as src:
        cells = src.count * src.width * src.height
        itemsize = np.dtype(src.dtypes[0]).itemsize
    print(f"\nGDAL {rasterio.__gdal_version__} COG driver, the whole file ({cells * itemsize / 1e6:.0f} MB at full "
          "resolution, overviews beside), one compression thread")
    print(f"{'GDAL codec':44s}{'CPU s':>8}{'wall s':>8}{'size':>8}   read back")
    for name, opts, lossless in gdal_copies(raw, work, args.lossy):
        out = work / "gdal.tif"
        c, t = time.process_time(), time.perf_counter()
        rasterio.shutil.copy(str(raw), str(out), driver="COG", BLOCKSIZE="128", NUM_THREADS="1",
                             OVERVIEWS="FORCE_USE_EXISTING", BIGTIFF="IF_SAFER", **opts)
        dc, dt = time.process_time() - c, time.perf_counter() - t
        worst, equal = 0.0, True
        with rasterio.open(raw) as a, rasterio.open(out) as b:
            for _, window in a.block_windows(1):
                x, y = a.read(window=window), b.read(window=window)
                if lossless:
                    equal &= np.array_equal(x.view(np.uint8), y.view(np.uint8))
                else:
                    ok = np.isfinite(x)
                    worst = max(worst, float(np.max(np.abs(x[ok] - y[ok]), initial=0.0)))
        size_ratio = out.stat().st_size / raw.stat().st_size
        check = ("equal" if equal else "NOT EQUAL") if lossless else f"largest error {worst:.3g}"
        print(f"{name:44s}{dc:8.2f}{dt:8.2f}{size_ratio:8.3f}   {check}")
        out.unlink()
    if not args.keep:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
