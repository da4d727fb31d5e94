"""Resampling of a tile: read the image lines it needs, ``cv2.remap`` every band, mask nodata.

OpenCV's remap takes float32 maps of source (x = pixel, y = line) positions, pixel centres at
integers: the same convention as scangeo's image coordinates, so no half-pixel shift is involved.
Only the window a tile needs (its lines and, of those, its pixels, plus the kernel's reach) is read
from the image, so memory is bounded by the tile size, not by the strip's length or width.
"""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from rasterio.windows import Window

from scangeo.errors import RectifyOptionsError

#: resampling name -> (OpenCV interpolation flag, kernel radius in pixels)
RESAMPLING = {
    "nearest": (cv2.INTER_NEAREST, 1),
    "bilinear": (cv2.INTER_LINEAR, 1),
    "cubic": (cv2.INTER_CUBIC, 2),
}
#: dtypes cv2.remap handles as they are; others go through float64
_REMAP_DTYPES = {np.dtype(t) for t in ("uint8", "uint16", "int16", "float32", "float64")}


def check_resampling(name: str) -> str:
    if name not in RESAMPLING:
        raise RectifyOptionsError(f"resampling {name!r} is not one of {', '.join(RESAMPLING)}")
    return name


@dataclass(frozen=True)
class LineWindow:
    """Image lines ``start .. stop - 1`` of a tile, and of each line the pixels ``first .. last - 1``
    (``last`` None: to the line's end)."""

    start: int
    stop: int
    first: int = 0
    last: int | None = None

    def window(self, pixels: int) -> Window:
        last = pixels if self.last is None else self.last
        return Window(self.first, self.start, last - self.first, self.stop - self.start)


def line_window(line: np.ndarray, valid: np.ndarray, lines: int, radius: int, pixel: np.ndarray | None = None,
                pixels: int | None = None) -> LineWindow | None:
    """The image lines cells ``valid`` need, widened by the kernel radius; None when none. With
    ``pixel`` and ``pixels``, also the pixels of those lines they need (a tile across a wide swath
    reads its part of the lines only)."""
    if not valid.any():
        return None
    lv = line[valid]
    start = max(int(np.floor(lv.min())) - radius, 0)
    stop = min(int(np.ceil(lv.max())) + radius + 1, lines)
    if stop <= start:
        return None
    if pixel is None or pixels is None:
        return LineWindow(start, stop)
    pv = pixel[valid]
    first = min(max(int(np.floor(pv.min())) - radius, 0), pixels - 1)
    last = max(min(int(np.ceil(pv.max())) + radius + 1, pixels), first + 1)
    return LineWindow(start, stop, first, last)


def in_image(line: np.ndarray, pixel: np.ndarray, lines: int, pixels: int) -> np.ndarray:
    """Cells whose (line, pixel) lies on the image (within half a pixel of the outer centres)."""
    with np.errstate(invalid="ignore"):
        return (line >= -0.5) & (line <= lines - 0.5) & (pixel >= -0.5) & (pixel <= pixels - 0.5)


def remap_bands(
    data: np.ndarray,
    line: np.ndarray,
    pixel: np.ndarray,
    window: LineWindow,
    method: str,
) -> np.ndarray:
    """Resample every band of ``data`` (bands, window lines, pixels) at (line, pixel).

    Parameters
    ----------
    data : image lines ``window.start .. window.stop - 1``, pixels ``window.first ..``.
    line, pixel : (rows, cols) image coordinates of the output cells (full-image lines).
    method : ``nearest``, ``bilinear`` or ``cubic``.

    Returns
    -------
    (bands, rows, cols) array of ``data``'s dtype; cells off the image hold edge-replicated values
    (the caller masks them).
    """
    flag, _ = RESAMPLING[method]
    map_x, map_y = _maps(line, pixel, window)
    dtype = data.dtype
    work = data if dtype in _REMAP_DTYPES else data.astype(np.float64)
    out = np.empty((data.shape[0],) + line.shape, dtype=dtype)
    for b in range(data.shape[0]):
        if work.dtype == dtype:  # straight into the output: no copy of every band
            cv2.remap(work[b], map_x, map_y, flag, dst=out[b], borderMode=cv2.BORDER_REPLICATE)
        else:
            out[b] = _cast(cv2.remap(work[b], map_x, map_y, flag, borderMode=cv2.BORDER_REPLICATE), dtype)
    return out


def _maps(line: np.ndarray, pixel: np.ndarray, window: LineWindow) -> tuple[np.ndarray, np.ndarray]:
    """cv2.remap's float32 maps of (pixel, line in the window); NaN (unseen) as -1 (masked later)."""
    map_x = np.nan_to_num((pixel - window.first).astype(np.float32), copy=False, nan=-1.0)
    map_y = np.nan_to_num((line - window.start).astype(np.float32), copy=False, nan=-1.0)
    return map_x, map_y


def _cast(values: np.ndarray, dtype: np.dtype) -> np.ndarray:
    if np.issubdtype(dtype, np.integer):
        info = np.iinfo(dtype)
        return np.clip(np.rint(values), info.min, info.max).astype(dtype)
    return values.astype(dtype)


def source_nodata_mask(
    data: np.ndarray, nodata: float, line: np.ndarray, pixel: np.ndarray, window: LineWindow, method: str
) -> np.ndarray:
    """Cells whose resampling kernel touches a source pixel equal to ``nodata`` in any band."""
    bad = np.isnan(data) if np.isnan(nodata) else (data == nodata)
    bad = bad.any(axis=0).astype(np.uint8)
    if not bad.any():
        return np.zeros(line.shape, dtype=bool)
    if method == "cubic":
        bad = cv2.dilate(bad, np.ones((3, 3), np.uint8))
    flag = cv2.INTER_NEAREST if method == "nearest" else cv2.INTER_LINEAR
    map_x, map_y = _maps(line, pixel, window)
    touched = cv2.remap(bad.astype(np.float32), map_x, map_y, flag, borderMode=cv2.BORDER_REPLICATE)
    return touched > 1e-6
