import numpy as np
import pytest

from scangeo.frames import Geoid, MapFrame, ProjectFrame, ecef_to_geodetic, geodetic_to_ecef
from scangeo.rotation import R_ENU_NED, matrix_to_rph, rph_to_matrix, rph_to_matrix_with_derivatives


def test_ecef_round_trip_is_exact():
    rng = np.random.default_rng(1)
    lat = rng.uniform(-1.5, 1.5, 1000)
    lon = rng.uniform(-3.1, 3.1, 1000)
    h = rng.uniform(-500, 12000, 1000)
    lat2, lon2, h2 = ecef_to_geodetic(geodetic_to_ecef(lat, lon, h))
    assert np.max(np.abs(lat2 - lat)) < 1e-12
    assert np.max(np.abs(lon2 - lon)) < 1e-12
    assert np.max(np.abs(h2 - h)) < 1e-6


def test_known_ecef_value():
    # The equator at the prime meridian lies at x = a.
    assert np.allclose(geodetic_to_ecef(0.0, 0.0, 0.0), [6378137.0, 0.0, 0.0])
    # The pole: z = b = a (1 - f).
    assert np.allclose(geodetic_to_ecef(np.pi / 2, 0.0, 0.0), [0.0, 0.0, 6356752.314245], atol=1e-6)


def test_project_frame_axes_point_east_north_up():
    frame = ProjectFrame.from_origin(48.2, 16.37, 200.0)
    p0 = frame.geodetic_to_project(frame.lat0, frame.lon0, frame.h0)
    assert np.allclose(p0, 0.0, atol=1e-6)
    up = frame.geodetic_to_project(frame.lat0, frame.lon0, frame.h0 + 100.0)
    assert np.allclose(up, [0, 0, 100.0], atol=1e-6)
    north = frame.geodetic_to_project(frame.lat0 + 1e-5, frame.lon0, frame.h0)
    assert north[1] > 60 and abs(north[0]) < 1e-6
    east = frame.geodetic_to_project(frame.lat0, frame.lon0 + 1e-5, frame.h0)
    assert east[0] > 40 and abs(east[1]) < 1e-3
    # R_PL at the origin maps NED onto ENU exactly.
    assert np.allclose(frame.R_PL(frame.lat0, frame.lon0), R_ENU_NED, atol=1e-15)


def test_R_PL_carries_curvature_and_convergence():
    frame = ProjectFrame.from_origin(48.2, 16.37, 0.0)
    # 17 km north: the vertical has turned by about 17e3 / 6.37e6 rad = 0.153 deg about the east axis.
    lat = frame.lat0 + 17e3 / 6.37e6
    R = frame.R_PL(lat, frame.lon0)
    down_P = R[:, 2]
    tilt = np.degrees(np.arccos(-down_P[2]))
    assert tilt == pytest.approx(0.153, abs=0.002)
    assert down_P[1] < 0  # the local down leans towards the origin (south) in P


@pytest.mark.parametrize("crs", ["EPSG:31256", "EPSG:32633", "EPSG:3035"])
def test_map_project_round_trip_below_1mm_over_50km(crs):
    geoid = Geoid(constant=45.3)
    probe = MapFrame(crs, ProjectFrame(0, 0, 0), geoid)
    lat0, lon0 = np.radians(48.2), np.radians(16.37)
    x0, y0 = probe.geodetic_to_map_2d(np.array([lat0]), np.array([lon0]))
    mf = MapFrame.centred_on(crs, float(x0[0]), float(y0[0]), 200.0, geoid)
    rng = np.random.default_rng(2)
    x = x0[0] + rng.uniform(-25e3, 25e3, 2000)
    y = y0[0] + rng.uniform(-25e3, 25e3, 2000)
    H = rng.uniform(100, 3000, 2000)
    p = mf.map_to_project(x, y, H)
    x2, y2, H2 = mf.project_to_map(p)
    err = np.sqrt((x2 - x) ** 2 + (y2 - y) ** 2 + (H2 - H) ** 2)
    assert err.max() < 1e-3
    # the origin is at the centre map point, up to the geoid
    p0 = mf.map_to_project(x0, y0, np.array([200.0]))
    assert np.allclose(p0, 0.0, atol=1e-6)


def test_rotation_round_trip_and_derivatives():
    rng = np.random.default_rng(3)
    r, p, h = rng.uniform(-0.5, 0.5, 50), rng.uniform(-0.5, 0.5, 50), rng.uniform(-3, 3, 50)
    R = rph_to_matrix(r, p, h)
    assert np.allclose(R @ np.swapaxes(R, -1, -2), np.eye(3), atol=1e-14)
    r2, p2, h2 = matrix_to_rph(R)
    assert np.allclose([r2, p2, h2], [r, p, h], atol=1e-12)
    R0, dR = rph_to_matrix_with_derivatives(r, p, h)
    eps = 1e-7
    for k, delta in enumerate(np.eye(3) * eps):
        num = (rph_to_matrix(r + delta[0], p + delta[1], h + delta[2])
               - rph_to_matrix(r - delta[0], p - delta[1], h - delta[2])) / (2 * eps)
        assert np.allclose(dR[:, k], num, atol=1e-8)
