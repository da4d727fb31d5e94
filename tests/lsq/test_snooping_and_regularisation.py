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


@pytest.mark.parametrize("linear", [False, True])
def test_removal_update_is_exact_on_a_linear_problem(linear):
    # removing observations by the low-rank update gives the solution and the w-tests of a full
    # re-solution, one removal and two (cumulative) removals after the factorisation; the linear
    # rounds' model is the problem itself here, so they are exact too, without a linearisation
    rng = np.random.default_rng(4)
    truth, group = levelling_network(rng, n_points=20, n_lines=70, blunders=[(5, 0.03), (33, -0.03)])
    solver = Solver(levelling_parameters(truth), [group], SolverOptions())
    solution = solver.solve()
    stats = Statistics(solution)
    update = RemovalUpdate(solver, solution, stats.leverages, np.ones(group.n_rows, bool))
    for rows in ([5], [33]):
        assert update.remove(np.array(rows), linear=linear)
        assert update.polished is not linear
        reference, ref_stats = _full_solution(Solver(levelling_parameters(truth), [group], SolverOptions()),
                                              update.active)
        for name in truth:
            assert update.values[Unknown(name)][0] == pytest.approx(reference.parameters[Unknown(name)].values[0],
                                                                   abs=1e-10)
        w, w_ref = update.w_tests()[0], ref_stats.w_tests()[0]
        act = update.active[0]
        assert not act[rows].any() and np.isnan(w[~act]).all()
        np.testing.assert_allclose(w[act], w_ref[act], rtol=1e-8, atol=1e-8)


def _trilateration():
    """One point P (truth 120, 90) from 6 stations, a 0.5 m blunder in the fourth distance; solved."""
    stations = np.array([[0, 0], [400, 0], [0, 300], [500, 450], [-200, 250], [250, -300]], float)
    p = np.array([120.0, 90.0])
    d = np.hypot(*(p - stations).T) + np.array([0.003, -0.002, 0.001, 0.5, -0.002, 0.001])
    params = Parameters()
    params.add(Unknown("P"), [100.0, 100.0])
    group = Distances(stations, d, 0.003)
    solver = Solver(params, [group], SolverOptions())
    solution = solver.solve()
    return params, group, solver, solution, Statistics(solution)


def test_removal_update_follows_a_nonlinear_problem():
    # trilateration: the chord iteration converges to the full solution within its tolerance
    params, group, solver, solution, stats = _trilateration()
    p = np.array([120.0, 90.0])
    update = RemovalUpdate(solver, solution, stats.leverages, np.ones(group.n_rows, bool))
    assert update.remove(np.array([3]))
    reference, ref_stats = _full_solution(Solver(params, [group], SolverOptions()), update.active)
    sigma = ref_stats.sigmas(Unknown("P"), posterior=False)
    assert np.all(np.abs(update.values[Unknown("P")] - reference.parameters[Unknown("P")].values) < 0.05 * sigma)
    act = update.active[0]
    np.testing.assert_allclose(update.w_tests()[0][act], ref_stats.w_tests()[0][act], atol=0.05)
    assert np.abs(update.values[Unknown("P")] - p).max() < 0.01   # the blunder is gone


def test_linear_rounds_then_the_polish_are_the_chord_iteration_to_the_bit():
    # trilateration, the 0.5 m blunder removed: the linear model's residuals (the w-tests of the next round)
    # stay within the second-order terms of the step (the removal moves P by about 0.2 m; a distance's
    # curvature is 1 / rho, rho >= 150 m: |dr| <= step^2 / (2 rho), in units of the 3 mm sigma), and the
    # polish takes the very chord steps of a removal without linear rounds: the same bits
    params, group, solver, solution, stats = _trilateration()
    tested = np.ones(group.n_rows, bool)
    chord = RemovalUpdate(solver, solution, stats.leverages, tested)
    linear = RemovalUpdate(solver, solution, stats.leverages, tested)
    assert chord.remove(np.array([3])) and chord.polished
    assert linear.remove(np.array([3]), linear=True) and not linear.polished
    assert chord.linear_steps == 0 and linear.steps == 0 and linear.linear_steps >= 1
    step = np.linalg.norm(chord.values[Unknown("P")] - solution.parameters[Unknown("P")].values)
    assert 0.05 < step < 0.5
    act = chord.active[0]
    w_linear, w_chord = linear.w_tests()[0][act], chord.w_tests()[0][act]
    second_order = step**2 / (2 * 150.0) / 0.003 / np.sqrt(1 - stats.leverages[act]).min()
    assert 0 < np.abs(w_linear - w_chord).max() < second_order
    assert linear.polish() and linear.polished
    np.testing.assert_array_equal(linear.values[Unknown("P")], chord.values[Unknown("P")])
    np.testing.assert_array_equal(linear.w_tests()[0], chord.w_tests()[0])


def _station_network(rng, n_points=12, blunders=()):
    """Points each measured by distances from 6 of 10 fixed stations (one group per point, 1-2 km
    apart); ``blunders``: (point, row, size in m)."""
    stations = rng.uniform(-1500, 1500, (10, 2))
    params, groups, truth = Parameters(), [], {}
    for i in range(n_points):
        p = rng.uniform(-500, 500, 2)
        sel = rng.choice(10, 6, replace=False)
        d = np.hypot(*(p - stations[sel]).T) + 0.003 * rng.standard_normal(6)
        for point, row, size in blunders:
            if point == i:
                d[row] += size
        key = Unknown(f"Q{i}")
        truth[key] = p
        params.add(key, p + rng.normal(0, 2.0, 2))
        g = Distances(stations[sel], d, 0.003, key)
        g.name = f"distances Q{i}"
        g.ids = np.array([f"Q{i}-S{j}" for j in sel])
        groups.append(g)
    return params, groups, truth


def test_linear_rounds_snoop_as_the_chord_iteration_on_a_nonlinear_network():
    # 12 points, 7 blunders of 5-30 cm in 5 of them, 4 units a round (two rounds: the 7 and a good
    # observation beside a blunder of the second, four blind a round): the linear rounds reject the same
    # observations in the same rounds; the statistics are those of the last full solution in both
    rng = np.random.default_rng(3)
    blunders = [(0, 1, 0.3), (2, 0, -0.2), (2, 4, 0.15), (5, 2, 0.1), (7, 3, -0.05), (9, 5, 0.25), (9, 0, 0.08)]
    params, groups, truth = _station_network(rng, blunders=blunders)
    results = {m: adjust(params, groups, SolverOptions(), SnoopingOptions(method=m, per_round=4))
               for m in ("update", "linear")}
    upd, lin = results["update"], results["linear"]
    blundered = {str(groups[point].ids[row]) for point, row, _ in blunders}
    assert blundered <= {r.id for r in upd.rejections} and len(upd.rejections) == 8 and upd.snooping_rounds == 2
    assert [(r.id, r.round) for r in lin.rejections] == [(r.id, r.round) for r in upd.rejections]
    np.testing.assert_allclose([r.w for r in lin.rejections], [r.w for r in upd.rejections], rtol=1e-3)
    assert lin.statistics.sigma0 == pytest.approx(upd.statistics.sigma0, rel=1e-9)
    for key in truth:
        np.testing.assert_allclose(lin.parameters[key].values, upd.parameters[key].values, atol=1e-6)
    assert lin.full_solutions == upd.full_solutions


@pytest.mark.parametrize("method", ["update", "linear", "resolve"])
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
    for method in ("update", "linear", "resolve"):
        rng = np.random.default_rng(9)
        truth, group = levelling_network(rng, n_points=30, n_lines=150, blunders=[(i, 0.03) for i in (2, 50, 77, 120)])
        result = adjust(levelling_parameters(truth), [group], SolverOptions(), SnoopingOptions(method=method))
        flagged[method] = result
    upd, ref = flagged["update"], flagged["resolve"]
    assert [r.id for r in upd.rejections] == [r.id for r in ref.rejections] and len(ref.rejections) == 4
    np.testing.assert_allclose([r.w for r in upd.rejections], [r.w for r in ref.rejections], rtol=1e-8)
    assert upd.statistics.sigma0 == pytest.approx(ref.statistics.sigma0, rel=1e-10)
    assert upd.full_solutions == 2 and ref.full_solutions == 5
    lin = flagged["linear"]   # the linear rounds: exact on a linear problem, no linearisation between solutions
    assert [r.id for r in lin.rejections] == [r.id for r in ref.rejections]
    np.testing.assert_allclose([r.w for r in lin.rejections], [r.w for r in ref.rejections], rtol=1e-8)
    assert lin.statistics.sigma0 == pytest.approx(ref.statistics.sigma0, rel=1e-10)
    assert lin.full_solutions == 2
