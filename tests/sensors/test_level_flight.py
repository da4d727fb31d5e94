"""Hand-checked geometry: a level flight north over a flat DTM."""
import numpy as np
import pytest

from scangeo.sensors import Mounting, Pushbroom, StripGeometry, Whiskbroom
from scangeo.sensors.kernels import NOT_SEEN, OK, OUTSIDE_SWATH
from scangeo.timing import LineTiming

from .helpers import flat_world, level_spline, level_strip

H_FLIGHT, H_GROUND = 2300.0, 100.0


def curvature_drop(d):
    return d * d / (2 * 6.38e6)


def test_nadir_pixel_sees_the_point_below():
    mf, dtm = flat_world(H_GROUND)
    sensor = Whiskbroom(pixels=717, per_pixel_timing=False)  # odd: pixel 358 is exactly nadir
    strip = level_strip(sensor)
    g, status = strip.image_to_ground(np.array([250.0]), np.array([358.0]), dtm)
    assert status[0] == OK
    t = strip.timing.time_of_line(250.0)
    y_aircraft = -2000.0 + 60.0 * t
    assert g[0, 0] == pytest.approx(0.0, abs=1e-6)
    assert g[0, 1] == pytest.approx(y_aircraft, abs=1e-6)
    # the DTM lies 100 m above the ellipsoid, lowered by the earth's curvature in P
    assert g[0, 2] == pytest.approx(H_GROUND - curvature_drop(y_aircraft), abs=0.02)


@pytest.mark.parametrize("direction", [1, -1])
def test_edge_pixel_lands_at_H_tan_theta_on_the_correct_side(direction):
    mf, dtm = flat_world(H_GROUND)
    sensor = Whiskbroom(per_pixel_timing=False, scan_direction=direction)
    strip = level_strip(sensor)
    g, status = strip.image_to_ground(np.array([100.0, 100.0]), np.array([0.0, 715.0]), dtm)
    assert (status == OK).all()
    theta = sensor.scan_angle(np.array([0.0, 715.0]))
    height = H_FLIGHT - g[:, 2]
    assert np.allclose(g[:, 0], height * np.tan(theta), atol=1e-4)
    # pixel 0 is on the left (west, x < 0) when pixels grow to the right
    assert np.sign(g[0, 0]) == -direction
    assert abs(g[0, 0]) == pytest.approx(
        (H_FLIGHT - H_GROUND) * np.tan(np.radians(42.9 / 2) - 0.5 * sensor.step), rel=1e-3
    )


def test_one_degree_roll_moves_the_ground_point_by_the_expected_amount():
    mf, dtm = flat_world(H_GROUND)
    sensor = Whiskbroom(per_pixel_timing=False)
    pixels = np.array([0.0, 357.5, 715.0])
    lines = np.full(3, 100.0)
    g0, _ = level_strip(sensor).image_to_ground(lines, pixels, dtm)
    g1, _ = level_strip(sensor, roll=np.radians(1.0)).image_to_ground(lines, pixels, dtm)
    theta = sensor.scan_angle(pixels)
    # right wing down (positive roll) turns the look to the left: x = h tan(theta - roll)
    assert np.allclose(g1[:, 0], (H_FLIGHT - g1[:, 2]) * np.tan(theta - np.radians(1.0)), atol=1e-3)
    assert g1[1, 0] == pytest.approx(-(H_FLIGHT - g1[1, 2]) * np.tan(np.radians(1.0)), abs=1e-3)
    assert g1[1, 0] - g0[1, 0] == pytest.approx(-38.4, abs=0.1)  # 2200 m * tan(1 deg)


def test_per_pixel_time_offset_shifts_along_track():
    mf, dtm = flat_world(H_GROUND)
    on, off = Whiskbroom(per_pixel_timing=True), Whiskbroom(per_pixel_timing=False)
    lines, pixels = np.array([100.0, 100.0]), np.array([0.0, 715.0])
    g_on, _ = level_strip(on).image_to_ground(lines, pixels, dtm)
    g_off, _ = level_strip(off).image_to_ground(lines, pixels, dtm)
    dt_edge = (0 - on.centre) * on.step / (2 * np.pi * 25.0)
    assert g_on[0, 1] - g_off[0, 1] == pytest.approx(60.0 * dt_edge, abs=1e-6)
    assert g_on[1, 1] - g_off[1, 1] == pytest.approx(-60.0 * dt_edge, abs=1e-6)


def test_lever_arm_and_boresight():
    mf, dtm = flat_world(H_GROUND)
    sensor = Whiskbroom(pixels=717, per_pixel_timing=False)
    base = level_strip(sensor)
    mount = Mounting(lever_arm_B=np.array([2.0, 1.0, 0.5]), boresight=np.array([0.0, np.radians(0.5), 0.0]))
    moved = StripGeometry(sensor, base.spline, base.timing, base.n_lines, mount)
    g0, _ = base.image_to_ground(np.array([100.0]), np.array([358.0]), dtm)
    g1, _ = moved.image_to_ground(np.array([100.0]), np.array([358.0]), dtm)
    # heading north: body x = north, y = east, z = down -> lever (2, 1, 0.5) = +2 m north, +1 m east
    # a positive boresight pitch (nose up) looks forward by h tan(0.5 deg)
    h = H_FLIGHT - 0.5 - g1[0, 2]
    assert g1[0, 0] - g0[0, 0] == pytest.approx(1.0, abs=1e-4)
    assert g1[0, 1] - g0[0, 1] == pytest.approx(2.0 + h * np.tan(np.radians(0.5)), abs=1e-3)


def test_points_outside_the_strip_are_nan_with_a_reason():
    strip = level_strip(Whiskbroom())
    y_first = -2000 + 60 * 1.0
    pts = np.array([[0.0, y_first - 500, 100.0], [2000.0, y_first + 300, 100.0], [0.0, y_first + 300, 100.0]])
    line, pixel, status = strip.ground_to_image(pts)
    assert status[0] == NOT_SEEN and np.isnan(line[0])
    assert status[1] == OUTSIDE_SWATH and np.isnan(pixel[1])
    assert status[2] == OK and line[2] == pytest.approx(300 / 60 * 25, abs=0.01)


def test_pushbroom_pinhole_nadir_and_edge():
    mf, dtm = flat_world(H_GROUND)
    cam = Pushbroom(pixels=1001, focal_length=0.05, pitch=10e-6)
    strip = StripGeometry(cam, level_spline(), LineTiming(1.0, 25.0), 500)
    g, status = strip.image_to_ground(np.array([100.0, 100.0]), np.array([500.0, 1000.0]), dtm)
    assert (status == OK).all()
    assert g[0, 0] == pytest.approx(0.0, abs=1e-6)
    h = H_FLIGHT - g[1, 2]
    assert g[1, 0] == pytest.approx(h * 500 * 10e-6 / 0.05, abs=1e-4)
