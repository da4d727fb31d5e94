"""Data snooping finds injected blunders; rank defects end in a regularisation note, never a failure."""
from __future__ import annotations

import logging

import numpy as np
import pytest

from scangeo.lsq import Parameters, SnoopingOptions, Solver, SolverOptions, Statistics, Unknown, adjust
from scangeo.lsq import factor as factor_module
from scangeo.lsq.removal import RemovalUpdate
from scangeo.lsq.solver import REMOVED

from .backends import BACKENDS
from .problems import Distances, HeightDifferences, levelling_network
from .test_engine import NO_SNOOPING, levelling_parameters


@pytest.mark.parametrize("backend", BACKENDS)
def test_blunders_are_flagged_and_good_observations_kept(backend):
    flagged_bad, flagged_good, n_bad, n_good = 0, 0, 0, 0
    for seed in range(5):
        rng = np.random.default_rng(seed)
        n_lines = 120
        bad = rng.choice(n_lines, 4, replace=False)
        truth, group = levelling_network(rng, n_points=25, n_lines=n_lines, sigma=0.002,
                                         blunders=[(i, 0.05 * rng.choice([-1, 1])) for i in bad])
        result = adjust(levelling_parameters(truth), [group], SolverOptions(backend=backend),
                        SnoopingOptions(critical_value=3.29))
        rejected = {r.id for r in result.rejections}
        bad_ids = {group.ids[i] for i in bad}
        flagged_bad += len(rejected & bad_ids)
        flagged_good += len(rejected - bad_ids)
        n_bad += len(bad_ids)
        n_good += n_lines - len(bad_ids)
        # after snooping, the heights are as good as without blunders
        got = np.array([result.parameters[Unknown(n)].values[0] for n in truth])
        assert np.max(np.abs(got - np.array(list(truth.values())))) < 0.01
        assert result.statistics.accounting.rejected == len(rejected)
        w = result.statistics.w_tests()[0]
        active = result.solution.active[0]
        assert np.nanmax(np.abs(w[active])) <= 3.29
        assert np.all(np.abs(w[~active]) > 3.29)  # the predicted residuals of rejected rows still fail
    assert flagged_bad / n_bad >= 0.95
    assert flagged_good / n_good <= 0.01


def test_snooping_critical_value_is_configurable():
    rng = np.random.default_rng(7)
    truth, group = levelling_network(rng, n_points=10, n_lines=40, blunders=[(5, 0.02)])
    strict = adjust(levelling_parameters(truth), [group], snooping=SnoopingOptions(critical_value=3.29))
    lax = adjust(levelling_parameters(truth), [group], snooping=SnoopingOptions(critical_value=1e3))
    assert group.ids[5] in {r.id for r in strict.rejections}
    assert lax.rejections == []
    # sigma0 of the first solution, before any rejection, is that of an adjustment without snooping
    plain = adjust(levelling_parameters(truth), [group], snooping=NO_SNOOPING)
    assert strict.sigma0_first == pytest.approx(plain.statistics.sigma0, rel=1e-12)
    assert strict.sigma0_first > 1.5 * strict.statistics.sigma0  # the blunder was in it, and is gone
    assert lax.sigma0_first == pytest.approx(lax.statistics.sigma0, rel=1e-12)


@pytest.mark.parametrize("backend", BACKENDS)
def test_datum_defect_is_regularised_not_fatal(backend):
    rng = np.random.default_rng(3)
    truth, group = levelling_network(rng, n_points=8, n_lines=20)
    params = Parameters()
    for name in truth:  # no benchmark fixed: a datum defect of 1
        params.add(Unknown(name), [truth[name] + 1.0], regularisation_sigma=0.5)
    result = adjust(params, [group], SolverOptions(backend=backend), NO_SNOOPING)
    notes = result.solution.regularisation
    assert len(notes) == 1
    assert notes[0].sigma == 0.5 and "singular" in notes[0].reason
    assert isinstance(notes[0].key, Unknown)
    # the differences are determined all the same
    got = {n: result.parameters[Unknown(n)].values[0] for n in truth}
    for a, b in [("P0", "P1"), ("P2", "P7")]:
        assert got[b] - got[a] == pytest.approx(truth[b] - truth[a], abs=0.01)
    # the pseudo-observation counts in the accounting, the unknowns do not lose a column
    acc = result.statistics.accounting
    assert acc.pseudo_observations == 1 and acc.unknowns == 8


def test_unknown_without_observations_is_regularised():
    group = HeightDifferences(["P0", "P0"], ["P1", "P1"], [1.0, 1.1], [0.1, 0.1])
    params = Parameters()
    params.add(Unknown("P0"), [0.0], free=False)
    params.add(Unknown("P1"), [0.0])
    params.add(Unknown("lonely"), [3.0], regularisation_sigma=2.0)
    result = adjust(params, [group], SolverOptions(), NO_SNOOPING)
    (note,) = result.solution.regularisation
    assert note.key == Unknown("lonely") and note.sigma == 2.0 and "no observation" in note.reason
    assert result.parameters[Unknown("lonely")].values[0] == 3.0
    assert result.statistics.sigmas(Unknown("lonely"), posterior=False)[0] == pytest.approx(2.0)
    assert result.parameters[Unknown("P1")].values[0] == pytest.approx(1.05)


def test_nearly_singular_geometry_is_regularised():
    # three collinear stations: the point's side of the line is undetermined at the line itself
    stations = np.array([[0, 0], [100, 0], [200, 0]], float)
    p = np.array([50.0, 0.0])
    d = np.hypot(*(p - stations).T)
    params = Parameters()
    params.add(Unknown("P"), [50.0, 0.0], regularisation_sigma=1.0)
    result = adjust(params, [Distances(stations, d, 0.01)], SolverOptions(), NO_SNOOPING)
    assert [n.component for n in result.solution.regularisation] == ["1"]
    np.testing.assert_allclose(result.parameters[Unknown("P")].values, p, atol=1e-9)


def test_scipy_fallback_when_cholmod_is_absent(monkeypatch):
    monkeypatch.setattr(factor_module, "_cholmod_analyze", None)
    assert factor_module.available_backends() == ["superlu"]
    rng = np.random.default_rng(1)
    truth, group = levelling_network(rng)
    result = adjust(levelling_parameters(truth), [group], SolverOptions(backend="auto"), NO_SNOOPING)
    assert result.solution.factor.backend == "superlu"
    got = np.array([result.parameters[Unknown(n)].values[0] for n in truth])
    assert np.max(np.abs(got - np.array(list(truth.values())))) < 0.02
    with pytest.raises(factor_module.AdjustmentError, match="scikit-sparse"):
        factor_module.Factorizer("cholmod")


def _full_solution(solver, active):
    solution = solver.solve([a.copy() for a in active])
    return solution, Statistics(solution)


def test_removal_update_is_exact_on_a_linear_problem():
    # removing observations by the low-rank update gives the solution and the w-tests of a full
    # re-solution, one removal and two (cumulative) removals after the factorisation
    rng = np.random.default_rng(4)
    truth, group = levelling_network(rng, n_points=20, n_lines=70, blunders=[(5, 0.03), (33, -0.03)])
    solver = Solver(levelling_parameters(truth), [group], SolverOptions())
    solution = solver.solve()
    stats = Statistics(solution)
    update = RemovalUpdate(solver, solution, stats.leverages, np.ones(group.n_rows, bool))
    for rows in ([5], [33]):
        assert update.remove(np.array(rows))
        reference, ref_stats = _full_solution(Solver(levelling_parameters(truth), [group], SolverOptions()),
                                              update.active)
        for name in truth:
            assert update.values[Unknown(name)][0] == pytest.approx(reference.parameters[Unknown(name)].values[0],
                                                                   abs=1e-10)
        w, w_ref = update.w_tests()[0], ref_stats.w_tests()[0]
        act = update.active[0]
        assert not act[rows].any() and np.isnan(w[~act]).all()
        np.testing.assert_allclose(w[act], w_ref[act], rtol=1e-8, atol=1e-8)


def test_removal_update_follows_a_nonlinear_problem():
    # trilateration: the chord iteration converges to the full solution within its tolerance
    stations = np.array([[0, 0], [400, 0], [0, 300], [500, 450], [-200, 250], [250, -300]], float)
    p = np.array([120.0, 90.0])
    d = np.hypot(*(p - stations).T) + np.array([0.003, -0.002, 0.001, 0.5, -0.002, 0.001])
    params = Parameters()
    params.add(Unknown("P"), [100.0, 100.0])
    group = Distances(stations, d, 0.003)
    solver = Solver(params, [group], SolverOptions())
    solution = solver.solve()
    stats = Statistics(solution)
    update = RemovalUpdate(solver, solution, stats.leverages, np.ones(group.n_rows, bool))
    assert update.remove(np.array([3]))
    reference, ref_stats = _full_solution(Solver(params, [group], SolverOptions()), update.active)
    sigma = ref_stats.sigmas(Unknown("P"), posterior=False)
    assert np.all(np.abs(update.values[Unknown("P")] - reference.parameters[Unknown("P")].values) < 0.05 * sigma)
    act = update.active[0]
    np.testing.assert_allclose(update.w_tests()[0][act], ref_stats.w_tests()[0][act], atol=0.05)
    assert np.abs(update.values[Unknown("P")] - p).max() < 0.01   # the blunder is gone


@pytest.mark.parametrize("method", ["update", "resolve"])
def test_removal_that_leaves_an_unknown_undetermined_is_regularised(method, caplog):
    # PX is tied to the network only by the two lines of one observation unit; one holds a blunder.
    # Removing the unit leaves PX undetermined: the update declines, the full solution regularises PX
    rng = np.random.default_rng(5)
    truth, net = levelling_network(rng, n_points=10, n_lines=30)
    truth["PX"] = 123.0
    frm = list(net.frm) + ["P3", "P7"]
    to = list(net.to) + ["PX", "PX"]
    dh = np.concatenate([net.dh, [truth["PX"] - truth["P3"] + 0.05, truth["PX"] - truth["P7"]]])
    group = HeightDifferences(frm, to, dh, np.concatenate([net.sigma, [0.002, 0.002]]))
    group.row_unit = np.concatenate([np.arange(net.n_rows), [net.n_rows, net.n_rows]])
    params = levelling_parameters(truth)
    params[Unknown("PX")].regularisation_sigma[:] = 5.0
    with caplog.at_level(logging.INFO, logger="scangeo.lsq.solver"):
        result = adjust(params, [group], SolverOptions(), SnoopingOptions(method=method))
    assert [r.id for r in result.rejections] == ["P3-PX"]
    assert [(n.key, n.sigma) for n in result.solution.regularisation] == [(Unknown("PX"), 5.0)]
    # expected after a removal: said at INFO with the cause, not as a warning on the user's terminal
    assert result.solution.regularisation[0].reason == REMOVED
    (record,) = [r for r in caplog.records if "regularised" in r.getMessage()]
    assert record.levelno == logging.INFO
    assert result.full_solutions == 2


def test_update_and_resolve_snoop_alike_on_a_levelling_network():
    flagged = {}
    for method in ("update", "resolve"):
        rng = np.random.default_rng(9)
        truth, group = levelling_network(rng, n_points=30, n_lines=150, blunders=[(i, 0.03) for i in (2, 50, 77, 120)])
        result = adjust(levelling_parameters(truth), [group], SolverOptions(), SnoopingOptions(method=method))
        flagged[method] = result
    upd, ref = flagged["update"], flagged["resolve"]
    assert [r.id for r in upd.rejections] == [r.id for r in ref.rejections] and len(ref.rejections) == 4
    np.testing.assert_allclose([r.w for r in upd.rejections], [r.w for r in ref.rejections], rtol=1e-8)
    assert upd.statistics.sigma0 == pytest.approx(ref.statistics.sigma0, rel=1e-10)
    assert upd.full_solutions == 2 and ref.full_solutions == 5
