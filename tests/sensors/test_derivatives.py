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


def _pushbroom_sensors(**calibration):
    """A look-angle table with a smile and a distorted pinhole, both with ``calibration``."""
    from scangeo.sensors import Pushbroom

    n = 900
    u = (np.arange(n) - (n - 1) / 2) / ((n - 1) / 2)
    table = Pushbroom(n, along=np.radians(0.1 + 0.05 * u**2), across=0.33 * u + 0.01 * u**3, **calibration)
    pinhole = Pushbroom(1000, focal_length=0.05, pitch=3e-5, principal_point=505.3, k1=20.0, k2=1e4,
                        line_offset=0.001, **calibration)
    return table, pinhole


CALIBRATION = {"across_offset": 0.002, "across_scale": -0.004, "along_offset": 0.0015}


def test_pushbroom_look_derivatives_wrt_calibration():
    for sensor in _pushbroom_sensors(**CALIBRATION):
        pixels = np.array([-2.0, 0.0, 100.3, 449.5, 700.25, sensor.pixels - 1.0])
        analytic = sensor.look_S_derivatives(pixels)
        assert set(analytic) == set(sensor.calibration_names)
        for name in sensor.calibration_names:
            eps = 1e-7
            plus = sensor.with_calibration(**{name: getattr(sensor, name) + eps}).look_S(pixels)
            minus = sensor.with_calibration(**{name: getattr(sensor, name) - eps}).look_S(pixels)
            np.testing.assert_allclose(analytic[name], (plus - minus) / (2 * eps), atol=1e-8)


def test_pushbroom_calibration_formula_and_inverse():
    nominal = _pushbroom_sensors()
    for sensor, base in zip(_pushbroom_sensors(**CALIBRATION), nominal):
        j = np.linspace(-3.0, sensor.pixels + 2.0, 157)
        # the documented formula, in the tangents, about the centre pixel
        look, look0 = sensor.look_S(j), base.look_S(j)
        tx, tx0 = look[:, 1] / look[:, 2], look0[:, 1] / look0[:, 2]
        tc = base.look_S(np.array([(base.pixels - 1) / 2]))[0]
        tc = tc[1] / tc[2]
        np.testing.assert_allclose(tx, tx0 + 0.002 - 0.004 * (tx0 - tc), atol=1e-13)
        np.testing.assert_allclose(look[:, 0] / look[:, 2], look0[:, 0] / look0[:, 2] + 0.0015, atol=1e-13)
        np.testing.assert_allclose(np.tan(sensor.along_angle(j)), look[:, 0] / look[:, 2], atol=1e-13)
        # pixel_of inverts look_S, and 0.002 rad across is 0.002 / IFOV pixels at the centre
        np.testing.assert_allclose(sensor.pixel_of(look), j, atol=1e-7)
        centre = np.array([(sensor.pixels - 1) / 2])
        shift = sensor.pixel_of(base.look_S(centre)) - centre
        ifov = float(np.diff(tx0[[77, 79]])[0]) / float(np.diff(j[[77, 79]])[0])
        np.testing.assert_allclose(shift, -0.002 / ifov, rtol=0.01)


def test_compiled_kernels_apply_the_pushbroom_calibration():
    """rays and ground_to_image (numba) of a calibrated sensor agree with its numpy model."""
    from .helpers import level_strip

    for sensor in _pushbroom_sensors(**CALIBRATION):
        strip = level_strip(sensor, n_lines=400, z=2300.0, roll=0.01, pitch=-0.005)
        lines = np.linspace(20.0, 380.0, 25)
        pixels = np.linspace(5.0, sensor.pixels - 6.0, 25)
        o, d = strip.rays(lines, pixels)
        p, R = strip.pose(strip.time_of(lines, pixels))
        np.testing.assert_allclose(d, np.einsum("nij,nj->ni", R, sensor.look_S(pixels)), atol=1e-12)
        ground = o + d * (2000.0 / -d[:, 2:3])
        line, pixel, status = strip.ground_to_image(ground, tol_line=1e-8)
        assert np.all(status == 0)
        np.testing.assert_allclose(line, lines, atol=1e-6)
        np.testing.assert_allclose(pixel, pixels, atol=1e-6)
