"""Windows of a strip image: read directly from a raw ENVI cube (BSQ, BIL or BIP), else through GDAL.

An imaging spectrometer's line is a raw cube of hundreds of bands (HySpex VNIR-1800: 1800 px x 182
bands x 4,000-13,000 lines of float32, 5-17 GB). GDAL's ENVI driver reads a window of it a line of a
band at a time through its block cache, at about 200 MB/s here; the window's bytes read straight
from the file reach 2-3 GB/s. :func:`image_reader` returns a :class:`RawCube` for an uncompressed
ENVI file whose header it understands (and whose size, band count and data type agree with what
GDAL reports), else the rasterio dataset itself: both answer ``read(window)`` with a
``(bands, rows, cols)`` array of the image's data type in native byte order.

Layouts (``interleave`` of the header; ``header offset`` bytes before the data):

* BSQ: band, line, pixel. A window is one read per band of its lines (whole lines: contiguous), cut
  to its pixels;
* BIL: line, band, pixel. A window is one read of its lines, cut to its pixels, bands first;
* BIP: line, pixel, band. One read of its lines, cut, transposed.

Memory: the window's whole lines, once (for BSQ one band's at a time); no memory map (its pages
would count in the process's resident memory).
"""
from __future__ import annotations

import logging
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from rasterio.windows import Window

log = logging.getLogger(__name__)

#: ENVI ``data type`` codes -> numpy types
_ENVI_TYPES = {1: "u1", 2: "i2", 3: "i4", 4: "f4", 5: "f8", 12: "u2", 13: "u4", 14: "i8", 15: "u8"}


def read_envi_header(path: Path) -> dict[str, str]:
    """The ``key = value`` pairs of an ENVI header (keys lower case; ``{...}`` values joined on one
    line); an empty dict when the file does not start with ``ENVI``."""
    text = path.read_text(encoding="latin-1")
    if not text.lstrip().startswith("ENVI"):
        return {}
    out: dict[str, str] = {}
    lines = iter(text.splitlines()[1:])
    for raw in lines:
        if "=" not in raw:
            continue
        key, value = (part.strip() for part in raw.split("=", 1))
        if value.startswith("{"):
            while "}" not in value:
                value += " " + next(lines, "}").strip()
        out[key.lower()] = value
    return out


@dataclass
class RawCube:
    """A raw cube's layout: file, header offset, lines, pixels, bands, data type and interleave."""

    path: Path
    offset: int
    lines: int
    pixels: int
    bands: int
    dtype: np.dtype
    interleave: str

    def _read_at(self, f, at: int, count: int) -> np.ndarray:
        buf = np.empty(count, dtype=self.dtype)
        f.seek(at)
        n = f.readinto(buf.view(np.uint8).data)
        if n != buf.nbytes:
            raise OSError(f"{self.path}: {buf.nbytes} bytes expected at byte {at}, got {n} (a truncated file?)")
        return buf

    def read(self, window: Window) -> np.ndarray:
        """The window's ``(bands, rows, cols)`` values, native byte order."""
        c0, r0 = int(window.col_off), int(window.row_off)
        w, h = int(window.width), int(window.height)
        if r0 < 0 or c0 < 0 or r0 + h > self.lines or c0 + w > self.pixels:
            raise ValueError(f"{self.path}: window {window} outside {self.lines} lines x {self.pixels} pixels")
        size = self.dtype.itemsize
        with open(self.path, "rb", buffering=0) as f:
            if self.interleave == "bsq":
                out = np.empty((self.bands, h, w), self.dtype.newbyteorder("="))
                for b in range(self.bands):
                    at = self.offset + ((b * self.lines + r0) * self.pixels) * size
                    out[b] = self._read_at(f, at, h * self.pixels).reshape(h, self.pixels)[:, c0:c0 + w]
                return out
            data = self._read_at(f, self.offset + r0 * self.pixels * self.bands * size, h * self.pixels * self.bands)
        if self.interleave == "bil":
            cube = data.reshape(h, self.bands, self.pixels)[:, :, c0:c0 + w].transpose(1, 0, 2)
        else:  # bip
            cube = data.reshape(h, self.pixels, self.bands)[:, c0:c0 + w, :].transpose(2, 0, 1)
        return np.ascontiguousarray(cube, dtype=self.dtype.newbyteorder("="))


def raw_cube(src) -> RawCube | None:
    """A :class:`RawCube` of the open rasterio dataset ``src`` when it is an uncompressed ENVI file
    whose header agrees with GDAL's view of it; else None (GDAL reads it)."""
    if src.driver != "ENVI":
        return None
    data_file = Path(src.name)
    headers = [Path(f) for f in src.files if Path(f).suffix.lower() == ".hdr"]
    if not headers:
        return None
    try:
        h = read_envi_header(headers[0])
        code = int(h.get("data type", "0"))
        cube = RawCube(data_file, int(h.get("header offset", "0")), int(h["lines"]), int(h["samples"]),
                       int(h["bands"]), np.dtype(_ENVI_TYPES[code]).newbyteorder("<" if h.get("byte order", "0")
                                                                              .strip() == "0" else ">"),
                       h.get("interleave", "bsq").strip().lower())
    except (KeyError, ValueError, OSError):
        return None
    agrees = (
        h.get("file compression", "0").strip() == "0"
        and cube.interleave in ("bsq", "bil", "bip")
        and (cube.lines, cube.pixels, cube.bands) == (src.height, src.width, src.count)
        and cube.dtype.newbyteorder("=") == np.dtype(src.dtypes[0])
        and os.path.getsize(data_file) >= cube.offset + cube.lines * cube.pixels * cube.bands * cube.dtype.itemsize
    )
    if not agrees:
        log.info("%s: ENVI header not understood as a plain raw cube; read through GDAL", data_file)
        return None
    return cube


class GdalReader:
    """``read(window)`` of a rasterio dataset (all bands)."""

    def __init__(self, src) -> None:
        self.src = src

    def read(self, window: Window) -> np.ndarray:
        return self.src.read(window=window)


def image_reader(src) -> RawCube | GdalReader:
    """The reader of the strip image ``src`` (an open rasterio dataset): raw for a plain ENVI cube."""
    return raw_cube(src) or GdalReader(src)


__all__ = ["GdalReader", "RawCube", "image_reader", "raw_cube", "read_envi_header"]
