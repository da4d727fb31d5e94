"""Pass 1 of the patch search (Kager 2004): a strip read in time order through a moving row buffer.

A strip's returns arrive in time order. Its topology is time x nadir (scan) angle: consecutive
returns of one mirror sweep form a *scan line*, consecutive lines follow each other along the
flight. This grid has no loops and no search, unlike the map plane where strips overlap and
cross. The buffer keeps the returns of the lines not yet grouped (at most one window of lines plus
the chunk being read) and works on them as they complete:

- **scan lines** end where the scan angle turns (an oscillating mirror: the sign of its change
  flips) or jumps back (a rotating polygon or a Palmer scanner's wrap), so one line is one
  monotone sweep; returns of one pulse (same angle) stay in its line;
- **windows along the flight**: a line's along-track position is the distance its centroid moved
  from the previous line's, measured perpendicular to the line (so the zigzag of an oscillating
  mirror and buildings across the line do not count), summed; the lines whose sum falls into one
  ``size`` step form one window;
- **bins across**: in a window, the scan angle is cut into steps of ``size / (metres per radian)``,
  the metres per radian measured on the window's own lines (ground distance from first to last
  return over their angle span), so a patch is about ``size`` wide on the ground at any flying
  height above any terrain, and the bin straddling nadir is centred on it;
- every (window, bin) cell with at least ``min_points`` returns is a plane with data snooping
  (:mod:`scangeo.lidar.plane_kernel`) and a *candidate* when it meets the criteria of
  :class:`~scangeo.lidar.patches.PatchOptions`: enough returns left, plane sigma, share of returns
  snooping removed, and slope.

Each candidate keeps its plane and footprint (centre, in-plane axes projected to the map, half
extents ``sqrt(3)`` times the spread of its returns: the half width of a uniformly covered
rectangle). The candidates of every strip seed pass 2 (:mod:`scangeo.lidar.seeded`).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from scangeo.lidar.patches import PatchOptions
from scangeo.lidar.plane_kernel import fit_planes
from scangeo.lidar.planes import Planes


@dataclass
class Candidates:
    """Pass 1's candidate patches of one strip: planes and map footprints (boxes), and the strip's
    along-track ground speed (m/s; pass 2 closes a patch once the strip has moved past it)."""

    strip: str
    planes: Planes
    centre: np.ndarray  # (m, 2) map
    axes: np.ndarray  # (m, 2, 2) unit axes (rows) of the footprint box in the map
    half: np.ndarray  # (m, 2) half extents along them
    speed: float
    returns: int
    lines: int
    bounds: tuple[float, float, float, float]

    @property
    def size(self) -> int:
        return int(self.centre.shape[0])


def accepted(planes: Planes, options: PatchOptions) -> np.ndarray:
    """The criteria of a patch: returns kept, plane sigma, share removed by snooping, slope."""
    total = planes.count + planes.rejected
    slope = np.degrees(np.arccos(np.clip(np.abs(planes.normal[:, 2]), 0.0, 1.0)))
    return (
        (planes.count >= options.min_points)
        & (planes.sigma < options.max_sigma)
        & (planes.rejected <= options.max_rejected * total)
        & (slope <= options.max_slope_deg)
    )


def footprints(planes: Planes) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Map boxes of planes: centre (m, 2), unit axes (m, 2, 2) along the planes' principal axes, half
    extents (m, 2) ``sqrt(3)`` times the spread of their returns (a uniformly covered rectangle's)."""
    ax = planes.axes[:, :, :2]
    length = np.linalg.norm(ax, axis=2)
    unit = ax / np.maximum(length, 1e-9)[:, :, None]
    # the second axis perpendicular to the first in the map (a roof's axes project to a non-orthogonal pair)
    unit[:, 1] = np.column_stack([-unit[:, 0, 1], unit[:, 0, 0]])
    half = np.sqrt(3.0) * planes.spread * length
    return planes.centroid[:, :2].copy(), unit, half


def _empty_planes() -> Planes:
    z = np.zeros(0)
    return Planes(z, z, np.zeros((0, 3)), np.zeros((0, 3)), z, np.zeros((0, 2, 3)), np.zeros((0, 2)), z,
                  np.zeros((0, 2)))


def concat_planes(parts: list[Planes]) -> Planes:
    if not parts:
        return _empty_planes()
    return Planes(*(np.concatenate([getattr(p, f) for p in parts]) for f in Planes.__dataclass_fields__))


class RowBuffer:
    """Pass 1 over one strip: :meth:`feed` chunks of returns in time order, then :meth:`finish`."""

    def __init__(
        self, strip: str, options: PatchOptions, prior_sigma: float, shifts: tuple[float, ...] = (0.0,)
    ) -> None:
        """``shifts``: tilings of the angle bins, in bins (``(0.0, 0.5)`` adds a tiling offset by half a
        bin: more roof faces fall into one window, at twice the cost)."""
        self.strip = strip
        self.shifts = shifts
        self.options = options
        self.prior = prior_sigma
        self._xyz = np.zeros((0, 3))
        self._t = np.zeros(0)
        self._angle = np.zeros(0)
        self._line = np.zeros(0, np.int64)
        self._last_angle: float | None = None
        self._last_sign = 0.0
        self._next_line = 0
        self._angle_lo, self._angle_hi = np.inf, -np.inf
        # per completed line: window index; the along-track sum and centroid of the last one
        self._done_lines = 0
        self._along = 0.0
        self._centroid: np.ndarray | None = None
        self._line_window: list[np.ndarray] = []
        self._line_mpr: list[np.ndarray] = []
        self._lines_window = np.zeros(0, np.int64)
        self._lines_mpr = np.zeros(0)
        self._first_window = 0
        self._planes: list[Planes] = []
        self.returns = 0
        self._t0: float | None = None
        self._t1: float | None = None
        self._lo = np.array([np.inf, np.inf])
        self._hi = np.array([-np.inf, -np.inf])

    # --- scan lines ------------------------------------------------------------------------------
    def _lines_of(self, angle: np.ndarray) -> np.ndarray:
        """Line index of every return of a chunk (the state carries over from the previous chunk)."""
        self._angle_lo = min(self._angle_lo, float(angle.min()))
        self._angle_hi = max(self._angle_hi, float(angle.max()))
        prev = angle[0] if self._last_angle is None else self._last_angle
        d = np.diff(angle, prepend=prev)
        jump = np.abs(d) > 0.5 * max(self._angle_hi - self._angle_lo, 1e-9)
        s = np.sign(np.where(jump, 0.0, d))
        # returns without a change of angle (several returns of a pulse) keep the previous direction
        filled = np.where(s != 0, np.arange(s.size), -1)
        np.maximum.accumulate(filled, out=filled)
        s = np.where(filled >= 0, s[np.maximum(filled, 0)], self._last_sign)
        before = np.r_[self._last_sign, s[:-1]]
        brk = jump | ((s != before) & (before != 0))
        line = self._next_line + np.cumsum(brk)
        self._next_line = int(line[-1])
        self._last_angle, self._last_sign = float(angle[-1]), float(s[-1])
        return line

    def feed(self, xyz: np.ndarray, t: np.ndarray, angle: np.ndarray) -> None:
        """Add returns (map coordinates (n, 3), GPS time (n,), scan angle (n,) rad) in time order."""
        if t.size == 0:
            return
        self.returns += int(t.size)
        self._t0 = float(t[0]) if self._t0 is None else self._t0
        self._t1 = float(t[-1])
        self._lo = np.minimum(self._lo, xyz[:, :2].min(axis=0))
        self._hi = np.maximum(self._hi, xyz[:, :2].max(axis=0))
        line = self._lines_of(np.asarray(angle, float))
        self._xyz = np.concatenate([self._xyz, xyz])
        self._t = np.concatenate([self._t, t])
        self._angle = np.concatenate([self._angle, angle])
        self._line = np.concatenate([self._line, line])
        self._process(final=False)

    def _complete_lines(self, upto: int) -> None:
        """Along-track position, window and metres per radian of the buffered lines below ``upto``."""
        first_line = self._done_lines
        if upto <= first_line:
            return
        sel = self._line < upto
        sel &= self._line >= first_line
        idx = np.flatnonzero(sel)
        local = self._line[idx] - first_line
        k = upto - first_line
        count = np.bincount(local, minlength=k).astype(float)
        xy = self._xyz[idx, :2]
        cen = np.column_stack([np.bincount(local, xy[:, j], k) for j in range(2)]) / np.maximum(count, 1)[:, None]
        starts = np.searchsorted(local, np.arange(k))
        ends = np.searchsorted(local, np.arange(k), side="right") - 1
        first, last = idx[np.minimum(starts, idx.size - 1)], idx[np.maximum(ends, 0)]
        across = self._xyz[last, :2] - self._xyz[first, :2]
        span = np.abs(self._angle[last] - self._angle[first])
        width = np.linalg.norm(across, axis=1)
        mpr = np.where(span > 0, width / np.maximum(span, 1e-12), np.nan)
        along_dir = np.column_stack([-across[:, 1], across[:, 0]]) / np.maximum(width, 1e-9)[:, None]
        # every line id below ``upto`` has returns (ids come from counting breaks)
        prev = np.vstack([cen[:1] if self._centroid is None else self._centroid[None], cen[:-1]])
        step = np.where(width > 0, np.abs(np.einsum("ij,ij->i", cen - prev, along_dir)), 0.0)
        along = self._along + np.cumsum(step)
        window = (along // self.options.size).astype(np.int64)
        self._along, self._centroid = float(along[-1]), cen[-1]
        self._lines_window = np.r_[self._lines_window, window]
        self._lines_mpr = np.r_[self._lines_mpr, mpr]
        self._done_lines = upto

    def _process(self, final: bool) -> None:
        if self._t.size == 0:
            return
        last_line = int(self._line[-1])
        self._complete_lines(last_line + 1 if final else last_line)
        if self._done_lines == 0:
            return
        win_of_line = self._lines_window
        if final:
            n_ready = self._t.size
        else:
            # returns of the lines before the first line of the last (still open) window: a prefix
            first_open = int(np.searchsorted(win_of_line, win_of_line[-1], "left"))
            n_ready = int(np.searchsorted(self._line, first_open, "left"))
        if n_ready == 0:
            return
        self._group(slice(0, n_ready), win_of_line[self._line[:n_ready]])
        self._xyz, self._t = self._xyz[n_ready:], self._t[n_ready:]
        self._angle, self._line = self._angle[n_ready:], self._line[n_ready:]

    def _group(self, rows: slice, window: np.ndarray) -> None:
        """Cut the ready returns into (window, angle bin) cells and fit the candidates' planes."""
        o = self.options
        lines = self._line[rows]
        mpr_line = self._lines_mpr[lines]
        w0 = int(window.min())
        nw = int(window.max()) - w0 + 1
        ok = np.isfinite(mpr_line)
        lines_per_window = np.maximum(np.bincount(window[ok] - w0, minlength=nw), 1)
        mpr_w = np.bincount(window[ok] - w0, mpr_line[ok], nw) / lines_per_window
        step = o.size / np.where(mpr_w > 0, mpr_w, np.inf)[window - w0]
        scaled = self._angle[rows] / np.where(np.isfinite(step) & (step > 0), step, np.inf)
        scaled = np.where(np.isfinite(scaled), scaled, 0.0)
        xyz, t = self._xyz[rows], self._t[rows]
        for shift in self.shifts:
            b = np.floor(scaled + 0.5 + shift).astype(np.int64)
            b -= b.min()
            key = (window - w0).astype(np.int64) * (int(b.max()) + 1) + b
            counts = np.bincount(key)
            big = counts >= o.min_points
            if not big.any():
                continue
            remap = np.full(counts.size, -1, np.int64)
            remap[big] = np.arange(int(big.sum()))
            gg = remap[key]
            sel = gg >= 0
            planes = fit_planes(xyz[sel], gg[sel], int(big.sum()), self.prior, t[sel], o.critical_value)
            self._planes.append(planes.take(accepted(planes, o)))

    def finish(self) -> Candidates:
        """Group what remains; the strip's candidates."""
        self._process(final=True)
        planes = concat_planes(self._planes)
        centre, axes, half = footprints(planes)
        duration = (self._t1 - self._t0) if self._t0 is not None and self._t1 is not None else 0.0
        speed = self._along / duration if duration > 0 else 0.0
        bounds = (float(self._lo[0]), float(self._lo[1]), float(self._hi[0]), float(self._hi[1]))
        return Candidates(self.strip, planes, centre, axes, half, speed, self.returns, self._next_line + 1, bounds)


def search_strip(
    strip: str, chunks: Iterable[tuple[np.ndarray, np.ndarray, np.ndarray]], options: PatchOptions, prior_sigma: float
) -> Candidates:
    """Pass 1 of one strip from chunks ``(xyz, t, angle)`` in time order."""
    buffer = RowBuffer(strip, options, prior_sigma)
    for xyz, t, angle in chunks:
        buffer.feed(xyz, t, angle)
    return buffer.finish()
