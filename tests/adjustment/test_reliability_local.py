"""The external reliability over the rows near each strip: per window of strips, the rows
within ``radius`` strips evaluated, with the exact effects (partial solves with the whole factor). On
a 7-strip block it equals the figures over every row to rounding, and leaves the MDBs alone."""
from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from scangeo.adjustment.keys import Ground
from scangeo.adjustment.neighbourhoods import strip_neighbourhoods
from scangeo.adjustment.reliability_summary import strip_probes
from scangeo.adjustment.results import run_variant
from scangeo.adjustment.variants import Variant
from scangeo.lsq.partial_solve import PartialSolver
from scangeo.lsq.probe_effects import exact_probe_effects, near_probe_effects
from scangeo.lsq.reliability import compute_reliability
from scangeo.lsq.separability import scaled_jacobian

from .test_block import SHIFT_ONLY, _simulate

STRIPS = [f"{i:02d}" for i in range(1, 8)]


@pytest.fixture(scope="module")
def seven(tmp_path_factory):
    root = _simulate(tmp_path_factory.mktemp("local") / "seven",
                     {**SHIFT_ONLY, "flight": {"strips": len(STRIPS), "lines": 120},
                      "points": {"control_band_lines": 30.0}})
    return run_variant(root, Variant("SE", "SE"))


def test_strip_windows_share_a_neighbourhood_and_cover_every_strip(seven):
    hoods = strip_neighbourhoods(seven.adjustment.solution, radius=1, core=1)
    assert sorted(hoods) == STRIPS
    windows: dict[int, list[str]] = {}
    for sid, h in hoods.items():
        windows.setdefault(id(h), []).append(sid)
    # from the first strip along the chain: a strip not yet served and the others within one step
    assert sorted(sorted(w) for w in windows.values()) == [["01", "02"], ["03", "04"], ["05", "06"], ["07"]]
    n = seven.adjustment.solution.layout.n
    for h in hoods.values():
        assert 0 < h.near.size < n
    # a neighbourhood that reaches every strip is none: every row is evaluated
    assert strip_neighbourhoods(seven.adjustment.solution, radius=6, core=1) == {}


@pytest.mark.numerics  # two numerical routes: run under a second BLAS kernel too (.ci/run)
def test_partial_solve_equals_the_full_solve_at_the_rows_asked_for(seven):
    sol, st = seven.adjustment.solution, seven.adjustment.statistics
    n = sol.layout.n
    rng = np.random.default_rng(5)
    rows = np.sort(rng.choice(n, 12, replace=False))
    B = rng.normal(size=(rows.size, 3))
    targets = rng.choice(n, 40, replace=False)
    full = np.zeros((n, 3))
    full[rows] = B
    expected = np.asarray(sol.factor.solve(full)).reshape(n, 3)[targets]
    got = st.inverse.partial_solver().solve(rows, B, targets)
    np.testing.assert_allclose(got, expected, rtol=1e-10, atol=1e-12 * np.abs(expected).max())
    # a right-hand side on no unknown (a probe whose unknowns are all fixed, e.g. DG): zeros
    np.testing.assert_array_equal(st.inverse.partial_solver().solve(np.zeros(0, int), np.zeros((0, 90)), targets),
                                  np.zeros((targets.size, 90)))
    ldl = sol.factor.ldl()
    again = PartialSolver.from_ldl(ldl.perm, ldl.L, ldl.d).solve(rows, B, targets)
    np.testing.assert_allclose(again, got, rtol=1e-12)


def test_near_rows_get_the_exact_effects_and_the_far_rows_none(seven):
    sol, st = seven.adjustment.solution, seven.adjustment.statistics
    probe = strip_probes(seven, radius=1)[0]          # strip 01: rows of strips 01-03 evaluated
    assert probe.strip == "01" and probe.neighbourhood is not None
    P = (probe.matrix @ sp.diags(1.0 / sol.system.scale)).tocsr()
    Js = scaled_jacobian(sol)
    Js = Js[np.flatnonzero(np.diff(Js.indptr) > 0)]
    size = np.linspace(1.0, 2.0, Js.shape[0])
    exact = exact_probe_effects(sol.factor, Js, size, P)
    near, = near_probe_effects(st.inverse.partial_solver(), Js.tocsc(), Js, size, [P], probe.neighbourhood)
    assert 0 < near.rows.size < 0.7 * Js.shape[0]
    np.testing.assert_allclose(near.length, exact.length[near.rows], rtol=1e-9, atol=1e-12 * exact.length.max())
    # the rows left out are those of the far strips: their effects are far below the largest
    far = np.setdiff1d(np.arange(Js.shape[0]), near.rows)
    assert exact.length[far].max() < 0.01 * exact.length.max()


@pytest.mark.numerics  # two numerical routes: run under a second BLAS kernel too (.ci/run)
def test_external_reliability_over_the_near_rows_equals_the_one_over_every_row(seven):
    sol, st = seven.adjustment.solution, seven.adjustment.statistics
    every = compute_reliability(sol, st, strip_probes(seven, radius=None), point_key=Ground)
    probes = strip_probes(seven)                  # the default radius
    assert sum(p.neighbourhood is not None for p in probes) >= 4     # the near route is taken
    near = compute_reliability(sol, st, probes, point_key=Ground, workers=2)
    for a, b in zip(every.mdb, near.mdb):
        np.testing.assert_array_equal(a, b)
    for a, b in zip(every.ext_point_m, near.ext_point_m):
        np.testing.assert_array_equal(a, b)
    assert every.ext_strip.keys() == near.ext_strip.keys() and len(every.ext_strip) == len(STRIPS)
    for sid, (size, gi, row) in every.ext_strip.items():
        assert near.ext_strip[sid][1:] == (gi, row)
        assert near.ext_strip[sid][0] == pytest.approx(size, rel=1e-9)
        np.testing.assert_allclose(near.ext_positions[sid], every.ext_positions[sid], rtol=1e-9)
    for a, b in zip(every.ext_orientation_m, near.ext_orientation_m):
        np.testing.assert_allclose(b, a, rtol=1e-9)
