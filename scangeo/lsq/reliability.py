"""Reliability of an adjustment (Baarda): minimal detectable blunders and their effect on the result.

With whitened rows (residual / sigma, Jacobian / sigma), ``N = J^T J`` and the redundancy number
``r_i = 1 - j_i N^-1 j_i^T`` of row ``i``:

- **internal reliability**, the minimal detectable blunder (MDB) of row ``i``: the blunder the w-test
  (two-sided, significance ``alpha0``) finds with probability ``beta``,

      MDB_i = sigma_i * delta0 / sqrt(r_i),   delta0 = z(1 - alpha0 / 2) + z(beta)

  (``alpha0 = 0.1 %``, ``beta = 80 %``: ``delta0 = 3.29 + 0.84 = 4.13``, ``lambda0 = delta0^2 = 17.07``),
  in the observation's unit (lines, pixels, metres, radians). A row with ``r_i`` below
  ``MIN_REDUNDANCY`` is uncontrolled: its MDB is infinite (no blunder there can be detected);
- **external reliability**: an undetected blunder of MDB size shifts the unknowns by
  ``dx_i = N^-1 j_i^T delta0 / sqrt(r_i)``. Reported are its effect on the observation's own ground
  point (``ext_point_m``: the length of the shift of ``point_key(id)``, e.g. ``Ground(id)``, metres),
  its largest effect on the ground positions of the strips (``ext_orientation_m``: the horizontal
  shift, at fixed height, of where a pixel lands on the ground, the largest over a grid of image
  positions in every strip, see :class:`OrientationProbe`, built by the caller), and Baarda's
  bias-to-noise ratio ``sqrt_lambda = delta0 sqrt((1 - r) / r)``: no function ``f`` of the unknowns
  moves by more than ``sqrt_lambda * sigma_f`` (a priori).

Everything comes from the factor of the last solution and its selected inverse: the effects on the
ground points from the selected inverse (the unknowns of one observation share its pattern), the
effects on the strips' ground positions by one solve per probe position and axis, never a dense
inverse: over every row, or (a probe with a neighbourhood) over the rows near it, solved with the
whole factor restricted to the entries those rows need, linear in the size of a block
(:mod:`scangeo.lsq.probe_effects`, :mod:`scangeo.lsq.partial_solve`).
Rejected rows and pseudo-observations get NaN.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np
import scipy.sparse as sp
import scipy.stats

from scangeo.lsq.keys import PointKey
from scangeo.lsq.probe_effects import Neighbourhood, probe_effects
from scangeo.lsq.separability import scaled_jacobian
from scangeo.lsq.solver import Solution
from scangeo.lsq.statistics import MIN_REDUNDANCY, Statistics

#: Significance level of the w-test (two-sided) and power of the test, the MDB's definition.
ALPHA0 = 0.001
BETA = 0.80


@lru_cache(maxsize=64)
def delta0(alpha0: float = ALPHA0, beta: float = BETA) -> float:
    """``sqrt(lambda0)``: the non-centrality (in sigmas of the w-test) found with power ``beta``.
    Cached: the reliability summary asks for it per check-point row, and each ``norm.ppf`` costs about
    0.1 ms (4 % of adjust SE on 96 strips of block24, py-spy)."""
    return float(scipy.stats.norm.ppf(1.0 - alpha0 / 2.0) + scipy.stats.norm.ppf(beta))


@dataclass(frozen=True)
class OrientationProbe:
    """How the unknowns move the ground positions of one strip's pixels.

    ``matrix`` (2 k x n, CSR) maps a change of the unknowns (unscaled, the layout's columns) to the
    horizontal shift (x, y in m, project frame, at fixed height) of where k image positions of the
    strip land on the ground: ``dG = -(dimage/dG_xy)^-1 dimage/dx`` per position.
    """

    strip: str
    matrix: sp.csr_matrix
    #: (k, 2) map x, y of the k positions (for maps), or None
    xy: np.ndarray | None = None
    #: the unknowns whose observations are evaluated (see :mod:`scangeo.lsq.probe_effects`); None:
    #: every row
    neighbourhood: Neighbourhood | None = None


@dataclass
class Reliability:
    """Per observation group, per row: redundancy number, MDB and external reliability.

    ``ext_strip`` holds per strip the largest shift of its ground positions (m) any single undetected
    MDB-sized blunder of a tested observation (image, control, DTM height; not the GPS/IMU samples,
    which data snooping does not test) causes, and the row (group index, row) responsible;
    ``ext_positions`` the same per probe position.
    """

    groups: list
    redundancy: list[np.ndarray]
    mdb: list[np.ndarray]
    sqrt_lambda: list[np.ndarray]
    ext_point_m: list[np.ndarray]
    ext_orientation_m: list[np.ndarray]
    alpha0: float = ALPHA0
    beta: float = BETA
    ext_strip: dict[str, tuple[float, int, int]] = field(default_factory=dict)
    #: per strip, at each probe position, the largest shift (m) of any single MDB-sized blunder
    ext_positions: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def delta0(self) -> float:
        return delta0(self.alpha0, self.beta)


def _point_columns(solution: Solution, groups, rows_of_group: list[np.ndarray],
                   point_key: PointKey) -> list[np.ndarray]:
    """Per group, (rows, 3) columns of ``point_key(id)`` of each row (-1 where the id has no free point)."""
    layout = solution.layout
    cache: dict[str, np.ndarray] = {}
    out = []
    for g, rows in zip(groups, rows_of_group):
        cols = np.full((rows.size, 3), -1, dtype=np.int64)
        for k, i in enumerate(rows):
            pid = str(g.ids[i])
            if pid not in cache:
                key = point_key(pid)
                c = layout.columns(key) if key in layout.start else np.full(3, -1)
                cache[pid] = c if c.size == 3 else np.full(3, -1)
            cols[k] = cache[pid]
        out.append(cols)
    return out


def compute_reliability(solution: Solution, statistics: Statistics, probes: Sequence[OrientationProbe] = (),
                        alpha0: float = ALPHA0, beta: float = BETA, external: bool = True,
                        point_key: PointKey | None = None, workers: int = 1) -> Reliability:
    """Redundancy numbers, MDBs and external reliability of every active observation row.

    Parameters
    ----------
    solution, statistics : a full solution and its statistics (``Adjustment.solution``, ``.statistics``).
    probes : per strip, the map of the unknowns to its ground positions (``ext_orientation_m``); none:
        NaN.
    external : False skips the external reliability (no solves; MDBs only).
    workers : threads over the probes.
    point_key : maps an observation id to the key of its point (3 coordinates; ``Ground`` of the
        line-scanner block) for ``ext_point_m``; None: NaN.
    """
    d0 = delta0(alpha0, beta)
    groups = solution.groups
    slices = solution.system.row_slices
    red_all = statistics.redundancy_numbers()
    red, mdb, lam, ext_p, ext_o = [], [], [], [], []
    for g, act, r in zip(groups, solution.active, red_all):
        obs = np.full(g.n_rows, g.kind == "observation") & act
        rr = np.where(obs, r, np.nan)
        ok = obs & (rr >= MIN_REDUNDANCY)
        with np.errstate(divide="ignore", invalid="ignore"):
            m = np.where(ok, g.sigma * d0 / np.sqrt(np.where(ok, rr, 1.0)), np.where(obs, np.inf, np.nan))
            lam_g = np.where(ok, d0 * np.sqrt(np.clip(1.0 - rr, 0.0, None) / np.where(ok, rr, 1.0)),
                             np.where(obs, np.inf, np.nan))
        red.append(rr)
        mdb.append(m)
        lam.append(lam_g)
        ext_p.append(np.where(obs, np.inf, np.nan))
        ext_o.append(np.where(obs, np.inf, np.nan))
    out = Reliability(list(groups), red, mdb, lam, ext_p, ext_o, alpha0, beta)
    if not groups:  # nothing was observed (direct georeferencing evaluated at check points only)
        return out
    if not external:
        out.ext_point_m = [np.full(g.n_rows, np.nan) for g in groups]
        out.ext_orientation_m = [np.full(g.n_rows, np.nan) for g in groups]
        return out
    # the effects of an MDB-sized blunder in every controlled observation row
    rows_of_group = [np.flatnonzero(np.isfinite(m)) for m in mdb]
    glob = np.concatenate([slices[gi].start + rows for gi, rows in enumerate(rows_of_group)])
    owner_group = np.concatenate([np.full(rows.size, gi) for gi, rows in enumerate(rows_of_group)])
    local = np.concatenate(rows_of_group)
    size = d0 / np.sqrt(np.concatenate([red[gi][rows] for gi, rows in enumerate(rows_of_group)]))  # whitened
    Js = scaled_jacobian(solution)[glob]
    scale = solution.system.scale
    gcols = (np.concatenate(_point_columns(solution, groups, rows_of_group, point_key))
             if glob.size and point_key is not None else np.full((glob.size, 3), -1, dtype=np.int64))
    point = _point_effects(statistics, solution.factor, Js, gcols, size, scale)
    for gi in range(len(groups)):
        sel = owner_group == gi
        ext_p[gi][local[sel]] = point[sel]
        ext_o[gi][local[sel]] = np.nan if not probes else 0.0
    tested = np.array([groups[gi].snooped for gi in owner_group], dtype=bool)
    # the strips' ground positions: N^-1 P^T per probe, at the rows near it when it has a neighbourhood
    scaled = [(probe.matrix @ sp.diags(1.0 / scale)).tocsr() for probe in probes]
    hoods = [probe.neighbourhood for probe in probes]
    solver = statistics.inverse.partial_solver() if any(h is not None for h in hoods) else None
    effects = probe_effects(solution.factor, solver, Js, size, scaled, hoods, workers)
    per_row_all = np.zeros(glob.size)
    for probe, effect in zip(probes, effects):
        length = effect.length                                      # (evaluated rows, K) metres
        per_row = length.max(axis=1, initial=0.0)
        np.maximum.at(per_row_all, effect.rows, per_row)
        t = tested[effect.rows]
        if t.any():
            out.ext_positions[probe.strip] = length[t].max(axis=0)
            j = int(np.argmax(np.where(t, per_row, -1.0)))
            r = effect.rows[j]
            out.ext_strip[probe.strip] = (float(per_row[j]), int(owner_group[r]), int(local[r]))
    if probes:
        for gi in range(len(groups)):
            sel = owner_group == gi
            ext_o[gi][local[sel]] = per_row_all[sel]
    return out


def _point_effects(statistics: Statistics, factor, Js: sp.csr_matrix, gcols: np.ndarray, size: np.ndarray,
                   scale: np.ndarray) -> np.ndarray:
    """Per row of ``Js``, the length (m) of the shift of its ground point (columns ``gcols``, -1:
    none, NaN) by a blunder of ``size`` sigmas: ``Z[g, c] j`` from the selected inverse ``Z`` (the
    row's columns usually share an observation, so the entries are on the factor's pattern; rows
    with a pair outside it are solved with ``factor``)."""
    out = np.full(Js.shape[0], np.nan)
    has = np.flatnonzero((gcols >= 0).all(axis=1))
    if not has.size:
        return out
    J = Js[has].tocoo()
    rows = np.repeat(J.row, 3)
    g = gcols[has][rows, np.tile(np.arange(3), J.nnz)]
    z = statistics.inverse.entries(g, np.repeat(J.col, 3))
    dx = np.zeros((has.size, 3))
    np.add.at(dx, (rows, np.tile(np.arange(3), J.nnz)), z * np.repeat(J.data, 3))
    missing = np.unique(rows[np.isnan(z)])     # a pair outside the pattern (no observation couples it): solve
    for a in range(0, missing.size, 256):
        k = missing[a:a + 256]
        B = Js[has[k]].toarray().T
        X = np.asarray(factor.solve(B)).reshape(B.shape)
        dx[k] = X[gcols[has[k]], np.arange(k.size)[:, None]]
    dx *= size[has, None] / scale[gcols[has]]
    out[has] = np.linalg.norm(dx, axis=1)
    return out


def blunder_effect(solution: Solution, group_index: int, row: int, size: float) -> np.ndarray:
    """The change of the unknowns (unscaled, the layout's columns) caused by a blunder of ``size``
    (the observation's unit) in row ``row`` of group ``group_index``, to first order:
    ``dx = N^-1 j^T size / sigma`` with ``j`` the row's whitened Jacobian: the adjusted unknowns move
    by ``dx`` when the observation is ``size`` too large."""
    s = solution.system
    g = solution.groups[group_index]
    Js = scaled_jacobian(solution)
    j = Js[s.row_slices[group_index].start + row].toarray().ravel()
    return np.asarray(solution.factor.solve(j)).ravel() * (size / g.sigma[row]) / s.scale


__all__ = ["ALPHA0", "BETA", "OrientationProbe", "Reliability", "blunder_effect", "compute_reliability", "delta0"]
