"""The effect of single blunders on a probe (a linear map of the unknowns): over every row, or over
the rows near the probe.

A probe ``P`` (k x n) maps a change of the unknowns to quantities a user cares about, e.g. the ground
positions of one strip. An undetected blunder of ``size_i`` whitened units in row ``i`` (whitened,
scaled Jacobian row ``j_i``) moves them by

    P N^-1 j_i^T size_i                                 (N the scaled normal matrix)

**Every row** (:func:`exact_probe_effects`): ``W = N^-1 P^T`` by one solve with the whole factor, then
every row. Per probe that costs a solve over all ``n`` unknowns and a product with all ``m`` rows: with
one probe per strip, quadratic in the number of strips (96 strips: 20 minutes, 4.8 GB).

**The rows near the probe** (:func:`near_probe_effects`), when the probe names a neighbourhood: only
the rows that touch its ``near`` columns are evaluated, and of ``W = N^-1 P^T`` only the entries
those rows need (their columns ``T``), by a solve with the whole factor restricted to the entries
that reach them (:class:`~scangeo.lsq.partial_solve.PartialSolver`: the ancestors of ``P``'s columns
and of ``T`` in the elimination tree). The figures of the rows evaluated are those of the exact
route (the same arithmetic; they agree to rounding). The approximation, stated: a row that touches no
``near`` column is not evaluated for this probe, i.e. its effect on the probe is taken to be below the
largest effect of the rows that are (on a block of strips the effect of a blunder decays by about ten
times per strip of distance). Cost per probe: about that of its neighbourhood's columns of the factor,
so linear in the number of probes.

Parallel: the partial solves are compiled and release the GIL; ``workers`` threads run the probes'
solves side by side (the products with the rows hold it in part).
"""
from __future__ import annotations

from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from scangeo.lsq.factor import Factor
from scangeo.lsq.partial_solve import PartialSolver


@dataclass(frozen=True)
class Neighbourhood:
    """Columns (the layout's) of a probe's neighbourhood: the rows that touch ``near`` are evaluated."""

    near: np.ndarray


@dataclass(frozen=True)
class ProbeEffect:
    """Per evaluated row (``rows``: indices into the rows given), the length of the shift of each
    position pair of the probe (``length``: rows x k/2, the probe's unit)."""

    rows: np.ndarray
    length: np.ndarray


def _lengths(shift: np.ndarray) -> np.ndarray:
    return np.hypot(shift[:, 0::2], shift[:, 1::2])


def exact_probe_effects(factor: Factor, Js: sp.csr_matrix, size: np.ndarray, Ps: sp.csr_matrix,
                        chunk: int = 2048) -> ProbeEffect:
    """Every row's effect on the probe ``Ps`` (2k x n, scaled columns): ``W = N^-1 Ps^T`` with the
    whole factor. ``Js`` (rows x n) whitened and scaled rows, ``size`` (rows,) the blunder in sigmas."""
    W = np.asarray(factor.solve(Ps.T.toarray())).reshape(Ps.shape[1], Ps.shape[0])
    length = np.zeros((Js.shape[0], Ps.shape[0] // 2))
    for a in range(0, Js.shape[0], chunk):
        length[a:a + chunk] = _lengths((Js[a:a + chunk] @ W) * size[a:a + chunk, None])
    return ProbeEffect(np.arange(Js.shape[0]), length)


def near_probe_effects(solver: PartialSolver, Js_csc: sp.csc_matrix, Js: sp.csr_matrix, size: np.ndarray,
                       probes: Sequence[sp.csr_matrix], hood: Neighbourhood) -> list[ProbeEffect]:
    """The effects of the rows that touch ``hood.near`` on each of ``probes`` (sharing the
    neighbourhood: one partial solve for all their right-hand sides), exact for those rows (see the
    module's docstring). ``Js_csc`` the same rows as ``Js`` in CSC (for finding the rows of a column)."""
    near = np.unique(hood.near)
    rows = np.unique(Js_csc[:, near].indices) if near.size else np.zeros(0, np.int64)
    if not rows.size:
        return [ProbeEffect(rows, np.zeros((0, P.shape[0] // 2))) for P in probes]
    J = Js[rows]
    T = np.unique(J.indices)
    support = np.unique(np.concatenate([P.indices for P in probes]))
    B = np.hstack([P[:, support].T.toarray() for P in probes])
    W = solver.solve(support, B, T)                     # (N^-1 P^T)[T], every probe's columns side by side
    shifts = (J[:, T] @ W) * size[rows, None]
    out, a = [], 0
    for P in probes:
        out.append(ProbeEffect(rows, _lengths(shifts[:, a:a + P.shape[0]])))
        a += P.shape[0]
    return out


def probe_effects(factor: Factor, solver: PartialSolver | None, Js: sp.csr_matrix, size: np.ndarray,
                  probes: Sequence[sp.csr_matrix], hoods: Sequence[Neighbourhood | None],
                  workers: int = 1) -> list[ProbeEffect]:
    """:func:`near_probe_effects` for the probes with a neighbourhood (probes that share one
    ``Neighbourhood`` object share its solve; ``solver`` from the same factor), :func:`exact_probe_effects`
    for the others; ``workers`` threads over the neighbourhoods."""
    near = solver is not None and any(h is not None for h in hoods)
    Js_csc = Js.tocsc() if near else None
    tasks: dict[int, list[int]] = {}
    for k, hood in enumerate(hoods):
        tasks.setdefault(id(hood) if hood is not None and near else -1 - k, []).append(k)

    def one(ks: list[int]) -> list[ProbeEffect]:
        hood = hoods[ks[0]]
        if hood is None or solver is None or Js_csc is None:
            return [exact_probe_effects(factor, Js, size, probes[k]) for k in ks]
        return near_probe_effects(solver, Js_csc, Js, size, [probes[k] for k in ks], hood)

    groups = list(tasks.values())
    if workers <= 1 or len(groups) < 2:
        results = [one(ks) for ks in groups]
    else:
        with ThreadPoolExecutor(max_workers=workers) as pool:
            results = list(pool.map(one, groups))
    out: list[ProbeEffect | None] = [None] * len(probes)
    for ks, res in zip(groups, results):
        for k, r in zip(ks, res):
            out[k] = r
    return [r for r in out if r is not None]


__all__ = ["Neighbourhood", "ProbeEffect", "exact_probe_effects", "near_probe_effects", "probe_effects"]
