"""Small synthetic adjustment problems with known answers, shared by the engine tests."""
from __future__ import annotations

import numpy as np

from scangeo.lsq import JacobianPart, Linearisation, ObservationGroup, Unknown


class HeightDifferences(ObservationGroup):
    """Levelling: ``dh = H[to] - H[frm]`` (metres), one key ``Unknown(point)`` of size 1 per point."""

    name = "levelling"

    def __init__(self, frm, to, dh, sigma) -> None:
        self.frm, self.to = list(frm), list(to)
        self.dh = np.asarray(dh, float)
        self.sigma = np.asarray(sigma, float)
        self.points = list(dict.fromkeys(self.frm + self.to))
        index = {p: i for i, p in enumerate(self.points)}
        self.i_from = np.array([index[p] for p in self.frm])
        self.i_to = np.array([index[p] for p in self.to])
        self._describe([f"{a}-{b}" for a, b in zip(self.frm, self.to)], "dh", "m")

    def keys(self):
        return [Unknown(p) for p in self.points]

    def linearise(self, values):
        H = np.array([values[Unknown(p)][0] for p in self.points])
        r = (H[self.i_to] - H[self.i_from] - self.dh) / self.sigma
        rows = np.arange(self.n_rows)
        keys = self.keys()
        return Linearisation(r, [
            JacobianPart(keys, rows, 0, 1.0 / self.sigma, self.i_to),
            JacobianPart(keys, rows, 0, -1.0 / self.sigma, self.i_from),
        ])


class Distances(ObservationGroup):
    """2D trilateration: distances (metres) from fixed stations to one unknown point ``Unknown("P")``."""

    name = "distances"

    def __init__(self, stations, d, sigma, key=Unknown("P")) -> None:  # noqa: B008 (keys are frozen)
        self.stations = np.asarray(stations, float)
        self.d = np.asarray(d, float)
        self.sigma = np.broadcast_to(np.asarray(sigma, float), self.d.shape).copy()
        self.key = key
        self._describe([f"S{i}" for i in range(len(self.d))], "distance", "m")

    def keys(self):
        return [self.key]

    def linearise(self, values):
        p = values[self.key]
        diff = p[None, :] - self.stations
        rho = np.hypot(diff[:, 0], diff[:, 1])
        r = (rho - self.d) / self.sigma
        dr = diff / (rho * self.sigma)[:, None]
        rows = np.arange(self.n_rows)[:, None]
        return Linearisation(r, [JacobianPart([self.key], rows, np.arange(2)[None, :], dr)])


class Polynomial(ObservationGroup):
    """``y = sum_k c_k x^k`` with the coefficients under one key (for significance tests)."""

    name = "polynomial"

    def __init__(self, x, y, sigma, degree, key=Unknown("c")) -> None:  # noqa: B008 (keys are frozen)
        self.x, self.y = np.asarray(x, float), np.asarray(y, float)
        self.sigma = np.full(self.x.size, float(sigma))
        self.V = self.x[:, None] ** np.arange(degree + 1)[None, :]
        self.key = key
        self._describe(np.arange(self.x.size).astype(str), "y", "m")

    def keys(self):
        return [self.key]

    def linearise(self, values):
        c = values[self.key]
        r = (self.V @ c - self.y) / self.sigma
        rows = np.arange(self.n_rows)[:, None]
        cols = np.arange(self.V.shape[1])[None, :]
        return Linearisation(r, [JacobianPart([self.key], rows, cols, self.V / self.sigma[:, None])])


def levelling_network(rng, n_points=12, n_lines=40, sigma=0.002, blunders=()):
    """A random levelling network over points P0..P{n-1} with true heights; P0 is the benchmark."""
    truth = {f"P{i}": float(h) for i, h in enumerate(100 + 10 * rng.standard_normal(n_points))}
    names = list(truth)
    # a chain through all points, then random extra lines
    pairs = [(names[i], names[i + 1]) for i in range(n_points - 1)]
    while len(pairs) < n_lines:
        a, b = rng.choice(n_points, 2, replace=False)
        pairs.append((names[a], names[b]))
    frm, to = zip(*pairs)
    sig = sigma * (0.5 + rng.random(len(pairs)))
    dh = np.array([truth[b] - truth[a] for a, b in pairs]) + sig * rng.standard_normal(len(pairs))
    for i, size in blunders:
        dh[i] += size
    return truth, HeightDifferences(frm, to, dh, sig)


def dense_design(group, names):
    """Whitened design matrix A (rows x points) of a HeightDifferences group over ``names``."""
    index = {p: i for i, p in enumerate(names)}
    A = np.zeros((group.n_rows, len(names)))
    for r, (a, b) in enumerate(zip(group.frm, group.to)):
        A[r, index[b]] += 1 / group.sigma[r]
        A[r, index[a]] -= 1 / group.sigma[r]
    return A
