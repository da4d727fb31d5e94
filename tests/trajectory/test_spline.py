"""The orientation spline: exactness, derivatives, basis matrix, heading unwrap."""
import numpy as np
import pytest

from scangeo.frames import ProjectFrame
from scangeo.trajectory import GpsImuStream, OrientationSpline
from scangeo.trajectory.spline import bspline_basis


def test_cubic_polynomials_are_reproduced_exactly():
    t = np.linspace(10.0, 30.0, 1001)
    poly = np.column_stack([t**3 * 0.01 - t, 2 * t**2, np.full_like(t, 5.0), 0.001 * t, np.sin(0 * t), -0.002 * t**3])
    sp = OrientationSpline.fit(t, poly, 0.5)
    tt = np.linspace(10.0, 30.0, 777)
    expect = np.column_stack([tt**3 * 0.01 - tt, 2 * tt**2, np.full_like(tt, 5.0), 0.001 * tt, 0 * tt, -0.002 * tt**3])
    assert np.abs(sp.evaluate(tt) - expect).max() < 1e-7
    d_expect = np.column_stack([0.03 * tt**2 - 1, 4 * tt, 0 * tt, 0.001 + 0 * tt, 0 * tt, -0.006 * tt**2])
    assert np.abs(sp.evaluate(tt, 1) - d_expect).max() < 1e-7


def test_partition_of_unity_and_c2_continuity():
    u = np.linspace(0, 1, 11)
    assert np.allclose(bspline_basis(u).sum(1), 1.0)
    assert np.allclose(bspline_basis(u, 1).sum(1), 0.0)
    rng = np.random.default_rng(0)
    sp = OrientationSpline(0.0, 0.2, rng.normal(size=(20, 6)))
    knots = sp.t0 + sp.spacing * np.arange(1, 16)
    for d in (0, 1, 2):
        left = sp.evaluate(knots - 1e-9, d) if d < 2 else None
        if d == 2:
            j, u = sp.segment(knots - 1e-12)
            # second derivative from both sides of each knot
            idx = j[:, None] + np.arange(4)
            lft = np.einsum("nk,nkc->nc", bspline_basis(u, 2), sp.coef[idx])
            j2, u2 = sp.segment(knots + 1e-12)
            rgt = np.einsum("nk,nkc->nc", bspline_basis(u2, 2), sp.coef[j2[:, None] + np.arange(4)])
            assert np.allclose(lft, rgt, atol=1e-6)
        else:
            assert np.allclose(left, sp.evaluate(knots + 1e-9, d), atol=1e-6)


def test_basis_matrix_maps_coefficients_to_values_and_matches_finite_differences():
    rng = np.random.default_rng(1)
    sp = OrientationSpline(100.0, 0.25, rng.normal(size=(30, 6)))
    t = rng.uniform(sp.t0, sp.t_end, 200)
    for d in (0, 1):
        A = sp.basis_matrix(t, d)
        assert A.shape == (200, 30)
        assert np.allclose(A @ sp.coef, sp.evaluate(t, d))
    # derivative w.r.t. one coefficient, by finite differences
    k, c, eps = 12, 4, 1e-6
    coef = sp.coef.copy()
    coef[k, c] += eps
    num = (sp.with_coef(coef).evaluate(t)[:, c] - sp.evaluate(t)[:, c]) / eps
    assert np.allclose(sp.basis_matrix(t)[:, k].toarray().ravel(), num, atol=1e-6)
    # time derivative against finite differences of the values
    h = 1e-5
    num_t = (sp.evaluate(t + h) - sp.evaluate(t - h)) / (2 * h)
    assert np.allclose(sp.evaluate(t, 1), num_t, atol=1e-5)


def test_knot_values():
    rng = np.random.default_rng(2)
    sp = OrientationSpline(0.0, 0.2, rng.normal(size=(12, 6)))
    K = sp.knot_value_matrix()
    times = sp.t0 + np.arange(sp.n_coef - 2) * sp.spacing
    assert np.allclose(K @ sp.coef, sp.evaluate(times))
    # the value at a knot is (c[k-1] + 4 c[k] + c[k+1]) / 6
    assert np.allclose((K @ sp.coef)[3], (sp.coef[3] + 4 * sp.coef[4] + sp.coef[5]) / 6)
    assert np.allclose(sp.knot_times[4], times[3])


def test_heading_is_unwrapped_across_180_degrees():
    frame = ProjectFrame.from_origin(48.0, 16.0, 0.0)
    t = np.linspace(0, 10, 501)
    heading = np.radians(170.0 + 2.0 * t)  # crosses 180 at t = 5
    wrapped = np.angle(np.exp(1j * heading))
    stream = GpsImuStream(t, np.full_like(t, frame.lat0), np.full_like(t, frame.lon0), np.full_like(t, 1000.0),
                          0 * t, 0 * t, wrapped)
    traj = stream.to_project(frame)
    assert np.all(np.abs(np.diff(traj.angles_P[:, 2])) < 0.01)
    sp = OrientationSpline.from_trajectory(traj, 0.2)
    h = sp.evaluate(np.linspace(0.1, 9.9, 300))[:, 5]
    assert np.all(np.diff(h) > 0)
    assert np.degrees(h[-1] - h[0]) == pytest.approx(2.0 * 9.8, abs=0.05)
