"""Solver back-ends for tests: CHOLMOD's absence is a visible skip naming it, never SuperLU twice."""
from __future__ import annotations

import pytest

from scangeo.lsq.factor import available_backends

CHOLMOD_MISSING = ("CHOLMOD back-end missing: scikit-sparse is not installed (bash .ci/install builds it "
                   "against libsuitesparse-dev)")

#: Parametrise a test over every back-end; the CHOLMOD case skips, naming it, when it is not installed.
BACKENDS = [pytest.param("cholmod", marks=pytest.mark.skipif("cholmod" not in available_backends(),
                                                             reason=CHOLMOD_MISSING)),
            "superlu"]


def require_cholmod() -> None:
    """Skip (naming the missing back-end) a test that compares CHOLMOD with SuperLU."""
    if "cholmod" not in available_backends():
        pytest.skip(CHOLMOD_MISSING)
