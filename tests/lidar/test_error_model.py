"""Hand-derivable error vectors of the laser equation, and the ``scangeo lidar errors`` command."""
from __future__ import annotations

import numpy as np
import pytest

from scangeo.errors import LidarError
from scangeo.lidar.error_sources import error_budget_by_source, line_errors
from scangeo.lidar.laser_equation import FlightGeometry, SystematicErrors, error_vectors

H = 1000.0
FOV = np.radians(40.0)
TAU = FOV / 2
GEOMETRY = FlightGeometry(height=H, fov=FOV)


def test_range_offset_gives_minus_plus_dr_sin_tau_and_dr_cos_tau():
    dr = 0.12
    line = line_errors(GEOMETRY, SystematicErrors(range_offset=dr))
    np.testing.assert_allclose(line.start, [0.0, -dr * np.sin(TAU), dr * np.cos(TAU)], atol=1e-9)
    np.testing.assert_allclose(line.middle, [0.0, 0.0, dr], atol=1e-9)
    np.testing.assert_allclose(line.end, [0.0, dr * np.sin(TAU), dr * np.cos(TAU)], atol=1e-9)
    assert line.plane_tilt == pytest.approx(0.0, abs=1e-12)


def test_mounting_pitch_shifts_every_return_along_track_by_h_times_angle():
    dp = np.radians(0.02)
    err, _ = error_vectors(GEOMETRY, SystematicErrors(mounting=(0.0, dp, 0.0)))
    # the range is measured, so the point turns about the sensor: -rho * dp along; rho cos(theta) = H
    np.testing.assert_allclose(err[:, 0], -H * dp, rtol=1e-6)
    np.testing.assert_allclose(err[:, 1], 0.0, atol=1e-9)
    assert np.max(np.abs(err[:, 2])) < 1e-3 * H * dp        # second order only


def test_heading_error_rotates_scan_line_about_nadir():
    dh = np.radians(0.03)
    err, true = error_vectors(GEOMETRY, SystematicErrors(imu=(0.0, 0.0, dh)))
    mid = GEOMETRY.pulses // 2
    np.testing.assert_allclose(err[mid], 0.0, atol=1e-9)
    # along-track error proportional to the across position: a rotation by dh about the nadir point
    np.testing.assert_allclose(err[:, 0], true[:, 1] * dh, rtol=1e-6, atol=1e-12)
    np.testing.assert_allclose(err[:, 2], 0.0, atol=1e-9)
    np.testing.assert_allclose(err[0, 0], H * np.tan(TAU) * dh, rtol=1e-6)


def test_mounting_roll_tilts_horizontal_plane_across_swath():
    dr = np.radians(0.015)
    line = line_errors(GEOMETRY, SystematicErrors(mounting=(dr, 0.0, 0.0)))
    assert line.plane_tilt == pytest.approx(dr, rel=1e-4)
    # vertical error +-H tan(tau) dr at the edges, across H dr everywhere
    assert line.start[2] == pytest.approx(H * np.tan(TAU) * dr, rel=1e-3)
    assert line.end[2] == pytest.approx(-H * np.tan(TAU) * dr, rel=1e-3)
    np.testing.assert_allclose([line.start[1], line.middle[1], line.end[1]], H * dr, rtol=1e-3)


def test_scan_angle_of_pulse_i_of_n_index_and_scale():
    geometry = FlightGeometry(height=H, fov=FOV, pulses=5)
    d_index, d_fov = np.radians(0.01), np.radians(0.04)
    err_i, _ = error_vectors(geometry, SystematicErrors(index_error=d_index))
    err_s, _ = error_vectors(geometry, SystematicErrors(scan_angle_error=d_fov))
    theta = FOV * (0.5 - np.arange(5) / 4)
    # turning the beam by dtheta about the sensor moves the point by -rho dtheta across
    rho = H / np.cos(theta)
    np.testing.assert_allclose(err_i[:, 1], -rho * np.cos(theta) * d_index, rtol=1e-3)
    np.testing.assert_allclose(
        err_s[:, 1], -rho * np.cos(theta) * d_fov * (0.5 - np.arange(5) / 4), rtol=1e-3, atol=1e-9
    )


def test_gps_and_lever_arm_shift_every_return_by_minus_offset():
    e = SystematicErrors(gps=(0.1, -0.2, 0.3))
    err, _ = error_vectors(GEOMETRY, e)
    np.testing.assert_allclose(err, np.tile([-0.1, 0.2, 0.3], (GEOMETRY.pulses, 1)), atol=1e-9)
    err, _ = error_vectors(GEOMETRY, SystematicErrors(lever_arm=(0.05, 0.02, -0.01)))
    np.testing.assert_allclose(err, np.tile([-0.05, -0.02, -0.01], (GEOMETRY.pulses, 1)), atol=1e-9)


def test_secondary_height_error_on_slope():
    slope = np.tan(np.radians(10.0))
    geometry = FlightGeometry(height=H, fov=FOV, slope_along=slope)
    dp = np.radians(0.02)
    line = line_errors(geometry, SystematicErrors(mounting=(0.0, dp, 0.0)))
    # a planimetric error d_along on a slope s gives the height error -s * d_along
    assert line.height_on_terrain[1] == pytest.approx(line.middle[2] - slope * line.middle[0], abs=1e-12)
    assert line.height_on_terrain[1] == pytest.approx(slope * H * dp, rel=0.02)


def test_total_is_sum_of_sources_for_small_errors():
    e = SystematicErrors(
        range_offset=0.05,
        index_error=1e-4,
        mounting=(1e-4, -2e-4, 3e-4),
        imu=(-1e-4, 1e-4, 2e-4),
        lever_arm=(0.01, 0.02, 0.03),
        gps=(0.05, 0.0, -0.1),
    )
    table = error_budget_by_source(GEOMETRY, e)
    assert list(table) == ["range", "scanner", "mounting", "imu", "lever_arm", "gps", "total"]
    summed = sum(table[k].start for k in table if k != "total")
    np.testing.assert_allclose(table["total"].start, summed, atol=2e-3)


def test_geometry_is_checked():
    with pytest.raises(LidarError, match="flying height"):
        FlightGeometry(height=-1.0, fov=FOV)
    with pytest.raises(LidarError, match="pulses"):
        FlightGeometry(height=H, fov=FOV, pulses=4)


def test_cli_errors_json_shape_and_values(run_lidar_json):
    out = run_lidar_json(
        [
            "lidar",
            "errors",
            "--height",
            "1000",
            "--scan-angle",
            "40",
            "--range-error",
            "0.1",
            "--mounting",
            "0,0.01,0",
            "--gps",
            "0,0,0.05",
        ]
    )
    assert set(out) == {"sources", "total"}
    assert list(out["sources"]) == ["range", "mounting", "gps"]
    for entry in [*out["sources"].values(), out["total"]]:
        assert set(entry) == {"start", "middle", "end", "plane_tilt_deg"}
        assert all(len(entry[k]) == 3 for k in ("start", "middle", "end"))
    np.testing.assert_allclose(out["sources"]["range"]["middle"], [0, 0, 0.1], atol=1e-9)
    np.testing.assert_allclose(out["sources"]["range"]["start"][1], -0.1 * np.sin(np.radians(20)), atol=1e-9)
    assert out["sources"]["mounting"]["middle"][0] == pytest.approx(-1000 * np.radians(0.01), rel=1e-6)
    # GPS 5 cm too high in "down" (true lower): computed 5 cm above, plus the range offset
    assert out["total"]["middle"][2] == pytest.approx(0.1 + 0.05, abs=1e-4)


def test_cli_errors_table_and_bad_triplet(run_lidar):
    code, text = run_lidar(["lidar", "errors", "--height", "800", "--scan-angle", "30", "--imu", "0.01,0,0"])
    assert code == 0 and "imu" in text and "total" in text
    with pytest.raises(SystemExit):
        run_lidar(["lidar", "errors", "--height", "800", "--scan-angle", "30", "--imu", "0.01,0"])
