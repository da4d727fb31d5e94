"""Analytic derivatives against finite differences: look directions and the compiled pose."""
import numpy as np

from scangeo.sensors import StripGeometry, Whiskbroom
from scangeo.timing import LineTiming
from scangeo.trajectory import OrientationSpline


def test_whiskbroom_look_derivatives_wrt_calibration():
    base = Whiskbroom(index_error=0.001, scale_error=0.002)
    pixels = np.array([0.0, 100.5, 357.5, 600.0, 715.0])
    analytic = base.look_S_derivatives(pixels)
    for name, eps in (("index_error", 1e-7), ("scale_error", 1e-7)):
        plus = base.with_calibration(**{name: getattr(base, name) + eps}).look_S(pixels)
        minus = base.with_calibration(**{name: getattr(base, name) - eps}).look_S(pixels)
        assert np.allclose(analytic[name], (plus - minus) / (2 * eps), atol=1e-8)


def test_pixel_of_inverts_look_with_calibration_errors():
    for s in (1, -1):
        sensor = Whiskbroom(scan_direction=s, index_error=0.003, scale_error=-0.01)
        j = np.linspace(-3, 718, 101)
        assert np.allclose(sensor.pixel_of(sensor.look_S(j)), j, atol=1e-9)


def test_compiled_pose_time_derivatives_match_finite_differences():
    rng = np.random.default_rng(3)
    coef = np.column_stack([rng.normal(0, 50, 40), rng.normal(0, 50, 40), 2000 + rng.normal(0, 5, 40),
                            rng.normal(0, 0.05, 40), rng.normal(0, 0.05, 40), rng.normal(0, 0.5, 40)])
    from scangeo.sensors import Mounting

    mount = Mounting(lever_arm_B=np.array([1.5, -0.3, 0.8]), boresight=np.array([0.01, -0.02, 0.03]))
    strip = StripGeometry(Whiskbroom(), OrientationSpline(0.0, 0.2, coef), LineTiming(0.0, 25.0), 100, mount)
    t = rng.uniform(0.5, 6.5, 50)
    p, R, dp, dR = strip.pose(t, derivatives=True)
    h = 1e-6
    p1, R1 = strip.pose(t + h)
    p0, R0 = strip.pose(t - h)
    assert np.allclose(dp, (p1 - p0) / (2 * h), atol=1e-5)
    assert np.allclose(dR, (R1 - R0) / (2 * h), atol=1e-6)
    # the compiled pose equals the numpy composition R_PB R_BS, p + R_PB l_B
    from scangeo.rotation import R_ENU_NED, rph_to_matrix

    v = strip.spline.evaluate(t)
    R_PB = R_ENU_NED @ rph_to_matrix(v[:, 3], v[:, 4], v[:, 5])
    assert np.allclose(R, R_PB @ mount.R_BS, atol=1e-13)
    assert np.allclose(p, v[:, :3] + R_PB @ mount.lever_arm_B, atol=1e-9)
