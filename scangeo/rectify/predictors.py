"""The TIFF predictors of the COG writer's blocks, in one pass from the band-sequential tile.

A block comes out of the resampling as ``(bands, rows, cols)``; the TIFF stores it pixel-interleaved,
each row differenced before deflate:

- predictor 2 (integers): each sample minus the same band's sample one pixel to the left;
- predictor 3 (floats, Adobe's floating-point predictor, libtiff's ``fpDiff``): each row's values
  split into byte planes, the most significant byte of every value first, then each byte minus the
  byte ``bands`` before it in the row, modulo 256.

numpy does either in three passes over the block (the interleaving copy, the byte planes, the
differences); the compiled kernels here read the band-sequential block once, difference the
interleaved row's values bytewise in their integer registers (no borrow from one byte into the next)
and write its byte planes once: 1.0-1.5 GB/s against numpy's 0.5-0.7 for a 182-band float block (no
GIL: the COG writer's encoder threads run them side by side). The numpy versions stay as the
reference the tests compare the kernels with bit for bit.
"""
from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, nogil=True)
def _fp_rows(bits: np.ndarray, out: np.ndarray, high, low) -> None:  # pragma: no cover - compiled
    """Predictor 3 of ``bits`` (bands, rows, cols), the floats' bits as unsigned integers of their size,
    into ``out`` (rows, size * cols * bands) uint8; ``high``, ``low``: 0x80 and 0x7F in every byte."""
    bands, rows, cols = bits.shape
    width = cols * bands
    size = out.shape[1] // width
    d = np.empty(width, bits.dtype)
    for r in range(rows):
        o = out[r]
        for b in range(bands):  # interleaved, each value's bytes minus those of the pixel before it
            d[b] = bits[b, r, 0]
            for c in range(1, cols):
                a, p = bits[b, r, c], bits[b, r, c - 1]
                d[c * bands + b] = ((a | high) - (p & low)) ^ ((a ^ ~p) & high)  # bytewise, no borrow
        for q in range(size):  # the byte planes, the most significant first
            shift = 8 * (size - 1 - q)
            base = q * width
            for j in range(width):
                o[base + j] = (d[j] >> shift) & 0xFF
            if q > 0:  # a plane's first pixel follows the previous plane's last one
                for b in range(bands):
                    last = (bits[b, r, cols - 1] >> (shift + 8)) & 0xFF
                    o[base + b] = (((bits[b, r, 0] >> shift) & 0xFF) - last) & 0xFF


@numba.njit(cache=True, nogil=True)
def _horizontal_rows(values: np.ndarray, out: np.ndarray) -> None:  # pragma: no cover - compiled
    """Predictor 2 of ``values`` (bands, rows, cols) into ``out`` (rows, cols, bands), wrapping as the
    integer type does."""
    bands, rows, cols = values.shape
    for r in range(rows):
        for b in range(bands):
            out[r, 0, b] = values[b, r, 0]
        for c in range(1, cols):
            for b in range(bands):
                out[r, c, b] = values[b, r, c] - values[b, r, c - 1]


#: the unsigned integer of a float's size, and its bytes' masks (0x80 and 0x7F in every byte)
_UNSIGNED = {4: (np.uint32, np.uint32(0x80808080), np.uint32(0x7F7F7F7F)),
             8: (np.uint64, np.uint64(0x8080808080808080), np.uint64(0x7F7F7F7F7F7F7F7F))}


def floating_point(block: np.ndarray) -> np.ndarray:
    """TIFF predictor 3 of a block ``(bands, rows, cols)`` of float32 or float64 (any strides).

    Returns
    -------
    (rows, cols * bands * itemsize) uint8 array: the bytes the TIFF stores before deflate.
    """
    bands, rows, cols = block.shape
    size = block.dtype.itemsize
    if block.dtype.kind != "f" or size not in _UNSIGNED:
        raise ValueError(f"floating_point: a float32 or float64 block, not {block.dtype}")
    native = block if block.dtype.isnative else block.astype(block.dtype.newbyteorder("="))
    out = np.empty((rows, size * cols * bands), np.uint8)
    unsigned, high, low = _UNSIGNED[size]
    _fp_rows(native.view(unsigned), out, high, low)
    return out


def horizontal(block: np.ndarray) -> np.ndarray:
    """TIFF predictor 2 of an integer block ``(bands, rows, cols)`` (any strides), pixel-interleaved.

    Returns
    -------
    (rows, cols, bands) array of the block's dtype, native byte order.
    """
    if block.dtype.kind not in "ui":
        raise ValueError(f"horizontal: an integer block, not {block.dtype}")
    native = block if block.dtype.isnative else block.astype(block.dtype.newbyteorder("="))
    out = np.empty((block.shape[1], block.shape[2], block.shape[0]), native.dtype)
    _horizontal_rows(native, out)
    return out


def floating_point_reference(rows: np.ndarray) -> np.ndarray:
    """Predictor 3 in numpy, of pixel-interleaved rows ``(rows, cols, samples)`` of floats (the
    reference of :func:`floating_point`).

    Returns
    -------
    (rows, cols * samples * itemsize) uint8 array.
    """
    n_rows, cols, samples = rows.shape
    size = rows.dtype.itemsize
    values = np.ascontiguousarray(rows, dtype=rows.dtype.newbyteorder("<")).reshape(n_rows, cols * samples)
    planes = values.view(np.uint8).reshape(n_rows, cols * samples, size)[:, :, ::-1]   # big-endian bytes
    b = np.ascontiguousarray(planes.transpose(0, 2, 1)).reshape(n_rows, size * cols * samples)
    out = np.empty_like(b)
    out[:, :samples] = b[:, :samples]
    np.subtract(b[:, samples:], b[:, :-samples], out=out[:, samples:])  # uint8: modulo 256
    return out


def horizontal_reference(rows: np.ndarray) -> np.ndarray:
    """Predictor 2 in numpy, of pixel-interleaved rows ``(rows, cols, samples)`` of integers.

    Returns
    -------
    (rows, cols, samples) array of the rows' dtype.
    """
    d = np.empty(rows.shape, rows.dtype)
    d[:, 0] = rows[:, 0]
    np.subtract(rows[:, 1:], rows[:, :-1], out=d[:, 1:])
    return d


__all__ = ["floating_point", "floating_point_reference", "horizontal", "horizontal_reference"]
