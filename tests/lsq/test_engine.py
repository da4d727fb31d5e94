"""The adjustment engine on small problems with known answers (levelling, trilateration, polynomials)."""
from __future__ import annotations

import numpy as np
import pytest
import scipy.optimize

from scangeo.lsq import Parameters, SnoopingOptions, Solver, SolverOptions, Unknown, adjust
from scangeo.lsq.checks import check_jacobian

from .backends import BACKENDS
from .problems import Distances, HeightDifferences, Polynomial, dense_design, levelling_network

NO_SNOOPING = SnoopingOptions(enabled=False)


def levelling_parameters(truth, fixed="P0"):
    params = Parameters()
    for name, h in truth.items():
        params.add(Unknown(name), [h if name == fixed else 0.0], free=name != fixed)
    return params


@pytest.mark.numerics  # two numerical routes: run under a second BLAS kernel too (.ci/run)
@pytest.mark.parametrize("backend", BACKENDS)
def test_levelling_matches_dense_least_squares(backend):
    rng = np.random.default_rng(1)
    truth, group = levelling_network(rng)
    result = adjust(levelling_parameters(truth), [group], SolverOptions(backend=backend), NO_SNOOPING)
    names = [n for n in truth if n != "P0"]
    A_all = dense_design(group, list(truth))
    A = A_all[:, 1:]
    obs = group.dh / group.sigma + A_all[:, 0] * truth["P0"] * -1.0
    x, *_ = np.linalg.lstsq(A, obs, rcond=None)
    got = np.array([result.parameters[Unknown(n)].values[0] for n in names])
    np.testing.assert_allclose(got, x, atol=1e-9)
    # the estimate is close to the truth (2 mm levelling)
    assert np.max(np.abs(got - np.array([truth[n] for n in names]))) < 0.02
    # statistics against dense formulas
    stats = result.statistics
    v = A @ x - obs
    f = A.shape[0] - A.shape[1]
    assert stats.redundancy == f == stats.accounting.observations - stats.accounting.unknowns
    assert stats.sigma0 == pytest.approx(np.sqrt(v @ v / f), rel=1e-9)
    Qxx = np.linalg.inv(A.T @ A)
    sig = np.array([stats.sigmas(Unknown(n))[0] for n in names])
    np.testing.assert_allclose(sig, stats.sigma0 * np.sqrt(np.diag(Qxx)), rtol=1e-8)
    H = A @ Qxx @ A.T
    r = stats.redundancy_numbers()[0]
    np.testing.assert_allclose(r, 1 - np.diag(H), atol=1e-10)
    assert r.sum() == pytest.approx(f, abs=1e-8)
    w = stats.w_tests()[0]
    np.testing.assert_allclose(w, v / np.sqrt(1 - np.diag(H)), rtol=1e-8)
    assert result.solution.converged and len(result.solution.iterations) <= 2


@pytest.mark.numerics  # two numerical routes: run under a second BLAS kernel too (.ci/run)
def test_covariance_block_matches_dense_inverse():
    rng = np.random.default_rng(2)
    stations = np.array([[0, 0], [100, 0], [0, 100], [100, 100], [50, -40]], float)
    p_true = np.array([37.0, 61.0])
    d = np.hypot(*(p_true - stations).T) + 0.01 * rng.standard_normal(5)
    params = Parameters()
    params.add(Unknown("P"), [10.0, 10.0])
    group = Distances(stations, d, 0.01)
    result = adjust(params, [group], SolverOptions(), NO_SNOOPING)
    p = result.parameters[Unknown("P")].values
    ref = scipy.optimize.least_squares(lambda q: group.residuals({Unknown("P"): q}), [10.0, 10.0],
                                       xtol=1e-14, ftol=1e-14, gtol=1e-14)
    np.testing.assert_allclose(p, ref.x, atol=1e-7)
    assert np.linalg.norm(p - p_true) < 0.05
    J = ref.jac
    cov = np.linalg.inv(J.T @ J) * result.statistics.sigma0 ** 2
    np.testing.assert_allclose(result.statistics.covariance(Unknown("P")), cov, rtol=1e-5)


def test_trilateration_converges_from_a_far_start():
    stations = np.array([[0, 0], [1000, 0], [0, 1000], [1000, 1000]], float)
    p_true = np.array([420.0, 170.0])
    d = np.hypot(*(p_true - stations).T)
    params = Parameters()
    params.add(Unknown("P"), [900.0, 950.0])
    result = adjust(params, [Distances(stations, d, 0.01)], SolverOptions(), NO_SNOOPING)
    np.testing.assert_allclose(result.parameters[Unknown("P")].values, p_true, atol=1e-6)
    assert result.solution.converged
    assert result.statistics.redundancy == 2


def test_jacobian_checks_pass_and_catch_a_wrong_jacobian():
    stations = np.array([[0, 0], [100, 0], [0, 100]], float)
    group = Distances(stations, [50.0, 60.0, 70.0], 0.01)
    check = check_jacobian(group, {Unknown("P"): np.array([37.0, 61.0])}, 1e-4)
    assert check.max_relative_error < 1e-7, check.worst()
    truth, lev = levelling_network(np.random.default_rng(3), n_points=5, n_lines=8)
    check = check_jacobian(lev, {Unknown(n): np.array([h]) for n, h in truth.items()})
    assert check.max_relative_error < 1e-7, check.worst()

    class Wrong(Distances):
        def linearise(self, values):
            lin = super().linearise(values)
            lin.parts[0].values = lin.parts[0].values * np.array([1.0, 1.01])
            return lin

    bad = check_jacobian(Wrong(stations, [50.0, 60.0, 70.0], 0.01), {Unknown("P"): np.array([37.0, 61.0])}, 1e-4)
    assert bad.max_relative_error > 1e-3


def test_fixed_components_keep_their_values():
    stations = np.array([[0, 0], [100, 0], [0, 100]], float)
    p_true = np.array([30.0, 40.0])
    d = np.hypot(*(p_true - stations).T)
    params = Parameters()
    params.add(Unknown("P"), [10.0, 40.0], free=[True, False])
    result = adjust(params, [Distances(stations, d, 0.01)], SolverOptions(), NO_SNOOPING)
    assert result.solution.layout.n == 1
    assert result.parameters[Unknown("P")].values[1] == 40.0
    assert result.parameters[Unknown("P")].values[0] == pytest.approx(30.0, abs=1e-8)
    assert np.isnan(result.statistics.sigmas(Unknown("P"))[1])


def test_prior_is_a_weighted_pseudo_observation():
    # two height differences P0->P1 plus a prior on P1: the weighted mean, by hand
    group = HeightDifferences(["P0", "P0"], ["P1", "P1"], [1.0, 1.2], [0.1, 0.1])
    params = Parameters()
    params.add(Unknown("P0"), [0.0], free=False)
    params.add(Unknown("P1"), [0.5], prior_sigma=0.1, prior_values=[0.5])
    result = adjust(params, [group], SolverOptions(), NO_SNOOPING)
    assert result.parameters[Unknown("P1")].values[0] == pytest.approx((1.0 + 1.2 + 0.5) / 3, abs=1e-12)
    acc = result.statistics.accounting
    assert (acc.observations, acc.pseudo_observations, acc.unknowns, acc.redundancy) == (2, 1, 1, 2)
    assert result.statistics.sigmas(Unknown("P1"), posterior=False)[0] == pytest.approx(0.1 / np.sqrt(3))


def test_significance_of_polynomial_coefficients():
    x = np.linspace(-1, 1, 40)
    false_alarms = 0
    for seed in range(200):
        rng = np.random.default_rng(seed)
        y = 2.0 + 0.5 * x + 0.0 * x ** 2 + 0.01 * rng.standard_normal(x.size)
        params = Parameters()
        params.add(Unknown("c"), np.zeros(3), names=["c0", "c1", "c2"])
        result = adjust(params, [Polynomial(x, y, 0.01, 2)], SolverOptions(), NO_SNOOPING)
        tests = {c.component: c for c in result.statistics.significance(Unknown("c"), alpha=0.05)}
        assert tests["c0"].significant and tests["c1"].significant
        assert abs(tests["c1"].value - 0.5) < 5 * tests["c1"].sigma
        false_alarms += tests["c2"].significant
        if seed == 0:  # t against the dense formula
            V = x[:, None] ** np.arange(3)
            c, *_ = np.linalg.lstsq(V, y, rcond=None)
            s0 = np.linalg.norm(V @ c - y) / np.sqrt(x.size - 3)
            t = abs(c[2]) / (s0 * np.sqrt(np.linalg.inv(V.T @ V)[2, 2]))
            assert tests["c2"].t == pytest.approx(t, rel=1e-8)
    # a true zero is declared significant in about alpha = 5 % of the cases
    assert 2 <= false_alarms <= 20


def test_progress_callback_reports_each_iteration():
    stations = np.array([[0, 0], [1000, 0], [0, 1000]], float)
    d = np.hypot(*(np.array([420.0, 170.0]) - stations).T)
    params = Parameters()
    params.add(Unknown("P"), [900.0, 950.0])
    calls = []
    solution = Solver(params, [Distances(stations, d, 0.01)], SolverOptions(),
                      lambda done, total, msg="": calls.append((done, total, msg))).solve()
    iteration_calls = [c for c in calls if c[2].startswith("iteration")]
    assert len(iteration_calls) == len(solution.iterations) >= 3
    assert calls[-1][0] == calls[-1][1]


def test_convergence_does_not_depend_on_the_scale_of_the_a_priori_sigmas():
    # A large-residual, strongly non-linear problem (distances of a few metres with 3 m noise: Gauss-Newton
    # converges linearly). Sigmas 10 times too small (sigma0 about 16, as before blunders are removed) must
    # give the same path: the chi^2 convergence test is in units of the variance factor above 1 (with the bare
    # tolerance this run took 10 iterations instead of 8 and ended 5 mm elsewhere)
    rng = np.random.default_rng(4)
    stations = rng.uniform(-10.0, 10.0, (30, 2))
    d = np.abs(np.hypot(*(np.array([1.0, 2.0]) - stations).T) + 3.0 * rng.standard_normal(30))
    runs = {}
    for sigma in (2.0, 0.2):
        params = Parameters()
        params.add(Unknown("P"), [6.0, -5.0])
        runs[sigma] = adjust(params, [Distances(stations, d, sigma)], SolverOptions(), NO_SNOOPING)
    right, small = runs[2.0], runs[0.2]
    assert right.statistics.sigma0 > 1.0 and right.solution.converged and small.solution.converged
    assert small.statistics.sigma0 == pytest.approx(10.0 * right.statistics.sigma0, rel=1e-9)
    assert len(small.solution.iterations) == len(right.solution.iterations) >= 6
    np.testing.assert_allclose(small.parameters[Unknown("P")].values, right.parameters[Unknown("P")].values,
                               rtol=0.0, atol=1e-9)
