"""Observation groups of the photogrammetric model: finite-difference Jacobians and known answers."""
from __future__ import annotations

import numpy as np
import pytest

from scangeo.adjustment.gpsimu import GpsImuSamples
from scangeo.adjustment.image import ImageObservations
from scangeo.adjustment.keys import (
    AcrossOffset,
    AcrossScale,
    AlongOffset,
    Boresight,
    Ground,
    Knots,
    LeverArm,
    ScanIndex,
    ScanScale,
    TimeOffset,
)
from scangeo.lsq.checks import check_jacobian
from scangeo.orientation.models import Correction, GpsImuModel, ModelSet
from scangeo.sensors.models import Pushbroom, Whiskbroom
from scangeo.sensors.strip import Mounting, StripGeometry
from scangeo.timing import LineTiming
from scangeo.trajectory.spline import OrientationSpline


def wavy_strip(seed=0, lever=(0.5, -0.2, 1.0), bore=(0.002, -0.001, 0.003), toff=0.004):
    """A 20 s strip flying north at 70 m/s, 2000 m up, with attitude wiggles; a whiskbroom sensor."""
    rng = np.random.default_rng(seed)
    t = np.arange(-2.0, 22.0, 0.05)
    x = 3.0 * np.sin(0.3 * t)
    y = 70.0 * t
    z = 2000.0 + 5 * np.sin(0.2 * t)
    roll = 0.02 * np.sin(0.7 * t + 1)
    pitch = 0.01 * np.sin(0.5 * t)
    heading = 0.03 * np.sin(0.2 * t)   # project-NED: heading 0 = north
    spline = OrientationSpline.fit(t, np.column_stack([x, y, z, roll, pitch, heading]), 0.2)
    sensor = Whiskbroom(pixels=716, fov=np.radians(42.9), line_rate=25.0)
    timing = LineTiming(0.0, 25.0)
    mount = Mounting(np.array(lever), np.array(bore), toff)
    geom = StripGeometry(sensor, spline, timing, 500, mount, "A")
    pts = np.column_stack([rng.uniform(-700, 700, 30), rng.uniform(150, 1300, 30), rng.uniform(-20, 60, 30)])
    line, pixel, status = geom.ground_to_image(pts, tol_line=1e-9)
    ok = status == 0
    return spline, sensor, timing, mount, pts[ok], line[ok], pixel[ok]


def values_of(spline, mount, pts, index=0.0, scale=0.0, pushbroom=(0.0, 0.0, 0.0)):
    """Values of every unknown of the strip; ``pushbroom``: across_offset, across_scale, along_offset."""
    vals = {Knots("A"): spline.coef.ravel().copy(), Boresight(): np.array(mount.boresight, float),
            LeverArm(): np.array(mount.lever_arm_B, float), TimeOffset(): np.array([mount.time_offset]),
            ScanIndex(): np.array([index]), ScanScale(): np.array([scale]),
            AcrossOffset(): np.array([pushbroom[0]]), AcrossScale(): np.array([pushbroom[1]]),
            AlongOffset(): np.array([pushbroom[2]])}
    for i, p in enumerate(pts):
        vals[Ground(f"G{i}")] = p.copy()
    return vals


def test_image_model_reproduces_ground_to_image():
    spline, sensor, timing, mount, pts, line, pixel = wavy_strip()
    assert len(pts) > 15
    group = ImageObservations("A", sensor, spline, timing, [f"G{i}" for i in range(len(pts))], line, pixel, 0.3)
    pl, pp = group.predict(values_of(spline, mount, pts))
    np.testing.assert_allclose(pl, line, atol=1e-6)
    np.testing.assert_allclose(pp, pixel, atol=1e-6)


def test_image_jacobian_matches_finite_differences():
    spline, sensor, timing, mount, pts, line, pixel = wavy_strip(1)
    group = ImageObservations("A", sensor, spline, timing, [f"G{i}" for i in range(len(pts))],
                              line + 0.7, pixel - 1.3, 0.3)
    vals = values_of(spline, mount, pts, index=0.001, scale=0.002)
    steps = {Knots("A"): np.tile([1e-3, 1e-3, 1e-3, 1e-5, 1e-5, 1e-5], spline.n_coef),
             Boresight(): 1e-5, LeverArm(): 1e-3, TimeOffset(): 1e-5, ScanIndex(): 1e-5, ScanScale(): 1e-5}
    for i in range(len(pts)):
        steps[Ground(f"G{i}")] = 1e-3
    check = check_jacobian(group, vals, steps)
    assert check.max_relative_error < 1e-4, check.worst()
    # every kind of unknown has a non-trivial derivative
    for key in (Knots("A"), Ground("G0"), Boresight(), LeverArm(), TimeOffset(), ScanIndex(), ScanScale()):
        cols = [j for j, (k, _) in enumerate(check.labels) if k == key]
        assert np.abs(check.analytic[:, cols]).max() > 0, key


def test_gpsimu_jacobian_and_residuals():
    spline, *_ = wavy_strip()
    times = spline.knot_times[1:-1]
    gps = spline.evaluate(times)
    models = ModelSet([
        GpsImuModel("A1", ("A",), 0.0, 10.0, 2, 1, windows={"A": (-10.0, 10.0)}),
        GpsImuModel("A2", ("A",), 10.0, 20.0, 1, 0, follows="A1", windows={"A": (10.0, 30.0)}),
    ])
    group = GpsImuSamples("A", spline, times, gps, [0.05, 0.05, 0.1, 1e-4, 1e-4, 2e-4], models)
    rng = np.random.default_rng(3)
    vals = {Knots("A"): spline.coef.ravel(), Correction("A1"): rng.normal(size=models.models["A1"].size),
            Correction("A2"): rng.normal(size=models.models["A2"].size)}
    check = check_jacobian(group, vals, 1e-2)  # linear: a large step avoids rounding noise
    assert check.max_relative_error < 1e-8, check.worst()
    # with zero corrections the spline fitted to the GPS/IMU reproduces it exactly
    vals0 = {k: np.zeros_like(v) if k != Knots("A") else v for k, v in vals.items()}
    assert np.abs(group.residuals(vals0)).max() < 1e-6


def test_split_model_is_continuous_at_its_break():
    models = ModelSet([
        GpsImuModel("S1", ("A",), 0.0, 10.0, 2, 1, windows={"A": (-10.0, 10.0)}),
        GpsImuModel("S2", ("A",), 10.0, 25.0, 1, 2, follows="S1", windows={"A": (10.0, 25.0)}),
        GpsImuModel("S3", ("A",), 25.0, 30.0, 3, 0, follows="S2", windows={"A": (25.0, 40.0)}),
    ])
    rng = np.random.default_rng(0)
    coef = {m.key: rng.normal(scale=5.0, size=m.size) for m in models}
    for t_break in (10.0, 25.0):
        eps = 1e-9
        before = models.correction("A", np.array([t_break - eps]), np.zeros((1, 3)), coef)
        after = models.correction("A", np.array([t_break + eps]), np.zeros((1, 3)), coef)
        assert np.abs(after - before).max() < 1e-3 * 1e-3  # far below 1 mm (and 1 mrad)
    # the eliminated constants are the conditions of the accounting: 6 per break here
    assert sum(m.conditions for m in models) == 12
    # the DESIGN example: 3 sub-models of degree 1 (positions only) = 18 - 2 x 3 = 12 unknowns
    subs = [GpsImuModel(f"M{i}", ("A",), i, i + 1.0, 1, -1, follows=None if i == 0 else f"M{i - 1}") for i in range(3)]
    assert sum(m.size for m in subs) == 12 and sum(m.conditions for m in subs) == 6


def test_rigid_rotation_of_a_model_rotates_positions_about_its_centre():
    m = GpsImuModel("R", ("A",), 0.0, 1.0, -1, -1, rotation=True, centre=np.array([100.0, 0.0, 0.0]),
                    windows={"A": (0.0, 1.0)})
    p = np.array([[100.0, 50.0, 0.0], [200.0, 0.0, 0.0]])
    c = ModelSet([m]).correction("A", np.array([0.5, 0.5]), p, {m.key: np.array([0.0, 0.0, 0.01])})
    # a small rotation of 0.01 rad about z: (0, 50) -> (-0.5, 0); (100, 0) -> (0, 1)
    np.testing.assert_allclose(c[:, :3], [[-0.5, 0, 0], [0, 1.0, 0]], atol=1e-12)


PINHOLE = Pushbroom(pixels=1000, focal_length=0.05, pitch=3e-5, principal_point=505.3, k1=20.0, k2=1e4,
                    line_offset=0.001)


def smile_table(pixels=900):
    """A look-angle table with a nonlinear across-track angle and a smile (along-track angle varying
    with the pixel, 0.1-0.15 deg), as an imaging spectrometer's slit has."""
    u = (np.arange(pixels) - (pixels - 1) / 2) / ((pixels - 1) / 2)
    across = 0.33 * u + 0.01 * u**3
    along = np.radians(0.1) + np.radians(0.05) * u**2
    return Pushbroom(pixels=pixels, along=along, across=across)


def pushbroom_strip(sensor, seed=0, lever=(0.5, -0.2, 1.0), bore=(0.002, -0.001, 0.003), toff=0.004):
    """The wavy strip of ``wavy_strip`` seen by a pushbroom; measurements away from pixel centres
    (where a look-angle table's derivatives jump), so that central differences stay on one piece."""
    spline, _, timing, mount, *_ = wavy_strip(seed, lever, bore, toff)
    geom = StripGeometry(sensor, spline, timing, 500, mount, "A")
    rng = np.random.default_rng(seed + 100)
    pts = np.column_stack([rng.uniform(-650, 650, 36), rng.uniform(150, 1300, 36), rng.uniform(-20, 60, 36)])
    line, pixel, status = geom.ground_to_image(pts, tol_line=1e-9)
    frac = pixel - np.floor(pixel)
    ok = (status == 0) & (frac > 0.15) & (frac < 0.85)
    return spline, timing, mount, pts[ok], line[ok], pixel[ok]


@pytest.mark.parametrize("sensor", [PINHOLE, smile_table()], ids=["pinhole", "table"])
def test_pushbroom_image_model_reproduces_ground_to_image(sensor):
    spline, timing, mount, pts, line, pixel = pushbroom_strip(sensor)
    assert len(pts) > 15
    group = ImageObservations("A", sensor, spline, timing, [f"G{i}" for i in range(len(pts))], line, pixel, 0.3)
    pl, pp = group.predict(values_of(spline, mount, pts))
    np.testing.assert_allclose(pl, line, atol=1e-6)
    np.testing.assert_allclose(pp, pixel, atol=1e-6)
    # the along-track look angle matters: the same points seen with a zero along-track angle fall on
    # other lines (1 mrad forward at 2000 m is 2 m, a line is 2.8 m)
    if not sensor.is_pinhole:
        flat = Pushbroom(pixels=sensor.pixels, along=np.zeros(sensor.pixels), across=sensor.across)
        fl, _ = ImageObservations("A", flat, spline, timing, group.points, line, pixel, 0.3).predict(
            values_of(spline, mount, pts))
        assert np.abs(fl - line).min() > 0.5


@pytest.mark.parametrize("sensor", [PINHOLE, smile_table()], ids=["pinhole", "table"])
def test_pushbroom_image_jacobian_matches_finite_differences(sensor):
    # the points are picked away from pixel centres of the calibrated sensor (the model's pixels)
    calibration = (0.002, -0.003, 0.0015)
    calibrated = sensor.with_calibration(**dict(zip(sensor.calibration_names, calibration)))
    spline, timing, mount, pts, line, pixel = pushbroom_strip(calibrated, 1)
    group = ImageObservations("A", sensor, spline, timing, [f"G{i}" for i in range(len(pts))],
                              line + 0.7, pixel - 1.3, 0.3)
    # a pushbroom has no scan-mirror errors: its own calibration is the detector line's
    assert not {ScanIndex(), ScanScale()} & set(group.keys())
    assert {AcrossOffset(), AcrossScale(), AlongOffset()} <= set(group.keys())
    vals = values_of(spline, mount, pts, pushbroom=calibration)
    steps = {Knots("A"): np.tile([1e-3, 1e-3, 1e-3, 1e-5, 1e-5, 1e-5], spline.n_coef),
             Boresight(): 1e-5, LeverArm(): 1e-3, TimeOffset(): 1e-5, AcrossOffset(): 1e-6, AcrossScale(): 1e-6,
             AlongOffset(): 1e-6}
    for i in range(len(pts)):
        steps[Ground(f"G{i}")] = 1e-3
    # every 7th spline coefficient: each of the 6 components across the knots (the whiskbroom test checks all)
    check = check_jacobian(group, vals, steps, stride={Knots("A"): 7})
    assert check.max_relative_error < 1e-4, check.worst()
    assert len({name for key, name in check.labels if key == Knots("A")}) >= 6 * 3
    for key in (Knots("A"), Ground("G0"), Boresight(), LeverArm(), TimeOffset(), AcrossOffset(), AcrossScale(),
                AlongOffset()):
        cols = [j for j, (k, _) in enumerate(check.labels) if k == key]
        assert np.abs(check.analytic[:, cols]).max() > 0, key
    # the across-track offset moves the pixel by 1 / IFOV (in tangents) per radian
    col = {k: j for j, (k, _) in enumerate(check.labels) if k == AcrossOffset()}
    jac = check.analytic.reshape(-1, 2, check.analytic.shape[1]) * 0.3  # whitened by 0.3 px
    ifov = 3e-5 / 0.05 if sensor.is_pinhole else 0.66 / 899
    np.testing.assert_allclose(np.median(np.abs(jac[:, 1, col[AcrossOffset()]])) * ifov, 1.0, rtol=0.15)


@pytest.mark.parametrize("sensor", [PINHOLE, smile_table()], ids=["pinhole", "table"])
def test_pushbroom_calibration_unknowns_are_the_calibrated_sensor(sensor):
    """The image model of the nominal sensor with calibration unknowns predicts what the compiled
    ground -> image of the calibrated sensor (as rectification uses it) finds."""
    calibration = (-0.0025, 0.006, 0.002)
    calibrated = sensor.with_calibration(**dict(zip(sensor.calibration_names, calibration)))
    spline, timing, mount, pts, line, pixel = pushbroom_strip(calibrated, 2)
    assert len(pts) > 15
    group = ImageObservations("A", sensor, spline, timing, [f"G{i}" for i in range(len(pts))], line, pixel, 0.3)
    pl, pp = group.predict(values_of(spline, mount, pts, pushbroom=calibration))
    np.testing.assert_allclose(pl, line, atol=1e-6)
    np.testing.assert_allclose(pp, pixel, atol=1e-6)
    # the nominal values miss by pixels across (offset and scale) and by lines along (2 mrad at 2000 m)
    nl, npx = group.predict(values_of(spline, mount, pts))
    assert np.abs(npx - pixel).max() > 2.0 and np.abs(nl - line).min() > 0.5


@pytest.mark.parametrize("sensor", [PINHOLE, smile_table()], ids=["pinhole", "table"])
def test_measured_time_image_model_agrees_with_the_solved_time_on_exact_measurements(sensor):
    """With the measured line fixing the time, an exact measurement has zero residuals as with the time
    solved, and the geometry's ``measured_line_residuals`` (check points) computes what the group
    does; a measurement off by 0.4 lines along gives -0.4 lines of residual, to the strip's attitude
    wiggles (pitch 0.005 rad/s over 0.016 s against 1.4 mrad per line is 0.06 lines; roll and the
    smile add a little)."""
    calibration = (0.001, -0.002, 0.0005)
    calibrated = sensor.with_calibration(**dict(zip(sensor.calibration_names, calibration)))
    spline, timing, mount, pts, line, pixel = pushbroom_strip(calibrated, 3)
    ids = [f"G{i}" for i in range(len(pts))]
    vals = values_of(spline, mount, pts, pushbroom=calibration)
    group = ImageObservations("A", sensor, spline, timing, ids, line, pixel, 0.3, measured_time=True)
    pl, pp = group.predict(vals)
    np.testing.assert_allclose(pl, line, atol=1e-6)
    np.testing.assert_allclose(pp, pixel, atol=1e-6)
    moved = ImageObservations("A", sensor, spline, timing, ids, line + 0.4, pixel, 0.3, measured_time=True)
    ml, mp = moved.predict(vals)
    np.testing.assert_allclose(ml - (line + 0.4), -0.4, atol=0.1)
    geometry = StripGeometry(calibrated, spline, timing, 500, mount, "A")
    dl, dp = geometry.measured_line_residuals(pts, line + 0.4, pixel)
    np.testing.assert_allclose(dl, ml - (line + 0.4), atol=1e-6)
    np.testing.assert_allclose(dp, mp - pixel, atol=1e-6)


@pytest.mark.parametrize("sensor", [PINHOLE, smile_table()], ids=["pinhole", "table"])
def test_measured_time_image_jacobian_matches_finite_differences(sensor):
    calibration = (0.002, -0.003, 0.0015)
    calibrated = sensor.with_calibration(**dict(zip(sensor.calibration_names, calibration)))
    spline, timing, mount, pts, line, pixel = pushbroom_strip(calibrated, 1)
    group = ImageObservations("A", sensor, spline, timing, [f"G{i}" for i in range(len(pts))],
                              line + 0.7, pixel - 1.3, 0.3, measured_time=True)
    vals = values_of(spline, mount, pts, pushbroom=calibration)
    # the model's pixels are those of the pose 0.7 lines away, not the ones picked away from the table's
    # pixel centres: a boresight step of 1e-6 rad (0.001 px) stays on one piece of the table
    steps = {Knots("A"): np.tile([1e-3, 1e-3, 1e-3, 1e-5, 1e-5, 1e-5], spline.n_coef),
             Boresight(): 1e-6, LeverArm(): 1e-3, TimeOffset(): 1e-5, AcrossOffset(): 1e-6, AcrossScale(): 1e-6,
             AlongOffset(): 1e-6}
    for i in range(len(pts)):
        steps[Ground(f"G{i}")] = 1e-3
    check = check_jacobian(group, vals, steps, stride={Knots("A"): 7})
    assert check.max_relative_error < 1e-4, check.worst()
    for key in (Knots("A"), Ground("G0"), Boresight(), LeverArm(), TimeOffset(), AcrossOffset(), AcrossScale(),
                AlongOffset()):
        cols = [j for j, (k, _) in enumerate(check.labels) if k == key]
        assert np.abs(check.analytic[:, cols]).max() > 0, key


def test_relative_mounting_prior_jacobian_and_known_answer():
    """The prior's rows: analytic derivatives against central differences at boresights of degrees (the real
    HySpex pair's size), and its residual zero when the sensor's boresight is the reference's times the given
    relative rotation, whatever the reference's."""
    from scangeo.adjustment.mounting import RelativeMountingPrior, relative_rotation
    from scangeo.io.project import RelativeMounting
    from scangeo.rotation import matrix_to_rph, rph_to_matrix

    rel = np.radians([-1.54, 0.48, -0.21])
    prior = RelativeMounting("swir", "vnir", rel, np.radians([0.01, 0.01, 0.02]), np.array([0.0, 0.12, -0.03]),
                             np.array([0.005, 0.005, 0.01]))
    group = RelativeMountingPrior(prior)
    rng = np.random.default_rng(5)
    b_ref = np.radians([0.8, -0.3, 1.1])
    exact = np.array(matrix_to_rph(rph_to_matrix(*b_ref) @ rph_to_matrix(*rel)))
    on = {Boresight("swir"): exact, Boresight("vnir"): b_ref, LeverArm("swir"): np.array([0.1, 0.2, 0.3]),
          LeverArm("vnir"): np.array([0.1, 0.08, 0.33])}
    assert np.allclose(group.residuals(on), 0.0, atol=1e-12)
    assert np.allclose(relative_rotation(exact, b_ref), rel, atol=1e-12)
    off = {**on, Boresight("swir"): exact + rng.normal(0, 1e-3, 3), LeverArm("vnir"): np.array([0.0, 0.1, 0.3])}
    check = check_jacobian(group, off, {Boresight("swir"): 1e-6, Boresight("vnir"): 1e-6, LeverArm("swir"): 1e-3,
                                        LeverArm("vnir"): 1e-3})
    assert check.max_relative_error < 1e-6, check.worst()
    # a small extra rotation about the sensor frame's x axis: a roll residual of its sine
    tilted = {**on, Boresight("swir"): np.array(matrix_to_rph(rph_to_matrix(*exact) @ rph_to_matrix(2e-4, 0, 0)))}
    w = group.residuals(tilted)[:3] * prior.boresight_sigma
    assert abs(w[0] - np.sin(2e-4)) < 1e-9 and np.all(np.abs(w[1:]) < 1e-9)
