"""The effect of single blunders on a probe (a linear map of the unknowns), exactly or locally.

A probe ``P`` (k x n) maps a change of the unknowns to quantities a user cares about, e.g. the ground
positions of one strip. An undetected blunder of ``size_i`` whitened units in row ``i`` (whitened,
scaled Jacobian row ``j_i``) moves them by

    P N^-1 j_i^T size_i                                 (N the scaled normal matrix)

**Exact** (:func:`exact_probe_effects`): ``W = N^-1 P^T`` by one solve with the whole factor, then every
row. Per probe that costs a solve over all ``n`` unknowns and a product with all ``m`` rows: with one
probe per strip, quadratic in the number of strips (96 strips: 20 minutes, 4.8 GB).

**Local** (:func:`local_probe_effects`), when the probe names a neighbourhood: ``near`` columns (the
rows that touch them are evaluated) inside a ``domain`` of columns (the unknowns solved for; it holds
``near``, the probe's own columns, and every column of a row that touches ``near``). Then

    W_D = N[D, D]^-1 P[:, D]^T,      effect_i = j_i[D] W_D size_i      (rows touching ``near``)

by one sparse factorisation of the domain's normal matrix. The approximation, stated: the unknowns
outside the domain are held fixed, i.e. the information they pass in through the domain's edge
counts as exact: ``N[D, D]`` misses the Schur complement ``N_DB N_BB^-1 N_BD`` of the outside. The
difference decays with the margin between ``near`` and the edge of the domain (on a chain of strips
by about ten times per strip of margin) and is zero when the domain holds every unknown coupled to
it. Rows that touch no ``near`` column are not evaluated for this probe (their effect on it is taken
as below the largest).
Cost per probe: that of its neighbourhood, so linear in the number of probes. Parallel: CHOLMOD's
supernodal factorisation and solves use the BLAS's threads; ``workers`` threads over the windows
overlap only what releases the GIL (scikit-sparse 0.4 holds it during CHOLMOD's calls, so the
default is one).
"""
from __future__ import annotations

from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from scangeo.lsq.factor import Factor, Factorizer


@dataclass(frozen=True)
class Neighbourhood:
    """Columns (the layout's) of a probe's neighbourhood: rows that touch ``near`` are evaluated,
    the unknowns ``domain`` (a superset of ``near``) are solved for, the others held fixed."""

    near: np.ndarray
    domain: np.ndarray


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


def local_probe_effects(normal: sp.csc_matrix, Js_csc: sp.csc_matrix, Js: sp.csr_matrix, size: np.ndarray,
                        probes: Sequence[sp.csr_matrix], hood: Neighbourhood) -> list[ProbeEffect]:
    """The effects of the rows that touch ``hood.near`` on each of ``probes`` (sharing the
    neighbourhood: one factorisation), with the unknowns outside ``hood.domain`` held fixed (see the
    module's docstring). ``normal`` the scaled normal matrix (n x n), ``Js_csc`` the same rows as
    ``Js`` in CSC (for finding the rows of a column)."""
    D = np.unique(hood.domain)
    near = np.unique(hood.near)
    rows = np.unique(Js_csc[:, near].indices) if near.size else np.zeros(0, np.int64)
    if not rows.size:
        return [ProbeEffect(rows, np.zeros((0, P.shape[0] // 2))) for P in probes]
    factor = Factorizer().factorize(normal[:, D][D, :])
    J = Js[rows][:, D]
    out = []
    for P in probes:   # one probe at a time: memory (domain x 2 positions) stays that of one probe
        W = np.asarray(factor.solve(P[:, D].T.toarray())).reshape(D.size, P.shape[0])
        out.append(ProbeEffect(rows, _lengths((J @ W) * size[rows, None])))
    return out


def probe_effects(factor: Factor, normal: sp.csc_matrix, Js: sp.csr_matrix, size: np.ndarray,
                  probes: Sequence[sp.csr_matrix], hoods: Sequence[Neighbourhood | None],
                  workers: int = 1) -> list[ProbeEffect]:
    """:func:`local_probe_effects` for the probes with a neighbourhood (probes that share one
    ``Neighbourhood`` object share its factorisation), :func:`exact_probe_effects` for the others;
    ``workers`` threads over the neighbourhoods."""
    Js_csc = Js.tocsc() if any(h is not None for h in hoods) else None
    tasks: dict[int, list[int]] = {}
    for k, hood in enumerate(hoods):
        tasks.setdefault(id(hood) if hood is not None else -1 - k, []).append(k)

    def one(ks: list[int]) -> list[ProbeEffect]:
        hood = hoods[ks[0]]
        if hood is None or Js_csc is None:
            return [exact_probe_effects(factor, Js, size, probes[k]) for k in ks]
        return local_probe_effects(normal, Js_csc, Js, size, [probes[k] for k in ks], hood)

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


__all__ = ["Neighbourhood", "ProbeEffect", "exact_probe_effects", "local_probe_effects", "probe_effects"]
