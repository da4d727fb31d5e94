"""Several units per round of data snooping: exact couplings, and the same blunders as Baarda's one by one."""
from __future__ import annotations

import numpy as np
import pytest

from scangeo.lsq import SnoopingOptions, Solver, SolverOptions, Statistics, adjust
from scangeo.lsq.removal import RemovalUpdate
from scangeo.lsq.rounds import couplings
from scangeo.lsq.separability import scaled_jacobian

from .problems import levelling_network
from .test_engine import levelling_parameters


@pytest.mark.numerics  # two numerical routes: run under a second BLAS kernel too (.ci/run)
def test_couplings_are_those_of_the_dense_inverse_before_and_after_a_removal():
    rng = np.random.default_rng(2)
    truth, group = levelling_network(rng, n_points=15, n_lines=50)
    solver = Solver(levelling_parameters(truth), [group], SolverOptions())
    solution = solver.solve()
    stats = Statistics(solution)
    Js = scaled_jacobian(solution)
    N = solution.system.normal.toarray()
    a, b = np.array([0, 3, 7]), np.array([10, 11, 40])
    partial = stats.inverse.partial_solver()
    dense = Js[b].toarray() @ np.linalg.solve(N, Js[a].toarray().T)
    np.testing.assert_allclose(couplings(Js, partial, a, b), dense, rtol=1e-10, atol=1e-12)
    # after removing row 20 by the low-rank update: N' = N - j_20^T j_20
    update = RemovalUpdate(solver, solution, stats.leverages, np.ones(group.n_rows, bool))
    assert update.remove(np.array([20]))
    j = Js[[20]].toarray()
    reduced = Js[b].toarray() @ np.linalg.solve(N - j.T @ j, Js[a].toarray().T)
    got = couplings(Js, partial, a, b) + update.coupling_correction(a, b)
    np.testing.assert_allclose(got, reduced, rtol=1e-9, atol=1e-12)


def test_independent_units_per_round_find_baardas_blunders_in_fewer_rounds():
    fewer = 0
    for seed in range(3):
        rng = np.random.default_rng(seed)
        bad = rng.choice(150, 6, replace=False)
        truth, group = levelling_network(rng, n_points=40, n_lines=150, blunders=[(i, 0.03) for i in bad])
        baarda = adjust(levelling_parameters(truth), [group], SolverOptions(), SnoopingOptions())
        rounds = adjust(levelling_parameters(truth), [group], SolverOptions(),
                        SnoopingOptions(per_round=64, independent=True))
        assert sorted(r.id for r in rounds.rejections) == sorted(r.id for r in baarda.rejections)
        assert {group.ids[i] for i in bad} <= {r.id for r in rounds.rejections}
        assert rounds.statistics.sigma0 == pytest.approx(baarda.statistics.sigma0, rel=1e-9)
        assert rounds.snooping_rounds <= baarda.snooping_rounds == len(baarda.rejections)
        fewer += rounds.snooping_rounds < baarda.snooping_rounds
    assert fewer >= 2
