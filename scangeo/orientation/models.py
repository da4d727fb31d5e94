"""GPS/IMU models and their correction functions.

A GPS/IMU model covers the whole block, one strip, or one part of a strip (a sub-model between break
epochs). Its correction function, added to the measured GPS/IMU, gives the orientation:

    s(t) = gpsimu(t) + c_m(t),   tau = 2 (t - t_start) / (t_end - t_start) - 1  in [-1, 1]

    c_m(t)[x, y, z]                = sum_{d=0..Dp} a_d tau^d  (+ omega x (p_gpsimu(t) - centre))
    c_m(t)[roll, pitch, heading]   = sum_{d=0..Da} b_d tau^d

``a_d`` (metres) and ``b_d`` (radians) are the coefficients, ``omega`` (radians, about the project
frame's axes at the model's ``centre``) the optional rigid rotation of the model's positions. A degree
of -1 means no correction of that kind.

Split models: a sub-model that ``follows`` another is C0-continuous with it at their common break
(kinks allowed). The condition is eliminated by the parametrisation: the follower has no constant
terms, its correction is ``c_prev(tau = +1) + sum_{d>=1} a_d (tau^d - (-1)^d)``; each eliminated
constant is one condition of the accounting. Everything is linear in the coefficients, so
:meth:`ModelSet.design` returns, for any times, the matrix of the correction with respect to each
coefficient block it depends on.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from scangeo.errors import AdjustmentError
from scangeo.lsq.keys import Key


@dataclass(frozen=True, slots=True)
class Correction(Key):
    """Coefficients of the correction function of one GPS/IMU model."""

    model: str


POSITION = ("x", "y", "z")
ATTITUDE = ("roll", "pitch", "heading")


@dataclass(frozen=True)
class GpsImuModel:
    """One GPS/IMU model.

    Parameters
    ----------
    id : model name (the key is ``Correction(id)``).
    strips : the strips it covers.
    t_start, t_end : its time span (s); tau runs from -1 to 1 over it.
    position_degree, attitude_degree : polynomial degrees (-1: none).
    rotation : also a rigid rotation of the model's positions about ``centre`` (3 unknowns).
    centre : (3,) metres, project frame; the rotation's centre (the mean GPS position).
    follows : id of the sub-model before this one's start break (C0 continuity), or None.
    windows : per strip, the time window (s) of the strip served by this model.
    """

    id: str
    strips: tuple[str, ...]
    t_start: float
    t_end: float
    position_degree: int = 0
    attitude_degree: int = 0
    rotation: bool = False
    centre: np.ndarray = field(default_factory=lambda: np.zeros(3))
    follows: str | None = None
    windows: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not self.t_end > self.t_start:
            raise AdjustmentError(f"GPS/IMU model {self.id}: empty time span [{self.t_start}, {self.t_end}]")
        for name in ("position_degree", "attitude_degree"):
            if not -1 <= getattr(self, name) <= 10:
                raise AdjustmentError(f"GPS/IMU model {self.id}: {name} must be between -1 and 10")
        if self.follows is not None and self.rotation:
            raise AdjustmentError(f"GPS/IMU model {self.id}: a split sub-model cannot have a rigid rotation")

    @property
    def key(self) -> Correction:
        return Correction(self.id)

    def tau(self, t: np.ndarray) -> np.ndarray:
        """Normalised time in [-1, 1] over the model's span."""
        return 2.0 * (np.asarray(t, float) - self.t_start) / (self.t_end - self.t_start) - 1.0

    def first_degree(self) -> int:
        """Lowest polynomial degree with a coefficient: 1 for a follower (constants eliminated)."""
        return 1 if self.follows is not None else 0

    def names(self) -> list[str]:
        """Coefficient names, in block order: position (degree-major), attitude, rotation."""
        d0 = self.first_degree()
        out = [f"{c}{d}" for d in range(d0, self.position_degree + 1) for c in POSITION]
        out += [f"{c}{d}" for d in range(d0, self.attitude_degree + 1) for c in ATTITUDE]
        if self.rotation:
            out += ["omega_x", "omega_y", "omega_z"]
        return out

    def degrees(self) -> np.ndarray:
        """The polynomial degree of each coefficient (in :meth:`names` order); -1 for the rotation's."""
        return np.array([int(n[-1]) if n[-1].isdigit() else -1 for n in self.names()], dtype=np.int64)

    def angular(self) -> np.ndarray:
        """Whether each coefficient corrects the attitude (radians) rather than the position (metres)."""
        return np.array([n.rstrip("0123456789") in ATTITUDE for n in self.names()], dtype=bool)

    @property
    def size(self) -> int:
        return len(self.names())

    @property
    def conditions(self) -> int:
        """Continuity conditions eliminated at this model's start break."""
        if self.follows is None:
            return 0
        return 3 * (self.position_degree >= 0) + 3 * (self.attitude_degree >= 0)

    def own_design(self, t: np.ndarray, p_gps: np.ndarray | None = None) -> np.ndarray:
        """(n, 6, size): d c(t)[component] / d coefficient, for this model's own coefficients."""
        tau = self.tau(t)
        n = tau.size
        out = np.zeros((n, 6, self.size))
        col = 0
        d0 = self.first_degree()
        for _comps, degree, offset in ((POSITION, self.position_degree, 0), (ATTITUDE, self.attitude_degree, 3)):
            for d in range(d0, degree + 1):
                basis = tau**d - (-1.0) ** d if self.follows is not None else tau**d
                for c in range(3):
                    out[:, offset + c, col] = basis
                    col += 1
        if self.rotation:
            if p_gps is None:
                raise AdjustmentError(f"GPS/IMU model {self.id}: the rotation needs the GPS positions")
            r = np.asarray(p_gps, float) - self.centre
            # omega x r = -[r]x omega
            out[:, 0, col:col + 3] = np.column_stack([np.zeros(n), r[:, 2], -r[:, 1]])
            out[:, 1, col:col + 3] = np.column_stack([-r[:, 2], np.zeros(n), r[:, 0]])
            out[:, 2, col:col + 3] = np.column_stack([r[:, 1], -r[:, 0], np.zeros(n)])
        return out


class ModelSet:
    """The GPS/IMU models of an adjustment and which model serves each strip at each time."""

    def __init__(self, models: list[GpsImuModel]) -> None:
        self.models = {m.id: m for m in models}
        if len(self.models) != len(models):
            raise AdjustmentError("GPS/IMU model ids must be unique")
        for m in models:
            if m.follows is not None and m.follows not in self.models:
                raise AdjustmentError(f"GPS/IMU model {m.id} follows unknown model {m.follows}")

    def __iter__(self):
        return iter(self.models.values())

    def __len__(self) -> int:
        return len(self.models)

    def model_at(self, strip: str, t: np.ndarray) -> np.ndarray:
        """Index into ``list(self)`` of the model serving each time of a strip (-1: none)."""
        t = np.asarray(t, float)
        out = np.full(t.size, -1, dtype=np.int64)
        for i, m in enumerate(self):
            if strip in m.windows:
                lo, hi = m.windows[strip]
                out[(t >= lo) & (t <= hi) & (out < 0)] = i
        return out

    def chain(self, model: GpsImuModel) -> list[GpsImuModel]:
        """The model and the ones it follows, the first of the chain first."""
        out = [model]
        while out[0].follows is not None:
            out.insert(0, self.models[out[0].follows])
        return out

    def design(self, strip: str, t: np.ndarray, p_gps: np.ndarray) -> list[tuple[Correction, np.ndarray, np.ndarray]]:
        """The correction of a strip at times t as a linear function of coefficient blocks.

        Returns a list of ``(key, rows, D)``: ``D`` (len(rows), 6, size of key) with
        ``c(t[rows]) = sum D @ coefficients[key]``. Times no model serves get no correction.
        """
        which = self.model_at(strip, t)
        models = list(self)
        out = []
        for i in np.unique(which[which >= 0]):
            rows = np.flatnonzero(which == i)
            chain = self.chain(models[i])
            for k, m in enumerate(chain):
                if k == len(chain) - 1:
                    D = m.own_design(t[rows], p_gps[rows])
                else:  # a predecessor contributes its value at its end, tau = +1
                    D = np.repeat(m.own_design(np.array([m.t_end]), p_gps[rows[:1]]), rows.size, axis=0)
                out.append((m.key, rows, D))
        return out

    def correction(self, strip: str, t: np.ndarray, p_gps: np.ndarray, coefficients) -> np.ndarray:
        """c(t) (n, 6) for a strip from ``coefficients[key]``."""
        t = np.asarray(t, float)
        c = np.zeros((t.size, 6))
        for key, rows, D in self.design(strip, t, p_gps):
            c[rows] += D @ np.asarray(coefficients[key], float)
        return c


def strip_models(strip: str, edges, position_degree: int, attitude_degree: int, rotation: bool = False,
                 centres=None, where: str = "") -> list[GpsImuModel]:
    """The models of one strip over ``edges[0] .. edges[-1]`` (s): one model (id ``strip``), or, with
    inner edges (breaks), sub-models ``strip.1``, ``strip.2``, ... each C0-continuous with the one before.

    The first sub-model serves the strip from the start of time, the last to its end. ``rotation``
    applies to an unsplit model only; ``centres`` (one (3,) per sub-model) are the rotation's centres;
    ``where`` prefixes the error message (e.g. the variant).
    """
    edges = [float(e) for e in edges]
    if any(b <= a for a, b in zip(edges[:-1], edges[1:])):
        raise AdjustmentError(f"{where}strip {strip}: breaks must lie inside the strip's GPS/IMU time span "
                              f"{edges[0]:.2f}..{edges[-1]:.2f} s and increase")
    n = len(edges) - 1
    out = []
    for k in range(n):
        lo = -np.inf if k == 0 else edges[k]
        hi = np.inf if k == n - 1 else edges[k + 1]
        centre = np.zeros(3) if centres is None else np.asarray(centres[k], float)
        out.append(GpsImuModel(strip if n == 1 else f"{strip}.{k + 1}", (strip,), edges[k], edges[k + 1],
                               position_degree, attitude_degree, rotation and n == 1, centre,
                               None if k == 0 else f"{strip}.{k}", {strip: (lo, hi)}))
    return out


def group_model(id: str, strips, t_start: float, t_end: float, position_degree: int, attitude_degree: int,
                rotation: bool = False, centre=None) -> GpsImuModel:
    """One model serving several strips over all their times (the block, a mission)."""
    return GpsImuModel(id, tuple(strips), t_start, t_end, position_degree, attitude_degree, rotation,
                       np.zeros(3) if centre is None else np.asarray(centre, float), None,
                       {s: (-np.inf, np.inf) for s in strips})


def coefficient_priors(model: GpsImuModel, coefficient_sigma_m: float, coefficient_sigma_deg: float,
                       constant_sigma_m: float | None, constant_sigma_deg: float | None) -> np.ndarray:
    """Prior sigma of the pseudo-observation "= 0" of each coefficient (preventive regularisation).

    Degree >= 1: ``coefficient_sigma_m`` (position, metres) or ``coefficient_sigma_deg`` (attitude);
    constants: ``constant_sigma_m`` / ``constant_sigma_deg`` (None or 0: no prior, sigma inf); the
    rotation's coefficients: none. Radians inside.
    """
    deg, angular = model.degrees(), model.angular()
    coef = np.where(angular, np.radians(coefficient_sigma_deg), coefficient_sigma_m)
    const = np.where(angular, np.radians(constant_sigma_deg) if constant_sigma_deg else np.inf,
                     constant_sigma_m if constant_sigma_m else np.inf)
    return np.where(deg >= 1, coef, np.where(deg == 0, const, np.inf))

