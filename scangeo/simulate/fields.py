"""Deterministic random fields: gridded spectral synthesis and point-evaluated lattice noise.

Gridded fields (terrain, DTM error) are made by filtering white noise in the Fourier domain.
Point-evaluated noise (the scene) is a hash-based value noise, so that any point of the ground can be
evaluated on its own, in any order and chunking, with the same result: images, points and the truth
orthoimage then sample one and the same scene.
"""
from __future__ import annotations

import math

import numba as nb
import numpy as np

from scangeo.threading_layer import choose_threading_layer

_M1 = np.uint64(0x9E3779B97F4A7C15)
_M2 = np.uint64(0xBF58476D1CE4E5B9)
_M3 = np.uint64(0x94D049BB133111EB)


def spectral_field(shape: tuple[int, int], resolution_m: float, rng: np.random.Generator,
                   min_wavelength_m: float, max_wavelength_m: float, exponent: float = 0.0) -> np.ndarray:
    """A zero-mean, unit-variance random field on a grid, band-limited between two wavelengths.

    Parameters
    ----------
    shape : (rows, cols) of the grid.
    resolution_m : grid spacing, metres.
    min_wavelength_m, max_wavelength_m : the band of wavelengths kept (smooth roll-off at both ends).
    exponent : power-law slope of the amplitude spectrum (amplitude ~ f^-exponent); 0 is flat.
    """
    rows, cols = shape
    pad_r, pad_c = rows + rows // 2 + 8, cols + cols // 2 + 8  # padding against wrap-around
    # memory: a 96-strip block's terrain grid is 24 M cells, padded 54 M. The transforms run one
    # axis at a time, in bands of rows where the axis allows (the white noise drawn band by band:
    # the same stream), the filter is applied in place, and only the rows kept are transformed back.
    band = 256
    spectrum = np.empty((pad_r, pad_c // 2 + 1), dtype=complex)
    for a in range(0, pad_r, band):
        spectrum[a:a + band] = np.fft.rfft(rng.standard_normal((min(band, pad_r - a), pad_c)), axis=1)
    np.fft.fft(spectrum, axis=0, out=spectrum)
    fy_all = np.fft.fftfreq(pad_r, d=resolution_m)[:, None]
    fx = np.fft.rfftfreq(pad_c, d=resolution_m)[None, :]
    f_lo, f_hi = 1.0 / max_wavelength_m, 1.0 / min_wavelength_m
    for a in range(0, pad_r, band):
        f = np.hypot(fx, fy_all[a:a + band])
        with np.errstate(divide="ignore"):
            amplitude = np.where(f > 0, f, np.inf) ** -exponent if exponent else np.ones_like(f)
        spectrum[a:a + band] *= amplitude * np.exp(-((f / f_hi) ** 4)) * (1.0 - np.exp(-((f / f_lo) ** 4)))
    np.fft.ifft(spectrum, axis=0, out=spectrum)
    field = np.empty((rows, cols))
    for a in range(0, rows, band):
        field[a:a + band] = np.fft.irfft(spectrum[a:min(a + band, rows)], n=pad_c, axis=1)[:, :cols]
    del spectrum
    field -= field.mean()
    std = field.std()
    return field / std if std > 0 else field


@nb.njit(cache=True, inline="always")
def hash01(ix: float, iy: float, seed: int) -> float:
    """Uniform [0, 1) number from integer lattice coordinates and a seed (splitmix64 mixing)."""
    h = (np.uint64(np.int64(ix)) * _M1) ^ (np.uint64(np.int64(iy)) * _M3) ^ (np.uint64(seed & 0xFFFFFFFF) * _M2)
    h = (h ^ (h >> np.uint64(30))) * _M2
    h = (h ^ (h >> np.uint64(27))) * _M3
    h = h ^ (h >> np.uint64(31))
    return float(h >> np.uint64(11)) / 9007199254740992.0


@nb.njit(cache=True)
def noise_at(x: float, y: float, wavelength_m: float, seed: int) -> float:
    """Smooth lattice noise in [-1, 1] at one map point, lattice spacing ``wavelength_m`` (C1, quintic fade)."""
    u = x / wavelength_m
    v = y / wavelength_m
    iu = math.floor(u)
    iv = math.floor(v)
    fu = u - iu
    fv = v - iv
    fu = fu * fu * fu * (fu * (fu * 6 - 15) + 10)
    fv = fv * fv * fv * (fv * (fv * 6 - 15) + 10)
    a = hash01(iu, iv, seed)
    b = hash01(iu + 1, iv, seed)
    c = hash01(iu, iv + 1, seed)
    d = hash01(iu + 1, iv + 1, seed)
    top = a + fu * (b - a)
    bottom = c + fu * (d - c)
    return 2.0 * (top + fv * (bottom - top)) - 1.0


@nb.njit(cache=True)
def fbm_at(x: float, y: float, wavelength_m: float, seed: int, octaves: int = 4, gain: float = 0.5) -> float:
    """Fractal sum of lattice noise at one point, octaves halving the wavelength; roughly in [-1, 1]."""
    total = 0.0
    amplitude = 1.0
    norm = 0.0
    wl = wavelength_m
    for k in range(octaves):
        total += amplitude * noise_at(x, y, wl, seed + 7919 * k)
        norm += amplitude
        amplitude *= gain
        wl *= 0.5
    return total / norm


@nb.njit(parallel=True, cache=True)
def _fbm_array(x, y, wavelength_m, seed, octaves, gain, out):
    for i in nb.prange(x.size):
        out[i] = fbm_at(x[i], y[i], wavelength_m, seed, octaves, gain)


def fbm(x: np.ndarray, y: np.ndarray, wavelength_m: float, seed: int, octaves: int = 4,
        gain: float = 0.5) -> np.ndarray:
    """Fractal noise (``fbm_at``) at arrays of map points."""
    xa = np.ascontiguousarray(np.asarray(x, dtype=float).ravel())
    ya = np.ascontiguousarray(np.broadcast_to(np.asarray(y, dtype=float), np.shape(x)).ravel())
    out = np.empty(xa.size)
    choose_threading_layer()
    _fbm_array(xa, ya, float(wavelength_m), int(seed), int(octaves), float(gain), out)
    return out.reshape(np.shape(x))
