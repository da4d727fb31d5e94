"""Benchmark: scangeo's dense BLAS/LAPACK calls at 1 and at 2 OpenBLAS threads, quiet and under load.

The calls are those of the adjustment's inner loops, at the sizes they have there:

- ``qr 1380x96``: the break selection's QR of a current design (``adjustment/diagnosis/local_fit.py``,
  ``scipy.linalg.qr(mode="r")``) and the triangular inverse beside it;
- ``eigvalsh k`` and ``inv k``: the redundancy matrix ``S`` of the removals since the last full solution
  (``lsq/removal.py``, ``lsq/separability.py``: k = the removed rows, up to 256);
- ``B @ S^-1 (m x k)``: the updated leverages of the tested rows (``RemovalUpdate.leverages``: m tested
  rows of a laser block, 3,000 on a reduced montafon block, 56,000 on the full one);
- ``solve 300``: a dense solve of a few hundred unknowns;
- ``cholmod``: CHOLMOD's supernodal factorisation of the sparse normal matrix of
  ``tests/benchmarks/solver.py`` (24 strips, 110,239 unknowns), whose BLAS is the system's OpenBLAS.

Each call runs ``--repeat`` times at 1 thread and at 2 (``threadpoolctl``, every BLAS library of the
process), alternating, in this process; printed: CPU seconds of the process (every thread, the
spinning of OpenBLAS's idle threads included) and wall seconds per call, the least of the repeats,
and the ratios 2 threads / 1 thread. ``--load N`` starts N busy-loop processes beside the
measurement (the load the machine then has is printed; the machine's own load counts as well).

Run: python tests/benchmarks/blas_threads.py [--repeat 5] [--load 0 1 2] [--skip-cholmod]
"""
from __future__ import annotations

import argparse
import multiprocessing as mp
import os
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import scipy.linalg

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))


def busy(stop) -> None:
    """A busy loop until ``stop`` is set (one core's worth of load)."""
    x = 0
    while not stop.is_set():
        for _ in range(100_000):
            x += 1


def calls(skip_cholmod: bool) -> dict[str, Callable[[], object]]:
    rng = np.random.default_rng(1)
    out: dict[str, Callable[[], object]] = {}
    A = rng.standard_normal((1380, 96))

    def qr():
        R = scipy.linalg.qr(A, mode="r", check_finite=False)[0][:96]
        return scipy.linalg.solve_triangular(R, np.eye(96), check_finite=False)

    out["qr 1380x96 + triangular inverse"] = qr
    for k in (24, 96, 256):
        M = rng.standard_normal((k, 3 * k))
        S = np.eye(k) + M @ M.T / (3 * k)
        out[f"eigvalsh {k}"] = lambda S=S: np.linalg.eigvalsh(S)
        out[f"inv {k}"] = lambda S=S: np.linalg.inv(S)
    for m, k in ((3000, 96), (3000, 256), (56000, 96), (56000, 256)):
        B = rng.standard_normal((m, k))
        S = np.linalg.inv(np.eye(k) + 0.01 * np.ones((k, k)))
        out[f"B @ S^-1, leverages {m}x{k}"] = lambda B=B, S=S: np.einsum("ik,ik->i", B @ S, B)
    N = rng.standard_normal((300, 300))
    N = N @ N.T + 300 * np.eye(300)
    b = rng.standard_normal(300)
    out["solve 300"] = lambda: np.linalg.solve(N, b)
    if not skip_cholmod:
        from scangeo.lsq.factor import Factorizer, available_backends
        from tests.benchmarks.solver import normal_matrix

        if "cholmod" in available_backends():
            Nsp = normal_matrix()
            fac = Factorizer("cholmod")
            out["cholmod factor 110k unknowns"] = lambda: fac.factorize(Nsp)
    return out


def measure(fn: Callable[[], object], threads: int, controller) -> tuple[float, float]:
    with controller.limit(limits=threads, user_api="blas"):
        c, t = time.process_time(), time.perf_counter()
        fn()
        return time.process_time() - c, time.perf_counter() - t


def run(loads: list[int], repeat: int, skip_cholmod: bool) -> None:
    from threadpoolctl import ThreadpoolController

    fns = calls(skip_cholmod)
    controller = ThreadpoolController()
    libs = [f"{i['prefix']} {i.get('version')} {i.get('architecture')} ({i['num_threads']} threads)"
            for i in controller.info() if i["user_api"] == "blas"]
    print(f"BLAS: {'; '.join(libs)}; OPENBLAS_CORETYPE={os.environ.get('OPENBLAS_CORETYPE')}", flush=True)
    for fn in fns.values():  # warm-up: threads started, pages touched
        for threads in (1, 2):
            measure(fn, threads, controller)
    ctx = mp.get_context("fork")
    for load in loads:
        stop = ctx.Event()
        procs = [ctx.Process(target=busy, args=(stop,), daemon=True) for _ in range(load)]
        for p in procs:
            p.start()
        time.sleep(2.0 if load else 0.0)
        print(f"\n{load} busy-loop processes beside it; load average {os.getloadavg()[0]:.1f} at the start", flush=True)
        print(f"{'call':38s}{'1 thr CPU ms':>13}{'2 thr CPU ms':>13}{'CPU 2/1':>8}{'1 thr wall ms':>14}"
              f"{'2 thr wall ms':>14}{'wall 2/1':>9}")
        for name, fn in fns.items():
            best = {1: [np.inf, np.inf], 2: [np.inf, np.inf]}
            n = repeat if "cholmod" not in name else max(1, repeat // 2)
            for _ in range(n):
                for threads in (1, 2):
                    cpu, wall = measure(fn, threads, controller)
                    best[threads] = [min(best[threads][0], cpu), min(best[threads][1], wall)]
            (c1, w1), (c2, w2) = best[1], best[2]
            print(f"{name:38s}{1e3 * c1:13.2f}{1e3 * c2:13.2f}{c2 / c1:8.2f}{1e3 * w1:14.2f}{1e3 * w2:14.2f}"
                  f"{w2 / w1:9.2f}", flush=True)
        stop.set()
        for p in procs:
            p.join()
        print(f"load average {os.getloadavg()[0]:.1f} at the end", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--load", type=int, nargs="+", default=[0, 1, 2], help="busy-loop processes beside it, per run")
    ap.add_argument("--skip-cholmod", action="store_true")
    args = ap.parse_args()
    run(args.load, args.repeat, args.skip_cholmod)


if __name__ == "__main__":
    main()
