"""Area-based matching of one template: normalised cross-correlation, then least-squares matching.

Both images are chips on one common ground grid (rectified overlap chips, or a strip chip and a
reference chip), so the geometric difference between them is a small shift plus a near-identity
affine. :func:`ncc_match` finds the integer peak of the normalised cross-correlation inside the
search radius, refines it with a parabola through the peak and its neighbours, and rejects weak or
ambiguous peaks; :func:`lsm_refine` then solves the least-squares matching of the template against
the search image (6 affine + 2 radiometric parameters, Gauss-Newton on the bicubic image) and
returns the refined position with its standard deviation from the adjustment's covariance.

Positions are (x, y) = (column, row) of chip cells, cell centres at integers (OpenCV's convention).
"""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

#: largest number of Gauss-Newton iterations of least-squares matching
LSM_ITERATIONS = 12
#: a shift update below this (cells) ends the iterations
LSM_TOLERANCE = 1e-3
#: LSM may move the position at most this far from the correlation peak, cells
LSM_MAX_MOVE = 1.5


@dataclass(frozen=True)
class Match:
    """One template's match: position in the search image, quality."""

    x: float
    y: float
    correlation: float
    sigma: float  # standard deviation of the position, cells (rms of x and y)
    second_peak: float = 0.0


def ncc_match(template: np.ndarray, image: np.ndarray, x0: float, y0: float, radius: int) -> tuple[
        float, float, float, float] | None:
    """Normalised cross-correlation peak of ``template`` in ``image`` within ``radius`` of (x0, y0).

    Returns (x, y, peak, second) with a parabolic sub-cell peak and ``second`` the highest
    correlation more than 2 cells from the peak (as a share of the peak), or None when the search
    window leaves the image or the template has no contrast.
    """
    h = template.shape[0] // 2
    cx, cy = int(round(x0)), int(round(y0))
    r0, r1 = cy - h - radius, cy + h + radius + 1
    c0, c1 = cx - h - radius, cx + h + radius + 1
    if r0 < 0 or c0 < 0 or r1 > image.shape[0] or c1 > image.shape[1]:
        return None
    if float(template.std()) < 1e-6:
        return None
    window = image[r0:r1, c0:c1]
    if not np.isfinite(window).all():
        return None
    score = cv2.matchTemplate(window, template, cv2.TM_CCOEFF_NORMED)
    iy, ix = np.unravel_index(int(np.argmax(score)), score.shape)
    peak = float(score[iy, ix])
    if not 0 < iy < score.shape[0] - 1 or not 0 < ix < score.shape[1] - 1:
        return None  # the peak is on the border of the search range: the true one may be outside
    # the second-highest local maximum away from the peak (a broad peak is not ambiguous)
    local = score >= cv2.dilate(score, np.ones((3, 3), np.uint8))
    local[max(iy - 2, 0):iy + 3, max(ix - 2, 0):ix + 3] = False
    others = score[local]
    second = float(others.max()) / peak if peak > 0 and others.size else 0.0
    dx = _parabola(score[iy, ix - 1], peak, score[iy, ix + 1])
    dy = _parabola(score[iy - 1, ix], peak, score[iy + 1, ix])
    return c0 + h + ix + dx, r0 + h + iy + dy, peak, second


def _parabola(left: float, centre: float, right: float) -> float:
    den = left - 2.0 * centre + right
    return 0.0 if den >= 0 else float(np.clip(0.5 * (left - right) / den, -0.5, 0.5))


def lsm_refine(template: np.ndarray, image: np.ndarray, gx: np.ndarray, gy: np.ndarray, x0: float, y0: float
               ) -> tuple[float, float, float] | None:
    """Least-squares matching of ``template`` in ``image`` from the start (x0, y0).

    Parameters
    ----------
    template : (t, t) float32, t odd; its centre cell is the point.
    image, gx, gy : float32 search image and its x and y gradients (same shape).
    x0, y0 : start position of the template's centre in ``image``, cells.

    Returns
    -------
    (x, y, sigma) with sigma the rms of the standard deviations of x and y (cells), or None when
    the iterations diverge or leave the image.
    """
    h = template.shape[0] // 2
    v, u = np.mgrid[-h:h + 1, -h:h + 1].astype(np.float32)
    u, v = u.ravel(), v.ravel()
    t = template.ravel().astype(np.float64)
    # x = x0 + p0 + (1 + p2) u + p3 v ; y = y0 + p1 + p4 u + (1 + p5) v ; t = r0 + r1 * image(x, y)
    p = np.zeros(6)
    r = np.array([0.0, 1.0])
    cov = None
    res = np.zeros(1)
    for _ in range(LSM_ITERATIONS):
        X = (x0 + p[0] + (1 + p[2]) * u + p[3] * v).astype(np.float32)
        Y = (y0 + p[1] + p[4] * u + (1 + p[5]) * v).astype(np.float32)
        if X.min() < 1 or Y.min() < 1 or X.max() > image.shape[1] - 3 or Y.max() > image.shape[0] - 3:
            return None
        g = _sample(image, X, Y)
        sx, sy = r[1] * _sample(gx, X, Y), r[1] * _sample(gy, X, Y)
        A = np.column_stack([sx, sy, sx * u, sx * v, sy * u, sy * v, np.ones_like(g), g])
        res = t - (r[0] + r[1] * g)
        N = A.T @ A
        try:
            d = np.linalg.solve(N, A.T @ res)
        except np.linalg.LinAlgError:
            return None
        p += d[:6]
        r += d[6:]
        cov = N
        if abs(d[0]) < LSM_TOLERANCE and abs(d[1]) < LSM_TOLERANCE:
            break
    else:
        return None
    if abs(p[0]) > LSM_MAX_MOVE or abs(p[1]) > LSM_MAX_MOVE or abs(r[1]) < 1e-6:
        return None
    dof = max(t.size - 8, 1)
    s0 = float(res @ res) / dof
    try:
        q = np.linalg.inv(cov)
    except np.linalg.LinAlgError:
        return None
    sigma = float(np.sqrt(0.5 * s0 * (q[0, 0] + q[1, 1])))
    return x0 + float(p[0]), y0 + float(p[1]), sigma


def _sample(image: np.ndarray, X: np.ndarray, Y: np.ndarray) -> np.ndarray:
    out = cv2.remap(image, X.reshape(1, -1), Y.reshape(1, -1), cv2.INTER_CUBIC, borderMode=cv2.BORDER_REPLICATE)
    return out.ravel().astype(np.float64)


def gradients(image: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Central-difference x and y gradients of a float32 image (cells^-1)."""
    gx = cv2.Sobel(image, cv2.CV_32F, 1, 0, ksize=1, scale=0.5)
    gy = cv2.Sobel(image, cv2.CV_32F, 0, 1, ksize=1, scale=0.5)
    return gx, gy


def smooth(image: np.ndarray, sigma: float) -> np.ndarray:
    """Gaussian smoothing of a float32 image with NaN holes (the holes stay NaN)."""
    if sigma <= 0:
        return image
    finite = np.isfinite(image)
    filled = np.where(finite, image, float(image[finite].mean()) if finite.any() else 0.0).astype(np.float32)
    out = cv2.GaussianBlur(filled, (0, 0), sigma)
    out[~finite] = np.nan
    return out


def prepare(image: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(image with NaN, image with NaN filled by its mean, x gradient, y gradient) for matching."""
    finite = np.isfinite(image)
    filled = np.where(finite, image, float(image[finite].mean()) if finite.any() else 0.0).astype(np.float32)
    return (image.astype(np.float32), filled, *gradients(filled))


def match_template(template: np.ndarray, prepared: tuple, x0: float, y0: float, radius: int,
                   min_correlation: float, max_second_peak: float, max_sigma: float) -> tuple[Match | None, str]:
    """Correlation, then least-squares matching in a :func:`prepare`-d image.

    Returns (match, "") or (None, the reason of the rejection).
    """
    image, filled, gx, gy = prepared
    found = ncc_match(template, image, x0, y0, radius)
    if found is None:
        return None, "no peak"
    x, y, peak, second = found
    if peak < min_correlation:
        return None, "weak correlation"
    if second > max_second_peak:
        return None, "ambiguous"
    refined = lsm_refine(template, filled, gx, gy, x, y)
    if refined is None:
        return None, "lsm failed"
    xr, yr, sigma = refined
    if sigma > max_sigma:
        return None, "imprecise"
    return Match(xr, yr, peak, sigma, second), ""
