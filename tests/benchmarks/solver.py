"""Benchmark: the sparse normal-equation solvers of scangeo.adjustment, side by side.

A synthetic normal matrix of the adjustment's structure: 24 strips x 700 spline knots x 6 (a cubic
B-spline couples 4 neighbouring knots: banded blocks), a correction model of 18 coefficients per strip
(dense against its strip's knots through the GPS/IMU observations), 7 calibration unknowns (dense
against every image observation), and 3,000 tie points (3 unknowns each) measured in 2-3 adjacent
strips of alternating flight direction: 110,239 unknowns in all.

Run:  python tests/benchmarks/solver.py [--skip-baseline]
Baseline: scipy's default sparse solve (SuperLU with COLAMD ordering and partial pivoting).
"""
from __future__ import annotations

import argparse
import os
import resource
import time

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from scangeo.lsq.factor import Factorizer, available_backends
from scangeo.lsq.selinv import SparseInverse


def normal_matrix(n_strips=24, n_knots=700, n_ties=3000, n_corr=18, n_calib=7, seed=0) -> sp.csc_matrix:
    """A Jacobi-scaled normal matrix J^T J of the structure described above."""
    rng = np.random.default_rng(seed)
    nk, ng, nc = n_strips * n_knots * 6, 3 * n_ties, n_strips * n_corr
    n = nk + ng + nc + n_calib
    R, C, V, r0 = [], [], [], 0
    k = np.arange(n_knots - 3)
    for s in range(n_strips):  # GPS/IMU samples: 4 knots of one component + the strip's corrections
        for comp in range(6):
            m = k.size
            cols = np.concatenate([(s * n_knots + k[:, None] + np.arange(4)) * 6 + comp,
                                   np.broadcast_to(nk + ng + s * n_corr + np.arange(n_corr), (m, n_corr))], 1)
            R.append(np.repeat(r0 + np.arange(m), cols.shape[1]))
            C.append(cols.ravel())
            V.append(rng.standard_normal(cols.size))
            r0 += m
    for p in range(n_ties):  # image measurements (line, pixel) of tie points in 2-3 strips
        s, u = rng.integers(0, n_strips - 2), rng.random()
        for ss in range(s, s + int(rng.integers(2, 4))):
            kk = int(u * (n_knots - 4)) if ss % 2 == 0 else int((1 - u) * (n_knots - 4))
            c = np.concatenate([((ss * n_knots + kk + np.arange(4))[:, None] * 6 + np.arange(6)).ravel(),
                                nk + 3 * p + np.arange(3), nk + ng + nc + np.arange(n_calib)])
            for _ in range(2):
                R.append(np.full(c.size, r0))
                C.append(c)
                V.append(rng.standard_normal(c.size))
                r0 += 1
    J = sp.csr_matrix((np.concatenate(V), (np.concatenate(R), np.concatenate(C))), shape=(r0, n))
    N = (J.T @ J).tocsc() + sp.diags(np.full(n, 1e-2))
    d = 1.0 / np.sqrt(N.diagonal())
    return (sp.diags(d) @ N @ sp.diags(d)).tocsc()


def timed(fn, *args):
    t0 = time.perf_counter()
    out = fn(*args)
    return out, time.perf_counter() - t0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--skip-baseline", action="store_true", help="skip scipy's default spsolve (~1-2 min)")
    args = parser.parse_args()
    print(f"OPENBLAS_CORETYPE={os.environ.get('OPENBLAS_CORETYPE')}  backends: {available_backends()}")
    N, t_build = timed(normal_matrix)
    print(f"normal matrix: {N.shape[0]} unknowns, {N.nnz} nonzeros (built in {t_build:.1f} s)")
    b = np.ones(N.shape[0])
    rows = []
    if not args.skip_baseline:
        x, t = timed(spla.spsolve, N, b)
        rows.append(("scipy spsolve default (SuperLU COLAMD) [baseline]", t, None, np.abs(N @ x - b).max()))
    for backend in available_backends():
        fz = Factorizer(backend)
        f, t_first = timed(fz.factorize, N)
        f, t_again = timed(fz.factorize, N)  # numeric refactorisation (cholmod reuses the analysis)
        x, t_solve = timed(f.solve, b)
        ldl, t_ldl = timed(f.ldl)
        rows.append(
            (f"{backend}: factor (first, with ordering)", t_first, ldl.L.nnz + N.shape[0], np.abs(N @ x - b).max())
        )
        rows.append((f"{backend}: factor (again, same pattern)", t_again, None, None))
        rows.append((f"{backend}: solve", t_solve, None, None))
        rows.append((f"{backend}: explicit LDL^T for selected inversion", t_ldl, None, None))
        if backend == available_backends()[0]:
            inv, t_inv = timed(SparseInverse, ldl)
            rows.append((f"{backend}: Takahashi selected inverse (all {N.shape[0]} variances)", t_inv, None, None))
            probe = np.arange(0, N.shape[0], N.shape[0] // 5)
            e = np.zeros((N.shape[0], probe.size))
            e[probe, np.arange(probe.size)] = 1.0
            ref = f.solve(e)[probe, np.arange(probe.size)]
            print(
                f"selected-inverse check at {probe.size} unknowns: max rel. error "
                f"{np.max(np.abs(inv.diagonal()[probe] - ref) / ref):.1e}"
            )
    base = rows[0][1] if not args.skip_baseline else None
    print(f"{'step':66s} {'seconds':>8s} {'x baseline':>10s} {'nnz(L)':>10s} {'residual':>9s}")
    for name, t, nnz, res in rows:
        ratio = f"{base / t:10.1f}" if base else " " * 10
        print(f"{name:66s} {t:8.2f} {ratio} {nnz or '':>10} {'' if res is None else f'{res:.1e}':>9}")
    print(f"peak memory: {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MiB")


if __name__ == "__main__":
    main()
