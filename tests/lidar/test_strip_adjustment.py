"""1D strip adjustment: covariance against a dense computation, control never hurts, recovery."""
from __future__ import annotations

import numpy as np
import pytest

from scangeo.errors import LidarError
from scangeo.lidar.network import BlockLayout, build_block, offset_precision, plot_design
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


@pytest.mark.parametrize("tilts", [False, True])
def test_offset_covariance_equals_dense_computation(tilts):
    # tilts: a cross strip's ties all lie on its axis, so its across tilt is undetermined
    layout = BlockLayout(n_strips=6, n_cross=0 if tilts else 2, length=6000.0, tie_spacing=1500.0)
    # (ties in the middle of the overlaps see only b_i + b_j of the across tilts: a control area
    # off a strip axis breaks the alternating null mode)
    off_axis = [(i * layout.spacing + 200.0, layout.length / 2) for i in range(layout.n_strips)]
    strips, ties, controls = build_block(layout, layout.corner_controls() + layout.ends_controls(2) + off_axis)
    Q = offset_covariance(strips, ties, controls, tilts=tilts)
    Q_dense = _dense_covariance(strips, ties, controls, tilts)
    np.testing.assert_allclose(Q, Q_dense, rtol=1e-8, atol=1e-14)


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
    np.testing.assert_allclose(result.params, truth, atol=1e-9)
    assert result.redundancy == len(ties) + len(controls) - 3 * len(strips)


def test_two_strips_hand_computed():
    # strip 0 has control (sigma 1), tie 0-1 (sigma 1): offsets 0.3 and 0.3-0.1; var = [1, 2]
    strips = [Strip("a", 0, 0, 0), Strip("b", 500, 0, 0)]
    result = adjust_strips(
        strips, [TieArea(0, 1, 250, 0, dh=0.1, sigma=1.0)], [ControlArea(0, 0, 0, dh=0.3, sigma=1.0)]
    )
    np.testing.assert_allclose(result.params[:, 0], [0.3, 0.2])
    np.testing.assert_allclose(result.offset_sigma**2, [1.0, 2.0])


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
