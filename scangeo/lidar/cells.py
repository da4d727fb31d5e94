"""The grid cells and the given (control and check) boxes of a strip, fitted from its returns streamed
chunk by chunk in time order, so that memory is bounded by the chunk and the number of cells, not by
the strip.

:class:`GridCellStream` bins the returns into the cells of ``patches.cell_keys`` and holds them only
until the strip has moved on: a cell no return has come to for ``close_after`` seconds (2 s: at
60 m/s that is 120 m of flight, at 20 m/s 40 m, many cell sizes; a straight strip never comes back)
is fitted (``patches.fit_cells``) and its returns are let go. The result equals the fit of the whole
strip at once whenever each cell's returns arrive within one such stretch (the tests hold the two
equal); a cell that a strip does revisit later is fitted twice, and the fit on more returns is kept.

:class:`BoxStream` keeps only the returns inside the given boxes (a few hundred per box).
"""

from __future__ import annotations

import numpy as np

from scangeo.lidar.patches import PatchOptions, StripPatches, box_members, cell_keys, fit_cells, fit_groups
from scangeo.lidar.planes import Planes

#: a grid cell no return has come to for this long (s) is complete
CLOSE_AFTER_S = 2.0


class GridCellStream:
    """Planar grid cells of one strip, its returns fed in time order (:meth:`feed`, :meth:`finish`)."""

    def __init__(self, strip: str, options: PatchOptions, prior_sigma: float, close_after: float = CLOSE_AFTER_S):
        self.strip, self.options, self.prior, self.close_after = strip, options, prior_sigma, close_after
        self._xyz: list[np.ndarray] = []
        self._t: list[np.ndarray] = []
        self._keys: list[np.ndarray] = []
        self._done: list[tuple[np.ndarray, Planes]] = []
        self.peak_pending = 0  # most returns held at once (the memory bound's measure)

    def feed(self, xyz: np.ndarray, t: np.ndarray) -> None:
        """A chunk of returns (map or project coordinates, GPS times)."""
        if not t.size:
            return
        self._xyz.append(np.asarray(xyz, float))
        self._t.append(np.asarray(t, float))
        self._keys.append(cell_keys(self._xyz[-1], self.options.size))
        xyz, t, keys = (np.concatenate(a) for a in (self._xyz, self._t, self._keys))
        self.peak_pending = max(self.peak_pending, t.size)
        uniq, inv = np.unique(keys, return_inverse=True)
        last = np.full(uniq.size, -np.inf)
        np.maximum.at(last, inv, t)
        closed = (last < t.max() - self.close_after)[inv]
        if closed.any():
            self._done.append(fit_cells(xyz[closed], t[closed], keys[closed], self.options, self.prior))
            open_ = ~closed
            xyz, t, keys = xyz[open_], t[open_], keys[open_]
        self._xyz, self._t, self._keys = [xyz], [t], [keys]

    def finish(self) -> StripPatches:
        """Fit the cells still open; every planar cell of the strip, sorted by cell key."""
        if self._t:
            xyz, t, keys = (np.concatenate(a) for a in (self._xyz, self._t, self._keys))
            self._done.append(fit_cells(xyz, t, keys, self.options, self.prior))
            self._xyz, self._t, self._keys = [], [], []
        if not self._done:
            self._done.append(fit_cells(np.zeros((0, 3)), np.zeros(0), np.zeros(0, np.int64), self.options, self.prior))
        cells = np.concatenate([c for c, _ in self._done])
        planes = Planes.concat([p for _, p in self._done])
        # sorted by cell; a cell fitted twice (a strip that came back) keeps the fit on more returns
        order = np.lexsort((-planes.count, cells))
        first = np.r_[True, cells[order][1:] != cells[order][:-1]] if cells.size else np.zeros(0, bool)
        keep = order[first]
        return StripPatches(self.strip, cells[keep], planes.take(keep))


class BoxStream:
    """Planes of a strip's returns inside given boxes (centre, unit axes (2, 2), half extents; map
    coordinates), fed chunk by chunk."""

    def __init__(self, centres: np.ndarray, axes: np.ndarray, half: np.ndarray, options: PatchOptions,
                 prior_sigma: float):
        self.centres, self.axes, self.half = centres, axes, half
        self.options, self.prior = options, prior_sigma
        self._parts: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []

    def feed(self, xyz: np.ndarray, t: np.ndarray) -> None:
        group, rows = box_members(xyz, self.centres, self.axes, self.half)
        if rows.size:
            self._parts.append((group, xyz[rows], t[rows]))

    def finish(self) -> tuple[Planes, np.ndarray]:
        """The planes of the boxes and which of them are accepted as planar."""
        m = self.centres.shape[0]
        g = np.concatenate([p[0] for p in self._parts]) if self._parts else np.zeros(0, np.int64)
        xyz = np.concatenate([p[1] for p in self._parts]) if self._parts else np.zeros((0, 3))
        t = np.concatenate([p[2] for p in self._parts]) if self._parts else np.zeros(0)
        ref = np.column_stack([self.centres, np.zeros(m)])
        if g.size:
            ref[:, 2] = np.bincount(g, xyz[:, 2], m) / np.maximum(np.bincount(g, minlength=m), 1)
        return fit_groups(xyz, t, g, m, ref, self.options, self.prior)
