"""SuperLU on a normal matrix with a zero diagonal pivot: a regularisable error, not 'off-diagonal pivots'."""
from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from scangeo.lsq.factor import Factorizer, NotPositiveDefinite


def test_a_zero_diagonal_gives_the_pivots_to_regularise():
    # columns 0 and 1 only coupled to each other (a zero diagonal: SuperLU would pivot off the diagonal)
    A = sp.csc_matrix(np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 2.0]]))
    with pytest.raises(NotPositiveDefinite, match="pivoted off the diagonal") as info:
        Factorizer("superlu").factorize(A)
    pivots = info.value.pivots
    assert pivots.shape == (3,) and pivots[2] == pytest.approx(2.0)
    assert np.sum(pivots[:2] <= 1e-10) >= 1  # the bad columns are the ones the solver regularises


def test_a_regular_matrix_still_factorises():
    A = sp.csc_matrix(np.array([[4.0, 1.0, 0.0], [1.0, 3.0, 0.5], [0.0, 0.5, 2.0]]))
    f = Factorizer("superlu").factorize(A)
    b = np.array([1.0, 2.0, 3.0])
    assert f.solve(b) == pytest.approx(np.linalg.solve(A.toarray(), b))
