"""scangeo.blas: the small dense calls on one OpenBLAS thread, the limits restored after them."""
from __future__ import annotations

import numpy as np
import pytest

from scangeo import blas


def test_one_thread_limits_every_blas_library_and_restores_them():
    before = blas.threads()
    assert before, "no BLAS library found in the process"
    with blas.one_thread():
        assert set(blas.threads().values()) == {1}
    assert blas.threads() == before


def test_nested_limits_restore_only_at_the_outermost():
    before = blas.threads()
    with blas.one_thread():
        with blas.one_thread():
            assert set(blas.threads().values()) == {1}
        assert set(blas.threads().values()) == {1}  # the inner exit keeps the outer's limit
    assert blas.threads() == before


def test_limits_restored_after_an_exception():
    before = blas.threads()
    with pytest.raises(ZeroDivisionError), blas.one_thread():
        raise ZeroDivisionError
    assert blas.threads() == before


def test_as_a_decorator():
    @blas.one_thread()
    def inside() -> set[int]:
        return set(blas.threads().values())

    before = blas.threads()
    assert inside() == {1} and inside() == {1}
    assert blas.threads() == before


@pytest.mark.numerics
def test_the_limited_calls_agree_with_the_threaded_ones_to_rounding():
    """What one thread changes in the calls scangeo limits: at most the last bits (a removal's
    redundancy matrix of 256 rows, a QR of the break selection's size)."""
    import scipy.linalg

    rng = np.random.default_rng(5)
    M = rng.standard_normal((256, 768))
    S = np.eye(256) + M @ M.T / 768
    A = rng.standard_normal((1380, 96))

    def calls():
        return (np.linalg.eigvalsh(S), np.linalg.inv(S), scipy.linalg.qr(A, mode="r", check_finite=False)[0][:96])

    threaded = calls()
    with blas.one_thread():
        single = calls()
    for a, b in zip(threaded, single):
        assert np.allclose(a, b, rtol=1e-12, atol=1e-12 * np.abs(a).max())
