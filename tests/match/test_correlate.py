"""Correlation and least-squares matching of one template; the local affine consistency test."""
from __future__ import annotations

import cv2
import numpy as np
import pytest

from scangeo.match.consistency import local_affine_inliers, precision_from_loo
from scangeo.match.correlate import match_template, ncc_match, prepare


def _texture(seed: int, size: int = 160, blur: float = 1.5) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return cv2.GaussianBlur(rng.normal(size=(size, size)).astype(np.float32), (0, 0), blur)


def _shifted(image: np.ndarray, dx: float, dy: float) -> np.ndarray:
    """``image`` moved by (dx, dy): the feature at (c, r) appears at (c + dx, r + dy)."""
    m = np.float32([[1, 0, dx], [0, 1, dy]])
    return cv2.warpAffine(image, m, image.shape[::-1], flags=cv2.INTER_CUBIC, borderMode=cv2.BORDER_REFLECT)


def test_known_subpixel_shifts_are_recovered_with_an_honest_sigma():
    base = _texture(1)
    rng = np.random.default_rng(2)
    errors, sigmas = [], []
    for _ in range(20):
        dx, dy = rng.uniform(-6, 6, 2)
        moved = _shifted(base, dx, dy) + rng.normal(scale=0.03 * base.std(), size=base.shape).astype(np.float32)
        m, reason = match_template(base[70:91, 70:91], prepare(moved), 80, 80, 10, 0.7, 0.99, 0.5)
        assert m is not None, reason
        errors.append([m.x - 80 - dx, m.y - 80 - dy])
        sigmas.append(m.sigma)
    rms = float(np.sqrt(np.mean(np.square(errors))))
    assert rms < 0.02
    # the LSM sigma (noise only) is of the size of the error actually made
    assert 0.3 < float(np.mean(sigmas)) / rms < 3.0


def test_correlation_alone_is_good_to_a_few_tenths():
    base = _texture(3)
    moved = _shifted(base, 2.3, -1.6)
    x, y, peak, second = ncc_match(base[70:91, 70:91], moved, 80, 80, 8)
    assert abs(x - 82.3) < 0.25 and abs(y - 78.4) < 0.25
    assert peak > 0.95 and second < 0.9


def test_featureless_periodic_and_out_of_range_templates_are_rejected():
    flat = np.full((120, 120), 7.0, np.float32)
    assert match_template(flat[50:71, 50:71], prepare(flat), 60, 60, 8, 0.7, 0.99, 0.5)[0] is None
    stripes = np.tile(np.sin(np.arange(120) * 2 * np.pi / 6.0).astype(np.float32), (120, 1))
    m, reason = match_template(stripes[50:71, 50:71], prepare(stripes), 60, 60, 8, 0.7, 0.95, 0.5)
    assert m is None and reason in ("ambiguous", "lsm failed", "no peak")
    base = _texture(4)
    moved = _shifted(base, 12.0, 0.0)  # beyond a search radius of 8
    assert match_template(base[70:91, 70:91], prepare(moved), 80, 80, 8, 0.7, 0.99, 0.5)[0] is None


def test_local_affine_ransac_finds_injected_outliers_and_the_precision():
    rng = np.random.default_rng(5)
    src = rng.uniform(0, 400, (150, 2))
    A = np.array([[1.001, 0.002], [-0.001, 0.999]])
    dst = src @ A.T + [3.0, -2.0] + 2e-5 * src**2 + rng.normal(scale=0.1, size=src.shape)
    bad = rng.choice(150, 8, replace=False)
    dst[bad] += rng.choice([-1, 1], (8, 2)) * rng.uniform(2, 6, (8, 2))
    inlier, loo = local_affine_inliers(src, dst, threshold=1.0, k=12)
    assert set(np.flatnonzero(~inlier)) == set(bad.tolist())
    assert precision_from_loo(loo[inlier], 12) == pytest.approx(0.1, rel=0.25)
