"""Observation groups of the laser strip adjustment (Kager 2003, section 3), for the common engine.

Planes: ``Plane(patch)`` holds ``(u, v, d)``; with the patch's fixed reference point ``c0``, normal
``n0`` and in-plane unit vectors ``e1, e2``, the plane is ``n . (p - c0) = d`` with
``n = m / |m|``, ``m = n0 + u e1 + v e2``.

- :class:`StripAnchors`: the anchor points of one strip's patches. Each anchor is georeferenced
  from its original observations (time, range, scan angle) through the laser equation with the
  strip's GPS/IMU, the correction functions of its GPS/IMU models and the calibration
  (``Boresight``, ``LeverArm``, ``RangeOffset``, ``ScanIndex``); without a trajectory, the anchor's
  given point plus the position correction function. Observation: its normal distance to the
  patch's plane is 0, sigma the anchor's (from the strip's plane fit). The four anchors of a patch in
  a strip enter as three orthonormal combinations (offset, tilt a, tilt b; :data:`FOUR_TO_THREE`),
  one observation unit (data snooping removes them together).
- :class:`ControlPatchPoints`: surveyed points on control patches lie in their plane.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from scangeo.adjustment.keys import Boresight, LeverArm, ScanIndex
from scangeo.lidar.georeference import Calibration, Polar, TrajectorySampler, derivatives, georeference
from scangeo.lidar.keys import Plane, RangeOffset
from scangeo.lsq.keys import Key
from scangeo.lsq.observations import Linearisation, ObservationGroup
from scangeo.lsq.parameters import JacobianPart
from scangeo.orientation.models import ModelSet


def laser_calibration_keys(sensor: str = "") -> tuple[Boresight, LeverArm, RangeOffset, ScanIndex]:
    """The calibration blocks of a laser scanner (``sensor`` its id; ``""``: the one sensor of a laser project)."""
    return Boresight(sensor), LeverArm(sensor), RangeOffset(sensor), ScanIndex(sensor)


CALIBRATION_KEYS = laser_calibration_keys()

#: The four anchors of a patch in a strip (``+a, -a`` along its first principal axis, ``+b, -b`` along
#: the second; ``planes.anchors``) enter as three orthonormal combinations of their normal distances:
#: offset, tilt along a, tilt along b. The fourth combination (the anchors' non-planarity) carries no
#: information on the plane and would only add one to the redundancy per patch and strip.
_s = np.sqrt(0.5)
FOUR_TO_THREE = np.array([[0.5, _s, 0.0], [0.5, -_s, 0.0], [0.5, 0.0, _s], [0.5, 0.0, -_s]])
COMBINATIONS = ("offset", "tilt a", "tilt b")


def combine_rows(r: np.ndarray) -> np.ndarray:
    """Whitened anchor residuals (4 per unit) -> the three combinations per unit."""
    return (r.reshape(-1, 4) @ FOUR_TO_THREE).ravel()


def combine_part(part: JacobianPart) -> JacobianPart:
    """A Jacobian part of anchor rows (4 per unit) as one of the combined rows (3 per unit)."""
    b = part.cols if part.block is None else part.block
    rows, cols, vals, block = (np.ravel(x) for x in np.broadcast_arrays(part.rows, part.cols, part.values, b))
    out_r, out_c, out_v, out_b = [], [], [], []
    for c in range(3):
        w = FOUR_TO_THREE[rows % 4, c]
        keep = w != 0.0
        out_r.append(3 * (rows[keep] // 4) + c)
        out_c.append(cols[keep])
        out_v.append(vals[keep] * w[keep])
        out_b.append(block[keep])
    cat = np.concatenate
    return JacobianPart(part.keys, cat(out_r), cat(out_c), cat(out_v), None if part.block is None else cat(out_b))


@dataclass
class PatchFrames:
    """Reference point, normal and in-plane axes of every patch (rows), and its key."""

    ids: list[str]
    c0: np.ndarray
    n0: np.ndarray
    e1: np.ndarray
    e2: np.ndarray

    @classmethod
    def from_points(cls, ids: list[str], centres: np.ndarray, normals: np.ndarray) -> PatchFrames:
        n0 = normals / np.linalg.norm(normals, axis=1)[:, None]
        helper = np.where(np.abs(n0[:, [0]]) < 0.9, [[1.0, 0, 0]], [[0.0, 1, 0]])
        e1 = np.cross(n0, helper)
        e1 /= np.linalg.norm(e1, axis=1)[:, None]
        return cls(list(ids), np.asarray(centres, float), n0, e1, np.cross(n0, e1))

    @property
    def keys(self) -> list[Plane]:
        return [Plane(i) for i in self.ids]

    def normals(self, planes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Unit normals (k, 3) and |m| (k,) for plane values (k, 3)."""
        return self._normals(np.arange(len(self.ids)), planes)

    def _normals(self, idx: np.ndarray, uvd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        m = self.n0[idx] + uvd[:, [0]] * self.e1[idx] + uvd[:, [1]] * self.e2[idx]
        norm = np.linalg.norm(m, axis=1)
        return m / norm[:, None], norm

    def distance(self, idx: np.ndarray, p: np.ndarray, uvd: np.ndarray):
        """Signed distances of points p (k, 3) to their planes, the unit normals and d/d(u, v, d)."""
        n, norm = self._normals(idx, uvd)
        q = p - self.c0[idx]
        nq = np.einsum("ij,ij->i", n, q)
        dd = np.empty((idx.size, 3))
        for k, e in enumerate((self.e1[idx], self.e2[idx])):
            dd[:, k] = (np.einsum("ij,ij->i", e, q) - nq * np.einsum("ij,ij->i", n, e)) / norm
        dd[:, 2] = -1.0
        return nq - uvd[:, 2], n, dd


def _plane_values(frames: PatchFrames, values, patch: np.ndarray, local: list[Plane]) -> np.ndarray:
    table = np.array([values[k] for k in local], float).reshape(len(local), 3)
    return table[patch]


class StripAnchors(ObservationGroup):
    """The anchors of one strip's patches; see the module docstring.

    Parameters
    ----------
    strip : strip id.
    patch : (k,) index of each anchor's patch in ``frames``.
    unit_id : (k,) observation unit (patch id within the strip) of each anchor.
    sigma : (k,) sigma of each anchor's normal distance (m).
    frames : the patches.
    models : GPS/IMU models (correction functions).
    points : (k, 3) anchor points in the work frame (used directly without a trajectory).
    polar, sampler, nominal : with a trajectory: the anchors' original observations, the strip's GPS/IMU
        and the nominal calibration (the observations were recovered with it).
    line : the id the GPS/IMU models serve the strip under: its flight line on a platform (None: the strip).
    sensor : the laser's id, of its calibration keys (``""``: the one sensor of a laser project).
    """

    def __init__(
        self,
        strip: str,
        patch: np.ndarray,
        unit_id: np.ndarray,
        sigma: np.ndarray,
        frames: PatchFrames,
        models: ModelSet,
        points: np.ndarray,
        times: np.ndarray,
        polar: Polar | None = None,
        sampler: TrajectorySampler | None = None,
        line: str | None = None,
        sensor: str = "",
    ) -> None:
        self.name = f"anchors {strip}"
        self.strip = strip
        self.calibration_keys = laser_calibration_keys(sensor)
        self.frames = frames
        self._anchor_sigma = np.asarray(sigma, float)
        self._k = self._anchor_sigma.size
        if self._k % 4 or np.any(np.asarray(patch).reshape(-1, 4) != np.asarray(patch)[::4, None]):
            raise ValueError("StripAnchors: four anchors per patch, consecutive")
        self.sigma = np.repeat(self._anchor_sigma[::4], 3)
        uniq, self._local = np.unique(patch, return_inverse=True)
        self._plane_keys = [Plane(frames.ids[i]) for i in uniq]
        self._patch = np.asarray(patch)
        units, row_unit = np.unique(np.asarray(unit_id)[::4], return_inverse=True)
        self._describe(np.repeat([frames.ids[i] for i in self._patch[::4]], 3), np.tile(COMBINATIONS, self._k // 4),
                       "m", np.repeat(row_unit, 3))
        self.points = np.asarray(points, float)
        self.polar = polar
        self.trajectory = polar is not None
        if polar is not None:
            assert sampler is not None
            self.pos0, self.ang0 = sampler.at(polar.time)
            times = polar.time
        else:
            self.pos0 = self.points
        self._design = models.design(strip if line is None else line, np.asarray(times, float), self.pos0)
        self._keys = [k for k, _, _ in self._design]

    def keys(self):
        keys: list[Key] = list(self._keys)
        if self.trajectory:
            keys += self.calibration_keys
        return list(dict.fromkeys(keys + list(self._plane_keys)))

    def _corrections(self, values) -> np.ndarray:
        c = np.zeros((self._k, 6))
        for key, rows, D in self._design:
            c[rows] += D @ np.asarray(values[key], float)
        return c

    def _evaluate(self, values, jacobian: bool):
        c = self._corrections(values)
        d = None
        if self.polar is not None:
            bore, lever, offset, index = self.calibration_keys
            cal = Calibration(np.asarray(values[bore], float), np.asarray(values[lever], float),
                              float(values[offset][0]), float(values[index][0]))
            if jacobian:
                d = derivatives(self.pos0 + c[:, :3], self.ang0 + c[:, 3:], self.polar, cal)
                p = d.points
            else:
                p = georeference(self.pos0 + c[:, :3], self.ang0 + c[:, 3:], self.polar, cal)
        else:
            p = self.pos0 + c[:, :3]
        uvd = _plane_values(self.frames, values, self._local, self._plane_keys)
        f, n, dd = self.frames.distance(self._patch, p, uvd)
        return f / self._anchor_sigma, d, n, dd

    def residuals(self, values) -> np.ndarray:
        return combine_rows(self._evaluate(values, False)[0])

    def linearise(self, values) -> Linearisation:
        r, d, n, dd = self._evaluate(values, True)
        w = 1.0 / self._anchor_sigma
        k = self._k
        rows = np.arange(k)
        g = np.zeros((k, 6))
        g[:, :3] = n
        if d is not None:
            g[:, 3:] = np.einsum("ni,nik->nk", n, d.attitude)
        parts = []
        for key, rr, D in self._design:
            J = np.einsum("ri,rik->rk", g[rr], D) * w[rr, None]
            parts.append(
                JacobianPart([key], np.repeat(rr, D.shape[2]), np.tile(np.arange(D.shape[2]), rr.size), J.ravel())
            )
        if d is not None:
            cal_key: Key
            bore, lever, offset, index = self.calibration_keys
            for cal_key, M in ((bore, d.boresight), (lever, d.lever_arm)):
                J = np.einsum("ni,nik->nk", n, M) * w[:, None]
                parts.append(JacobianPart([cal_key], np.repeat(rows, 3), np.tile(np.arange(3), k), J.ravel()))
            for cal_key, v in ((offset, d.range), (index, d.index)):
                parts.append(JacobianPart([cal_key], rows, np.zeros(k, np.int64), np.einsum("ni,ni->n", n, v) * w))
        parts.append(
            JacobianPart(
                self._plane_keys,
                np.repeat(rows, 3),
                np.tile(np.arange(3), k),
                (dd * w[:, None]).ravel(),
                np.repeat(self._local, 3),
            )
        )
        return Linearisation(combine_rows(r), [combine_part(p) for p in parts])


class ControlPatchPoints(ObservationGroup):
    """Surveyed points on control patches: normal distance to the patch's plane = 0 (sigma given);
    ``vertical``: height-only control planes (sports fields), the vertical distance = 0 instead
    (the plane's height above the point; its horizontal position is free)."""

    def __init__(
        self,
        ids: np.ndarray,
        patch: np.ndarray,
        points: np.ndarray,
        sigma: np.ndarray,
        frames: PatchFrames,
        vertical: bool = False,
    ) -> None:
        self.name = "height control planes" if vertical else "control patches"
        self.vertical = vertical
        self.frames = frames
        self.sigma = np.asarray(sigma, float)
        self.points = np.asarray(points, float)
        self._patch = np.asarray(patch)
        uniq, self._local = np.unique(patch, return_inverse=True)
        self._plane_keys = [Plane(frames.ids[i]) for i in uniq]
        self._describe(list(ids), "vertical distance" if vertical else "normal distance", "m")

    def keys(self):
        return list(self._plane_keys)

    def linearise(self, values) -> Linearisation:
        uvd = _plane_values(self.frames, values, self._local, self._plane_keys)
        f, n, dd = self.frames.distance(self._patch, self.points, uvd)
        if self.vertical:
            # f_v = f / n_z; d n_z / d(u, v) = (e_z - n_z (n . e)) / |m| for e = e1, e2
            _, norm = self.frames._normals(self._patch, uvd)
            nz = n[:, 2]
            dnz = np.zeros_like(dd)
            for k, e in enumerate((self.frames.e1[self._patch], self.frames.e2[self._patch])):
                dnz[:, k] = (e[:, 2] - nz * np.einsum("ij,ij->i", n, e)) / norm
            dd = dd / nz[:, None] - (f / nz**2)[:, None] * dnz
            f = f / nz
        rows = np.arange(self.n_rows)
        return Linearisation(
            f / self.sigma,
            [
                JacobianPart(
                    self._plane_keys,
                    np.repeat(rows, 3),
                    np.tile(np.arange(3), self.n_rows),
                    (dd / self.sigma[:, None]).ravel(),
                    np.repeat(self._local, 3),
                )
            ],
        )
