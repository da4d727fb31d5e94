"""Deterministic random fields: gridded spectral synthesis and point-evaluated lattice noise.

Gridded fields (terrain, DTM error) are made by filtering white noise in the Fourier domain.
Point-evaluated noise (the scene) is a hash-based value noise, so that any point of the ground can be
evaluated on its own, in any order and chunking, with the same result: images, points and the truth
orthoimage then sample one and the same scene.
"""
from __future__ import annotations

import numpy as np

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
    white = rng.standard_normal((pad_r, pad_c))
    fy = np.fft.fftfreq(pad_r, d=resolution_m)[:, None]
    fx = np.fft.rfftfreq(pad_c, d=resolution_m)[None, :]
    f = np.hypot(fx, fy)
    f_lo, f_hi = 1.0 / max_wavelength_m, 1.0 / min_wavelength_m
    with np.errstate(divide="ignore"):
        amplitude = np.where(f > 0, f, np.inf) ** -exponent if exponent else np.ones_like(f)
    amplitude = amplitude * np.exp(-((f / f_hi) ** 4)) * (1.0 - np.exp(-((f / f_lo) ** 4)))
    field = np.fft.irfft2(np.fft.rfft2(white) * amplitude, s=(pad_r, pad_c))[:rows, :cols]
    field -= field.mean()
    std = field.std()
    return field / std if std > 0 else field


def hash_uniform(ix: np.ndarray, iy: np.ndarray, seed: int) -> np.ndarray:
    """Uniform [0, 1) numbers from integer lattice coordinates and a seed (splitmix64 mixing)."""
    with np.errstate(over="ignore"):
        h = (np.asarray(ix).astype(np.int64).astype(np.uint64) * _M1) ^ (
            np.asarray(iy).astype(np.int64).astype(np.uint64) * _M3) ^ (np.uint64(seed & 0xFFFFFFFF) * _M2)
        h = (h ^ (h >> np.uint64(30))) * _M2
        h = (h ^ (h >> np.uint64(27))) * _M3
        h = h ^ (h >> np.uint64(31))
    return (h >> np.uint64(11)).astype(np.float64) / float(1 << 53)


def value_noise(x: np.ndarray, y: np.ndarray, wavelength_m: float, seed: int) -> np.ndarray:
    """Smooth lattice noise in [-1, 1] at map points, lattice spacing ``wavelength_m`` (C1, quintic fade)."""
    u = np.asarray(x, dtype=float) / wavelength_m
    v = np.asarray(y, dtype=float) / wavelength_m
    iu, iv = np.floor(u), np.floor(v)
    fu, fv = u - iu, v - iv
    fu = fu * fu * fu * (fu * (fu * 6 - 15) + 10)
    fv = fv * fv * fv * (fv * (fv * 6 - 15) + 10)
    a = hash_uniform(iu, iv, seed)
    b = hash_uniform(iu + 1, iv, seed)
    c = hash_uniform(iu, iv + 1, seed)
    d = hash_uniform(iu + 1, iv + 1, seed)
    top = a + fu * (b - a)
    bottom = c + fu * (d - c)
    return 2.0 * (top + fv * (bottom - top)) - 1.0


def fbm(x: np.ndarray, y: np.ndarray, wavelength_m: float, seed: int, octaves: int = 4,
        gain: float = 0.5) -> np.ndarray:
    """Fractal sum of value noise, octaves halving the wavelength; roughly in [-1, 1]."""
    total = np.zeros(np.shape(x))
    amplitude, norm = 1.0, 0.0
    for k in range(octaves):
        total += amplitude * value_noise(x, y, wavelength_m / 2**k, seed + 7919 * k)
        norm += amplitude
        amplitude *= gain
    return total / norm
