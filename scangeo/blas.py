"""OpenBLAS's threads only where they pay: the small dense calls run on one thread.

numpy, scipy and CHOLMOD each load an OpenBLAS that starts a thread per core. For a large product
(the leverages ``B S^-1`` of tens of thousands of tested rows, CHOLMOD's supernodal factorisation of a
block) the second thread shortens the wall time on a quiet machine. For the small calls of the
adjustment's inner loops (a QR of 1380 x 96, the inverse and eigenvalues of a redundancy matrix of a
few hundred rows, a solve of a few hundred unknowns) it does not: the threads hand the work over and
spin waiting for each other, and on a loaded machine, where the second core is busy with another
process, a call costs 10-150 times the CPU of one thread (docs/performance.md, "BLAS threads";
``tests/benchmarks/blas_threads.py``). :func:`one_thread` limits every BLAS library of the process to
one thread around such calls and restores the previous limits after them.

The limit is a property of the process (OpenBLAS has one thread count per library): code that
calls BLAS from several threads at once does not use :func:`one_thread`; scangeo's adjustment runs
in one thread. A thread count can change the last bit of a LAPACK result (an eigenvalue, an inverse
of a few hundred rows: 1e-16 relative, as another OpenBLAS kernel does), not a figure scangeo reports
(tests/test_blas.py; the demo's outputs compared before and after in docs/performance.md).
"""
from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager

import scipy.linalg  # noqa: F401  (its OpenBLAS loaded before the libraries are listed)
from threadpoolctl import ThreadpoolController

_lock = threading.Lock()
_blas = None
_depth = 0


def _libraries():
    """The BLAS libraries of the process, listed once (36 ms under load; a limit then costs ~0.1 ms)."""
    global _blas
    if _blas is None:
        _blas = ThreadpoolController().select(user_api="blas")
    return _blas


@contextmanager
def one_thread() -> Iterator[None]:
    """Run the block with every BLAS library of the process on one thread (nested: the outermost
    limits and restores).

    Yields
    ------
    None
    """
    global _depth
    with _lock:
        _depth += 1
        outer = _depth == 1
    if not outer:
        try:
            yield
        finally:
            with _lock:
                _depth -= 1
        return
    limiter = _libraries().limit(limits=1)
    try:
        yield
    finally:
        limiter.restore_original_limits()
        with _lock:
            _depth -= 1


def threads() -> dict[str, int]:
    """The thread count of each BLAS library of the process, by its file name (for benchmarks and tests).

    Returns
    -------
    dict of str to int
    """
    return {lib.filepath.rsplit("/", 1)[-1]: lib.num_threads for lib in _libraries().lib_controllers}


__all__ = ["one_thread", "threads"]
