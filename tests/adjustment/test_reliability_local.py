"""The local external reliability (issue 23): per window of strips, the unknowns beyond a margin held
fixed. On a 10-strip block it agrees with the exact figures (the whole factor, every row) to 1e-6
relative, and leaves the MDBs alone."""
from __future__ import annotations

import numpy as np
import pytest

from scangeo.adjustment.keys import Ground
from scangeo.adjustment.neighbourhoods import strip_neighbourhoods
from scangeo.adjustment.reliability_summary import strip_probes
from scangeo.adjustment.results import run_variant
from scangeo.adjustment.variants import Variant
from scangeo.lsq.reliability import compute_reliability

from .test_block import SHIFT_ONLY, _simulate


@pytest.fixture(scope="module")
def ten(tmp_path_factory):
    root = _simulate(tmp_path_factory.mktemp("local") / "ten",
                     {**SHIFT_ONLY, "flight": {"strips": 10, "lines": 120},
                      "points": {"control_band_lines": 30.0}})
    return run_variant(root, Variant("SE", "SE"))


def test_strip_windows_share_a_neighbourhood_and_cover_every_strip(ten):
    hoods = strip_neighbourhoods(ten.adjustment.solution, radius=1, margin=1, core=1)
    assert sorted(hoods) == [f"{i:02d}" for i in range(1, 11)]
    windows: dict[int, list[str]] = {}
    for sid, h in hoods.items():
        windows.setdefault(id(h), []).append(sid)
    # from the first strip along the chain: a strip not yet served and the others within one step
    expected = [["01", "02"], ["03", "04"], ["05", "06"], ["07", "08"], ["09", "10"]]
    assert sorted(sorted(w) for w in windows.values()) == expected
    n = ten.adjustment.solution.layout.n
    for h in hoods.values():
        assert np.isin(h.near, h.domain).all() and h.near.size < h.domain.size < n


def test_local_external_reliability_agrees_with_the_exact_one(ten):
    sol, st = ten.adjustment.solution, ten.adjustment.statistics
    exact = compute_reliability(sol, st, strip_probes(ten, radius=None), point_key=Ground)
    probes = strip_probes(ten)                  # default radius and margin
    assert sum(p.neighbourhood is not None for p in probes) >= 4     # the local route is taken
    local = compute_reliability(sol, st, probes, point_key=Ground, workers=2)
    for a, b in zip(exact.mdb, local.mdb):
        np.testing.assert_array_equal(a, b)
    for a, b in zip(exact.ext_point_m, local.ext_point_m):
        np.testing.assert_array_equal(a, b)
    assert exact.ext_strip.keys() == local.ext_strip.keys() and len(exact.ext_strip) == 10
    for sid, (size, gi, row) in exact.ext_strip.items():
        assert local.ext_strip[sid][1:] == (gi, row)
        assert local.ext_strip[sid][0] == pytest.approx(size, rel=1e-6)
        np.testing.assert_allclose(local.ext_positions[sid], exact.ext_positions[sid], rtol=1e-6)
    for a, b in zip(exact.ext_orientation_m, local.ext_orientation_m):
        np.testing.assert_allclose(b, a, rtol=1e-6)
    # the approximation is there: the figures are not bit-equal to the exact ones
    assert any(not np.array_equal(a, b) for a, b in zip(exact.ext_orientation_m, local.ext_orientation_m))
