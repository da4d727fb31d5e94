"""1D strip adjustment in the engine: covariance against a dense computation, control never hurts,
recovery, reliability against the hand-derived redundancy numbers, agreement with the former dense solver."""
from __future__ import annotations

import numpy as np
import pytest

from scangeo.errors import LidarError
from scangeo.lidar.network import BlockLayout, area_reliability, build_block, offset_precision, plot_design
from scangeo.lidar.strip_adjustment import (
    ControlArea,
    Strip,
    TieArea,
    adjust_strips,
    offset_covariance,
)


def _dense_covariance(strips, ties, controls, tilts):
    """Independent dense (A^T P A)^-1, rows written out by hand from the model's definition."""
    k = 3 if tilts else 1
    rows, w = [], []

    def terms(s, x, y):
        st = strips[s]
        dx, dy = x - st.x0, y - st.y0
        u = dx * np.sin(st.heading) + dy * np.cos(st.heading)
        v = dx * np.cos(st.heading) - dy * np.sin(st.heading)
        return [1.0, u, v][:k]

    for t in ties:
        row = np.zeros(k * len(strips))
        row[k * t.i: k * t.i + k] += terms(t.i, t.x, t.y)
        row[k * t.j: k * t.j + k] -= terms(t.j, t.x, t.y)
        rows.append(row)
        w.append(1 / t.sigma**2)
    for c in controls:
        row = np.zeros(k * len(strips))
        row[k * c.s: k * c.s + k] = terms(c.s, c.x, c.y)
        rows.append(row)
        w.append(1 / c.sigma**2)
    A = np.array(rows)
    return np.linalg.inv(A.T @ np.diag(w) @ A)


def _assert_covariances_close(Q, Q_dense, rel=1e-9):
    """Entry by entry within ``rel`` of ``sqrt(Q_ii Q_jj)`` (a correlation of 1e-9): rounding scales with
    the entry's variances, not with the entry (an exactly uncorrelated pair is ~1e-25 either way)."""
    d = np.sqrt(np.einsum("nii->ni", Q_dense))
    bound = rel * d[:, :, None] * d[:, None, :]
    assert np.all(np.abs(Q - Q_dense) <= bound), np.abs(Q - Q_dense).max()


def _blocks(Q, k):
    """The (n, k, k) diagonal blocks of a dense covariance matrix."""
    n = Q.shape[0] // k
    return np.array([Q[k * s: k * s + k, k * s: k * s + k] for s in range(n)])


@pytest.mark.numerics  # two numerical routes: run under a second BLAS kernel too (.ci/run)
@pytest.mark.parametrize("tilts", [False, True])
def test_offset_covariance_equals_dense_computation(tilts):
    # tilts: a cross strip's ties all lie on its axis, so its across tilt is undetermined
    layout = BlockLayout(n_strips=6, n_cross=0 if tilts else 2, length=6000.0, tie_spacing=1500.0)
    # (ties in the middle of the overlaps see only b_i + b_j of the across tilts: a control area
    # off a strip axis breaks the alternating null mode)
    off_axis = [(i * layout.spacing + 200.0, layout.length / 2) for i in range(layout.n_strips)]
    strips, ties, controls = build_block(layout, layout.corner_controls() + layout.ends_controls(2) + off_axis)
    Q = offset_covariance(strips, ties, controls, tilts=tilts)
    Q_dense = _blocks(_dense_covariance(strips, ties, controls, tilts), 3 if tilts else 1)
    # the selected inverse of a Cholesky factor: relative error ~ cond(N) * eps; the Jacobi-scaled normal
    # matrix of this block has a condition number below 1e5, so 1e-9 leaves a margin of 1e2
    _assert_covariances_close(Q, Q_dense)


def test_adding_control_areas_never_worsens_precision():
    layout = BlockLayout(n_strips=9, n_cross=2, length=8000.0)
    rng = np.random.default_rng(7)
    controls = list(layout.corner_controls())
    sigma = offset_precision(layout, controls)
    for _ in range(6):
        controls.append((float(rng.uniform(0, layout.width)), float(rng.uniform(0, layout.length))))
        better = offset_precision(layout, controls)
        assert np.all(better <= sigma + 1e-12)
        sigma = better
    # and at least one strip got strictly better overall
    assert np.any(sigma < offset_precision(layout, layout.corner_controls()) - 1e-4)


def test_cross_strips_improve_the_21_strip_block():
    with_cross = BlockLayout(n_strips=21, n_cross=4)
    without = BlockLayout(n_strips=21, n_cross=0)
    s_with = offset_precision(with_cross, with_cross.corner_controls())[:21]
    s_without = offset_precision(without, without.corner_controls())
    assert np.all(s_with < s_without)
    assert s_without.max() == pytest.approx(0.0212, abs=5e-4)   # 2.1 cm in the middle of the block
    assert s_with.max() == pytest.approx(0.0177, abs=5e-4)


def test_adjustment_recovers_injected_offsets_and_tilts():
    layout = BlockLayout(n_strips=5, n_cross=0, length=5000.0, tie_spacing=500.0)
    off_axis = [(i * layout.spacing + 200.0, layout.length / 2) for i in range(layout.n_strips)]
    strips, ties, controls = build_block(layout, layout.ends_controls(1) + off_axis)
    rng = np.random.default_rng(3)
    truth = np.c_[rng.normal(0, 0.2, len(strips)), rng.normal(0, 2e-5, len(strips)), rng.normal(0, 2e-5, len(strips))]

    def e(s, x, y):
        u, v = strips[s].along_across(x, y)
        return truth[s, 0] + truth[s, 1] * u + truth[s, 2] * v

    ties = [TieArea(t.i, t.j, t.x, t.y, dh=e(t.i, t.x, t.y) - e(t.j, t.x, t.y), sigma=t.sigma) for t in ties]
    controls = [ControlArea(c.s, c.x, c.y, dh=e(c.s, c.x, c.y), sigma=c.sigma) for c in controls]
    result = adjust_strips(strips, ties, controls, tilts=True)
    # exact observations: the estimate equals the truth up to the solver's step tolerance (1e-3 of a
    # standard deviation, below 1 mm and 1e-8 m/m here)
    np.testing.assert_allclose(result.params, truth, atol=1e-9)
    assert result.redundancy == len(ties) + len(controls) - 3 * len(strips)
    assert np.abs(result.residuals).max() < 1e-9


def test_two_strips_hand_computed():
    # strip 0 has control (sigma 1), tie 0-1 (sigma 1): offsets 0.3 and 0.3-0.1; var = [1, 2]
    strips = [Strip("a", 0, 0, 0), Strip("b", 500, 0, 0)]
    result = adjust_strips(
        strips, [TieArea(0, 1, 250, 0, dh=0.1, sigma=1.0)], [ControlArea(0, 0, 0, dh=0.3, sigma=1.0)]
    )
    np.testing.assert_allclose(result.params[:, 0], [0.3, 0.2], atol=1e-12)
    np.testing.assert_allclose(result.offset_sigma**2, [1.0, 2.0], rtol=1e-12)
    assert result.redundancy == 0 and np.isnan(result.sigma0)


def test_tilt_of_cross_strip_is_reported_singular():
    layout = BlockLayout(n_strips=4, n_cross=1, length=3000.0)
    strips, ties, controls = build_block(layout, layout.ends_controls(1))
    with pytest.raises(LidarError, match="singular"):
        offset_covariance(strips, ties, controls, tilts=True)


def test_block_without_control_is_singular():
    layout = BlockLayout(n_strips=4, n_cross=0, length=3000.0)
    strips, ties, controls = build_block(layout, [])
    with pytest.raises(LidarError, match="singular"):
        offset_covariance(strips, ties, controls)


def test_design_plot_written(tmp_path):
    layout = BlockLayout(n_strips=5, n_cross=1, length=4000.0)
    out = tmp_path / "net.png"
    scenarios = plot_design(layout, str(out))
    assert out.stat().st_size > 10_000
    assert len(scenarios) == 3


@pytest.mark.numerics  # two numerical routes: run under a second BLAS kernel too (.ci/run)
def test_noisy_adjustment_agrees_with_weighted_least_squares():
    """Offsets, tilts, residuals and sigma0 of noisy observations against the normal equations solved
    densely (numpy), within the rounding of a Cholesky solve of this conditioning (1e-9 relative)."""
    layout = BlockLayout(n_strips=5, n_cross=1, length=5000.0, tie_spacing=500.0)
    off_axis = [(i * layout.spacing + 200.0, layout.length / 2) for i in range(layout.n_strips)]
    strips, ties, controls = build_block(layout, layout.ends_controls(1) + off_axis + [(layout.width / 2 + 300.0,
                                                                                        2000.0)])
    rng = np.random.default_rng(11)
    ties = [TieArea(t.i, t.j, t.x, t.y, dh=rng.normal(0, t.sigma), sigma=t.sigma) for t in ties]
    controls = [ControlArea(c.s, c.x, c.y, dh=0.1 + rng.normal(0, c.sigma), sigma=c.sigma) for c in controls]
    result = adjust_strips(strips, ties, controls, tilts=True)
    Q = _dense_covariance(strips, ties, controls, True)
    k = 3
    A = np.zeros((len(ties) + len(controls), k * len(strips)))
    for r, t in enumerate(ties):
        for s, sign in ((t.i, 1.0), (t.j, -1.0)):
            u, v = strips[s].along_across(t.x, t.y)
            A[r, k * s: k * s + k] += sign * np.array([1.0, u, v])
    for r, c in enumerate(controls, start=len(ties)):
        u, v = strips[c.s].along_across(c.x, c.y)
        A[r, k * c.s: k * c.s + k] = [1.0, u, v]
    obs = np.array([t.dh for t in ties] + [c.dh for c in controls])
    sig = np.array([t.sigma for t in ties] + [c.sigma for c in controls])
    x = Q @ (A.T @ (obs / sig**2))
    v = A @ x - obs
    sx = np.sqrt(np.diag(Q))
    assert np.all(np.abs(result.params.ravel() - x) < 1e-6 * sx)   # the solver stops within 1e-3 sigma
    np.testing.assert_allclose(result.residuals, v, atol=1e-6 * sig.min())
    f = len(obs) - A.shape[1]
    assert result.sigma0 == pytest.approx(np.sqrt(np.sum((v / sig) ** 2) / f), rel=1e-9)
    _assert_covariances_close(result.covariance, _blocks(Q, k))


def test_area_reliability_of_a_two_strip_chain():
    """Strip a with one control, tie a-b twice (sigma 1): each tie has redundancy 1/2 and MDB
    4.13 / sqrt(1/2); the control is uncontrolled (r = 0, MDB inf)."""
    from scangeo.lidar.strip_adjustment import design_reliability

    strips = [Strip("a", 0, 0, 0), Strip("b", 500, 0, 0)]
    rel = design_reliability(strips, [TieArea(0, 1, 250, 0, sigma=1.0), TieArea(0, 1, 250, 100, sigma=1.0)],
                             [ControlArea(0, 0, 0, sigma=1.0)])
    red = dict(zip([g.name for g in rel.groups], rel.redundancy))
    mdb = dict(zip([g.name for g in rel.groups], rel.mdb))
    np.testing.assert_allclose(red["tie areas"], [0.5, 0.5], atol=1e-12)
    np.testing.assert_allclose(mdb["tie areas"], (3.290527 + 0.841621) / np.sqrt(0.5), rtol=1e-6)
    assert red["control areas"][0] == pytest.approx(0.0, abs=1e-12) and np.isinf(mdb["control areas"][0])


def test_area_reliability_of_the_regular_block():
    """Redundancy numbers sum to the redundancy; areas along a cross strip are better controlled
    than the side overlaps' without one."""
    layout = BlockLayout(n_strips=9, n_cross=2, length=8000.0)
    rel = area_reliability(layout, layout.ends_controls(4))
    strips, ties, ctl = build_block(layout, layout.ends_controls(4))
    total = sum(float(np.sum(g["redundancy"])) for g in rel.values())
    assert total == pytest.approx(len(ties) + len(ctl) - len(strips), abs=1e-8)
    assert np.all(np.isfinite(rel["tie areas"]["mdb_m"]))
    assert np.all(rel["tie areas"]["mdb_m"] >= 4.13 * layout.sigma_tie - 1e-12)   # MDB >= delta0 sigma


@pytest.mark.numerics  # two numerical routes: run under a second BLAS kernel too (.ci/run)
def test_network_design_unchanged_from_the_dense_solver():
    """The 21-strip design (docs/lidar.md section 3) to 1e-9 relative of the dense inverse's figures,
    recomputed here by the independent dense computation."""
    layout = BlockLayout()
    for controls in (layout.corner_controls(), layout.ends_controls(4)):
        strips, ties, ctl = build_block(layout, controls)
        dense = np.sqrt(np.diag(_dense_covariance(strips, ties, ctl, False)))
        np.testing.assert_allclose(offset_precision(layout, controls), dense, rtol=1e-9)
