"""Forward/reverse flights: IMU attitude errors come back within 1 % while the other errors cancel."""
from __future__ import annotations

import numpy as np
import pytest

from scangeo.lidar.calibration_flights import body_fixed_attitude, recover_attitude
from scangeo.lidar.laser_equation import FlightGeometry, SystematicErrors

d = np.radians
GEOMETRY = FlightGeometry(height=1500.0, fov=d(40.0), pulses=2001, speed=60.0)
IMU = (d(0.03), d(-0.02), d(0.05))
CANCELLING = dict(range_offset=0.2, scan_angle_error=d(0.05), gps=(0.3, -0.2, 0.4),
                  deflection=(2e-5, -3e-5), lever_arm=(0.0, 0.0, 0.1))


def test_imu_errors_recovered_within_one_percent_with_other_errors_present():
    r = recover_attitude(GEOMETRY, SystematicErrors(imu=IMU, **CANCELLING))
    np.testing.assert_allclose([r.roll, r.pitch, r.heading], IMU, rtol=0.01)


def test_world_fixed_and_symmetric_errors_cancel():
    r = recover_attitude(GEOMETRY, SystematicErrors(**CANCELLING))
    # 0.4 m GPS, 20 cm range, 0.05 deg scale error, 4 arcsec deflection: no pseudo attitude above 1e-9 rad
    assert np.max(np.abs([r.roll, r.pitch, r.heading])) < 1e-9
    np.testing.assert_allclose(r.d_ab_nadir[:2], 0.0, atol=1e-9)


def test_heading_cancels_in_forward_reverse_pair_and_needs_parallel_strip():
    r = recover_attitude(GEOMETRY, SystematicErrors(imu=(0.0, 0.0, d(0.05))))
    assert abs(r.heading_from_edges) < 1e-12
    assert r.heading == pytest.approx(d(0.05), rel=1e-4)


def test_body_fixed_errors_are_inseparable_from_imu_errors():
    e = SystematicErrors(imu=IMU, mounting=(d(0.01), d(0.01), d(0.01)), index_error=d(0.005),
                         plane_lean=d(0.004), plane_skew=d(0.003), lever_arm=(0.02, 0.03, 0.0), sync_offset=1e-4,
                         **{k: v for k, v in CANCELLING.items() if k != "lever_arm"})
    r = recover_attitude(GEOMETRY, e)
    expected = body_fixed_attitude(e, GEOMETRY.height, GEOMETRY.speed)
    np.testing.assert_allclose([r.roll, r.pitch, r.heading], expected, rtol=0.01)
    # and they differ from the IMU errors alone by more than 1 %: the mounting adds 0.01 deg
    assert abs(r.pitch - IMU[1]) > 0.1 * abs(IMU[1])


def test_cli_forward_reverse_json(run_lidar_json):
    out = run_lidar_json(["lidar", "forward-reverse", "--imu", "0.02,0.01,-0.04"])
    np.testing.assert_allclose([out["recovered_deg"][k] for k in ("roll", "pitch", "heading")],
                               [0.02, 0.01, -0.04], rtol=0.01)
    assert abs(out["heading_from_forward_reverse_edges_deg"]) < 1e-9
