"""Ground observations: control coordinates (XYZ, XY or Z) in the map CRS, and DTM heights.

The unknowns are ground points in the project frame (``Ground(point)``, metres). Control coordinates
are observed in the map CRS (x, y and orthometric height H), so the observation is
``map(P) - observed``; the derivatives of the map conversion are central differences of 1 cm (the
conversion is smooth at that scale). A DTM height is the observation ``H(P) - DTM(x(P), y(P)) = 0``
with the DTM's sigma, linearised with the DTM's slope (``DTM.height_condition``).
"""
from __future__ import annotations

import numpy as np

from scangeo.adjustment.keys import Ground
from scangeo.frames import MapFrame
from scangeo.lsq.observations import Linearisation, ObservationGroup
from scangeo.lsq.parameters import JacobianPart

_AXES = {"x": 0, "y": 1, "z": 2}


def _stack(values, keys) -> np.ndarray:
    return np.array([values[k] for k in keys], dtype=float).reshape(-1, 3)


class GroundControl(ObservationGroup):
    """Observed map coordinates of ground points.

    Parameters
    ----------
    points : (n,) point ids.
    xyz : (n, 3) observed map x, y (CRS units, metres) and orthometric height (m).
    sigma : (n, 3) their standard deviations (m).
    components : (n, 3) bool, which coordinates are observed (XYZ, XY or Z control).
    map_frame : map CRS <-> project frame.
    """

    def __init__(self, points, xyz, sigma, components, map_frame: MapFrame, name: str = "ground control") -> None:
        self.name = name
        self.points = np.asarray(points, dtype=object)
        self._keys = [Ground(str(p)) for p in self.points]
        comp = np.asarray(components, bool)
        self._point_of_row, self._axis_of_row = np.nonzero(comp)
        self.observed = np.asarray(xyz, float)[self._point_of_row, self._axis_of_row]
        self.sigma = np.asarray(sigma, float)[self._point_of_row, self._axis_of_row]
        self.map_frame = map_frame
        self._describe(self.points[self._point_of_row], np.array(["x", "y", "z"])[self._axis_of_row], "m",
                       self._point_of_row)

    def keys(self):
        return self._keys

    def _map(self, p_P: np.ndarray) -> np.ndarray:
        x, y, H = self.map_frame.project_to_map(p_P)
        return np.column_stack([x, y, H])

    def residuals(self, values) -> np.ndarray:
        m = self._map(_stack(values, self._keys))
        return (m[self._point_of_row, self._axis_of_row] - self.observed) / self.sigma

    def linearise(self, values) -> Linearisation:
        p = _stack(values, self._keys)
        m = self._map(p)
        eps = 0.01
        grad = np.empty((p.shape[0], 3, 3))  # d map[a] / d p[k]
        for k in range(3):
            d = np.zeros(3)
            d[k] = eps
            grad[:, :, k] = (self._map(p + d) - self._map(p - d)) / (2 * eps)
        r = (m[self._point_of_row, self._axis_of_row] - self.observed) / self.sigma
        J = grad[self._point_of_row, self._axis_of_row, :] / self.sigma[:, None]
        rows = np.arange(self.n_rows)[:, None]
        return Linearisation(r, [JacobianPart(self._keys, rows, np.arange(3)[None, :], J,
                                              self._point_of_row[:, None])])


class DtmHeights(ObservationGroup):
    """``H(P) = DTM(x(P), y(P))`` with the DTM's sigma (m), one row per point."""

    def __init__(self, points, dtm, sigma: float, name: str = "dtm heights") -> None:
        self.name = name
        self.points = np.asarray(points, dtype=object)
        self._keys = [Ground(str(p)) for p in self.points]
        self.dtm = dtm
        self.sigma = np.full(self.points.size, float(sigma))
        self._describe(self.points, "z", "m")

    def keys(self):
        return self._keys

    def residuals(self, values) -> np.ndarray:
        value, _ = self.dtm.height_condition(_stack(values, self._keys))
        return value / self.sigma

    def linearise(self, values) -> Linearisation:
        value, grad = self.dtm.height_condition(_stack(values, self._keys))
        rows = np.arange(self.n_rows)[:, None]
        return Linearisation(value / self.sigma, [JacobianPart(
            self._keys, rows, np.arange(3)[None, :], grad / self.sigma[:, None], np.arange(self.n_rows)[:, None])])
