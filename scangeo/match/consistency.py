"""Outlier removal and precision from the matches' own consistency: local affine RANSAC.

Between two chips rectified with the same (DG or adjusted) orientation, the displacement of a
matched point is the relative orientation error of the two strips at that place: smooth over a few
hundred metres. Around every match, its ``k`` nearest neighbours give a local affine transformation
(``cv2.estimateAffine2D`` with RANSAC, threshold in chip cells); a match farther than the threshold
from the affine of its neighbourhood is an outlier. The leave-one-out residuals of the inliers
(each predicted by the least-squares affine of its inlier neighbours) estimate the matching
precision without any truth.
"""
from __future__ import annotations

import cv2
import numpy as np


def _affine_fit(src: np.ndarray, dst: np.ndarray) -> np.ndarray | None:
    """Least-squares affine (2, 3) mapping src -> dst; None when under-determined."""
    if len(src) < 4:
        return None
    A = np.column_stack([src, np.ones(len(src))])
    coef, *_ = np.linalg.lstsq(A, dst, rcond=None)
    return coef.T


def local_affine_inliers(src: np.ndarray, dst: np.ndarray, threshold: float, k: int
                         ) -> tuple[np.ndarray, np.ndarray]:
    """Inlier flags and leave-one-out residuals (n, 2) of matches src -> dst (chip cells).

    Fewer than 4 matches cannot be tested: they all pass, with NaN residuals.
    """
    n = len(src)
    inlier = np.ones(n, bool)
    loo = np.full((n, 2), np.nan)
    if n < 4:
        return inlier, loo
    centre = src.mean(axis=0)
    s, d = src - centre, dst - centre
    k = min(k, n)
    dist = np.linalg.norm(s[:, None, :] - s[None, :, :], axis=2)
    order = np.argsort(dist, axis=1)[:, :k]
    for i in range(n):
        nb = order[i]
        M, _ = cv2.estimateAffine2D(s[nb].astype(np.float32).reshape(-1, 1, 2),
                                    d[nb].astype(np.float32).reshape(-1, 1, 2), method=cv2.RANSAC,
                                    ransacReprojThreshold=threshold, maxIters=500, confidence=0.995)
        if M is None:
            continue
        pred = M[:, :2] @ s[i] + M[:, 2]
        inlier[i] = bool(np.linalg.norm(pred - d[i]) <= threshold)
    for i in np.flatnonzero(inlier).tolist():
        nb = [j for j in order[i] if j != i and inlier[j]]
        M = _affine_fit(s[nb], d[nb])
        if M is not None:
            loo[i] = d[i] - (M[:, :2] @ s[i] + M[:, 2])
    return inlier, loo


def precision_from_loo(loo: np.ndarray, k: int) -> float:
    """Per-coordinate precision (chip cells) from leave-one-out residuals of affine fits of ``k - 1``
    neighbours: rms over both coordinates, less the fitted affine's share (about 3 / (k - 1))."""
    r = loo[np.isfinite(loo).all(axis=1)]
    if len(r) == 0:
        return float("nan")
    rms = float(np.sqrt(np.mean(r**2)))
    return rms / np.sqrt(1.0 + 3.0 / max(k - 1, 1))
