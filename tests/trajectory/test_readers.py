"""Trajectory readers: CSV forms and errors, Applanix SBET from the bytes, the real UTM 15N trajectory,
conversion to the project frame and back, lever-arm positions."""
from __future__ import annotations

import struct

import numpy as np
import pyproj
import pytest

from scangeo.errors import TrajectoryError
from scangeo.frames import ProjectFrame
from scangeo.trajectory import (
    GpsImuStream,
    ProjectTrajectory,
    read_sbet,
    read_trajectory,
    read_trajectory_csv,
    write_trajectory_csv,
)

from ..conftest import shared_file

UTM_TRAJECTORY = "trajectory/sbet_047_IGS08-UTM15N-Ellipsoid-trim.txt"
HEADER = "time,lat,lon,h,roll,pitch,heading"
ROWS = [
    "100.00,47.000000,16.000000,1000.0,1.0,-2.0,10.0",
    "100.01,47.000010,16.000000,1000.5,1.5,-2.5,11.0",
    "100.02,47.000020,16.000000,1001.0,2.0,-3.0,12.0",
]
SBET_BYTES = 17 * 8


def write(tmp_path, text: str, name: str = "nav.csv"):
    path = tmp_path / name
    path.write_text(text, encoding="utf-8", newline="")
    return path


def error_of(path, **kw) -> str:
    with pytest.raises(TrajectoryError) as info:
        read_trajectory(path, **kw)
    return str(info.value)


# --------------------------------------------------------------------------------- CSV forms
def test_geodetic_csv_in_radians_and_metres(tmp_path):
    s = read_trajectory_csv(write(tmp_path, HEADER + "\n" + "\n".join(ROWS) + "\n"))
    assert len(s) == 3
    np.testing.assert_allclose(s.time, [100.0, 100.01, 100.02])
    np.testing.assert_allclose(np.degrees(s.lat), [47.0, 47.00001, 47.00002], atol=1e-12)
    np.testing.assert_allclose(np.degrees(s.lon), 16.0, atol=1e-12)
    np.testing.assert_allclose(s.h, [1000.0, 1000.5, 1001.0])
    np.testing.assert_allclose(s.roll, np.radians([1.0, 1.5, 2.0]))
    np.testing.assert_allclose(s.pitch, np.radians([-2.0, -2.5, -3.0]))
    np.testing.assert_allclose(s.heading, np.radians([10.0, 11.0, 12.0]))
    assert s.rate_hz == pytest.approx(100.0)


@pytest.mark.parametrize("header, sep", [
    ('"GpsTime","Latitude","Longitude","Height","Roll","Pitch","Azimuth"', ","),
    ("gps_time latitude longitude alt roll pitch yaw", " "),
    ("T\tLAT\tLONG\tAltitude\tRoll\tPitch\tTrue_Heading", "\t"),
    ("'time', 'lat', 'lon', 'h', 'roll', 'pitch', 'heading'", ", "),
])
def test_column_aliases_quotes_and_separators(tmp_path, header, sep):
    rows = [r.replace(",", sep) for r in ROWS]
    s = read_trajectory_csv(write(tmp_path, header + "\n" + "\n".join(rows)))
    np.testing.assert_allclose(s.h, [1000.0, 1000.5, 1001.0])
    np.testing.assert_allclose(s.heading, np.radians([10.0, 11.0, 12.0]))


def test_columns_in_any_order_with_extra_columns_bom_and_crlf(tmp_path):
    text = "\ufeffheading,quality,time,h,lon,lat,pitch,roll\r\n"
    for r in ROWS:
        t, lat, lon, h, roll, pitch, heading = r.split(",")
        text += ",".join([heading, "3", t, h, lon, lat, pitch, roll]) + "\r\n"
    s = read_trajectory_csv(write(tmp_path, text))
    np.testing.assert_allclose(s.time, [100.0, 100.01, 100.02])
    np.testing.assert_allclose(np.degrees(s.lat), [47.0, 47.00001, 47.00002], atol=1e-12)
    np.testing.assert_allclose(s.roll, np.radians([1.0, 1.5, 2.0]))
    np.testing.assert_allclose(s.pitch, np.radians([-2.0, -2.5, -3.0]))


def test_heading_is_unwrapped_across_180(tmp_path):
    rows = ["0,47,16,1000,0,0,179.0", "1,47.001,16,1000,0,0,-179.0", "2,47.002,16,1000,0,0,-177.0"]
    s = read_trajectory_csv(write(tmp_path, HEADER + "\n" + "\n".join(rows)))
    np.testing.assert_allclose(np.degrees(s.heading), [179.0, 181.0, 183.0])


def test_map_csv_with_crs(tmp_path):
    lat = np.array([47.0, 47.001, 47.002])
    lon = np.array([16.0, 16.0005, 16.001])
    to_utm = pyproj.Transformer.from_crs("EPSG:4326", "EPSG:32633", always_xy=True)
    x, y = to_utm.transform(lon, lat)
    rows = [f"{t},{xi:.4f},{yi:.4f},{500.0 + t},0.5,0.25,45" for t, xi, yi in zip(range(3), x, y)]
    path = write(tmp_path, "time,easting,northing,z,roll,pitch,heading\n" + "\n".join(rows))
    s = read_trajectory_csv(path, crs="EPSG:32633")
    np.testing.assert_allclose(np.degrees(s.lat), lat, atol=1e-9)  # 0.1 mm in the file
    np.testing.assert_allclose(np.degrees(s.lon), lon, atol=1e-9)
    np.testing.assert_allclose(s.h, [500.0, 501.0, 502.0])  # z is ellipsoidal, passed through
    np.testing.assert_allclose(np.degrees(s.heading), 45.0)
    # a "height" column is the z of the map form
    path2 = write(tmp_path, "time,x,y,height,roll,pitch,heading\n" + "\n".join(rows), "nav2.csv")
    np.testing.assert_allclose(read_trajectory_csv(path2, crs="EPSG:32633").h, [500.0, 501.0, 502.0])
    assert "crs" in error_of(path)  # x,y without a CRS


def test_write_then_read_round_trip(tmp_path):
    s = read_trajectory_csv(write(tmp_path, HEADER + "\n" + "\n".join(ROWS)))
    out = tmp_path / "copy.csv"
    write_trajectory_csv(out, s)
    assert not [p for p in tmp_path.iterdir() if "tmp" in p.name]  # no temporary left
    back = read_trajectory_csv(out)
    for name in ("time", "lat", "lon", "h", "roll", "pitch", "heading"):
        np.testing.assert_allclose(getattr(back, name), getattr(s, name), rtol=0, atol=1e-6)


# --------------------------------------------------------------------------------- CSV errors
BAD_CSV = {
    "duplicate time": (ROWS + ["100.02,47.00003,16,1000,0,0,0"], 5, "repeats the previous"),
    "backwards time": (ROWS + ["100.015,47.00003,16,1000,0,0,0"], 5, "is before the previous"),
    "NaN value": (ROWS[:1] + ["100.01,nan,16,1000,0,0,0"] + ROWS[2:], 3, "lat is not a finite number"),
    "NaN time": (ROWS[:1] + ["NaN,47.00001,16,1000,0,0,0"] + ROWS[2:], 3, "time is not a finite number"),
    "infinite value": (ROWS[:2] + ["100.02,47,16,inf,0,0,0"], 4, "h is not a finite number"),
    "not a number": (ROWS[:1] + ["100.01,47.00001,16,1000,0,x2,0"] + ROWS[2:], 3, "pitch 'x2' is not a number"),
    "empty field": (ROWS[:1] + ["100.01,47.00001,,1000,0,0,0"] + ROWS[2:], 3, "lon '' is not a number"),
    "truncated last record": (ROWS + ["100.03,47.00003,16.0,10"], 5, "4 fields, expected at least 7"),
    "truncated record inside": (ROWS[:1] + ["100.01,47.00001"] + ROWS[2:], 3, "2 fields, expected at least 7"),
    "blank line inside": (ROWS[:2] + ["  "] + ROWS[2:], 4, "empty line"),
}


@pytest.mark.parametrize("case", sorted(BAD_CSV))
def test_bad_records_name_file_and_line(tmp_path, case):
    rows, line, what = BAD_CSV[case]
    path = write(tmp_path, HEADER + "\n" + "\n".join(rows) + "\n")
    message = error_of(path)
    assert message.startswith(f"{path} line {line}:"), message
    assert what in message


def test_error_line_numbers_in_a_long_file(tmp_path):
    """The fast parser and the line-finding slow path agree on the line 1 + record number."""
    t = np.arange(5000) * 0.005
    rows = [f"{ti:.3f},47,16,1000,0,0,0" for ti in t]
    rows[3210] = rows[3209]
    message = error_of(write(tmp_path, HEADER + "\n" + "\n".join(rows)))
    assert " line 3212: time 16.045000 repeats the previous 16.045000" in message


@pytest.mark.parametrize("header, expected", [
    ("time,lat,lon,roll,pitch,heading", "found time,lat,lon,roll,pitch,heading"),
    ("time,x,y,z,roll,pitch", "found time,x,y,z,roll,pitch"),
    ("100.00,47.0,16.0,1000.0,1.0,-2.0,10.0", "found 100.00,47.0"),  # no header line
    ("time,lat,lon,h,roll,pitch,heading,yaw", "column 'heading' appears twice"),
])
def test_wrong_column_set(tmp_path, header, expected):
    path = write(tmp_path, header + "\n" + "\n".join(ROWS))
    message = error_of(path)
    assert message.startswith(f"{path} line 1:")
    assert expected in message
    if "found" in expected:
        assert "expected the columns time,lat,lon,h,roll,pitch,heading or time,x,y,z,roll,pitch,heading" in message


@pytest.mark.parametrize("text, expected", [
    ("", "the file is empty"),
    (HEADER + "\n", "no records after the header"),
    (HEADER + "\n" + ROWS[0] + "\n", "at least 2 records, found 1"),
])
def test_empty_files(tmp_path, text, expected):
    path = write(tmp_path, text)
    message = error_of(path)
    assert str(path) in message and expected in message


def test_missing_and_binary_files(tmp_path):
    assert "cannot read" in error_of(tmp_path / "absent.csv")
    path = tmp_path / "nav.txt"
    path.write_bytes(struct.pack("<17d", *range(17)) + b"\xff\xfe")
    message = error_of(path)
    assert str(path) in message and "a binary file (NUL bytes), not text" in message and ".out" in message


# --------------------------------------------------------------------------------- SBET
def sbet_records(path) -> list[tuple[float, ...]]:
    """The records of an SBET, read straight from the bytes (17 little-endian doubles each)."""
    data = path.read_bytes()
    assert len(data) % SBET_BYTES == 0
    return [struct.unpack_from("<17d", data, k * SBET_BYTES) for k in range(len(data) // SBET_BYTES)]


@pytest.mark.parametrize("relative, n", [("sbet/2-points.sbet", 2), ("lidar/leeward_sbet.out", 200)])
def test_sbet_against_the_bytes(relative, n):
    path = shared_file(relative)
    records = sbet_records(path)
    s = read_sbet(path)
    assert len(s) == len(records) == n
    for k in (0, n // 2, n - 1):
        time, lat, lon, alt = records[k][:4]
        roll, pitch, platform_heading, wander = records[k][7:11]
        assert s.time[k] == time and s.lat[k] == lat and s.lon[k] == lon and s.h[k] == alt
        assert s.roll[k] == roll and s.pitch[k] == pitch
        assert wander != 0.0  # the files have a wander angle: the test means something
        # true heading = platform heading - wander angle (modulo a full turn: the stream unwraps)
        diff = s.heading[k] - (platform_heading - wander)
        assert abs(diff - 2 * np.pi * np.round(diff / (2 * np.pi))) < 1e-12
    assert read_trajectory(path).time[-1] == records[-1][0]  # dispatch by extension


def test_sbet_known_values():
    """First record of each file, spelled out (read once with ``xxd``/``struct``)."""
    s = read_sbet(shared_file("sbet/2-points.sbet"))
    assert s.time[0] == pytest.approx(151631.00283607, abs=1e-8)
    assert np.degrees(s.lat[0]) == pytest.approx(32.54521659, abs=1e-8)
    assert np.degrees(s.lon[0]) == pytest.approx(-116.9781799, abs=1e-7)
    assert s.h[0] == pytest.approx(107.71529533, abs=1e-8)
    # platform heading 174.56724723 deg, wander -1.25959886 deg
    assert np.degrees(s.heading[0]) % 360 == pytest.approx(175.82684609, abs=1e-8)
    s = read_sbet(shared_file("lidar/leeward_sbet.out"))
    assert s.rate_hz == pytest.approx(200.0, rel=1e-6)
    # platform heading 165.008866 deg, wander 1.02172049 deg
    assert np.degrees(s.heading[0]) % 360 == pytest.approx(163.98714593, abs=1e-7)


def test_truncated_sbet_names_the_record(tmp_path):
    path = tmp_path / "cut.out"
    data = shared_file("lidar/leeward_sbet.out").read_bytes()
    path.write_bytes(data[:-5])
    message = error_of(path)
    assert message.startswith(f"{path} record 200: truncated (131 bytes of 136")


def test_sbet_bad_values_name_the_record(tmp_path):
    records = [list(r) for r in sbet_records(shared_file("lidar/leeward_sbet.out"))[:20]]
    nan_copy = [r[:] for r in records]
    nan_copy[7][2] = float("nan")
    path = tmp_path / "nan.sbet"
    path.write_bytes(b"".join(struct.pack("<17d", *r) for r in nan_copy))
    assert error_of(path).startswith(f"{path} record 8: lon is not a finite number")
    back_copy = [r[:] for r in records]
    back_copy[12][0] = back_copy[10][0]
    path = tmp_path / "back.out"
    path.write_bytes(b"".join(struct.pack("<17d", *r) for r in back_copy))
    assert error_of(path).startswith(f"{path} record 13: time ")
    assert "is before the previous" in error_of(path)
    empty = tmp_path / "empty.out"
    empty.write_bytes(b"")
    assert "no SBET records" in error_of(empty)


# --------------------------------------------------------------------------------- real UTM 15N text
@pytest.fixture(scope="module")
def utm_stream() -> GpsImuStream:
    return read_trajectory(shared_file(UTM_TRAJECTORY), crs="EPSG:32615")


def test_real_trajectory_records_and_rate(utm_stream):
    lines = shared_file(UTM_TRAJECTORY).read_text().splitlines()
    assert len(utm_stream) == len(lines) - 1 == 14600
    assert utm_stream.rate_hz == pytest.approx(200.0, rel=1e-6)
    assert utm_stream.time[0] == 407106.003323 and utm_stream.time[-1] == 407178.999343
    assert np.all(np.diff(utm_stream.time) > 0)


@pytest.mark.parametrize("record", [0, 7301, 14599])
def test_real_trajectory_spot_check(utm_stream, record):
    """A record parsed by hand and converted with pyproj's UTM projection (not the reader's route)."""
    lines = shared_file(UTM_TRAJECTORY).read_text().splitlines()
    assert lines[0] == '"GpsTime","Y","X","Z","Roll","Pitch","Azimuth"'
    t, north, east, z, roll, pitch, azimuth = (float(v) for v in lines[record + 1].split(","))
    utm = pyproj.Proj(proj="utm", zone=15, ellps="WGS84")
    lon, lat = utm(east, north, inverse=True)
    assert utm_stream.time[record] == t
    assert np.degrees(utm_stream.lat[record]) == pytest.approx(lat, abs=1e-10)  # ~10 micrometres
    assert np.degrees(utm_stream.lon[record]) == pytest.approx(lon, abs=1e-10)
    assert 29.6 < lat < 29.8 and -95.5 < lon < -95.2  # near Houston
    assert utm_stream.h[record] == z
    assert np.degrees(utm_stream.roll[record]) == pytest.approx(roll, abs=1e-12)
    assert np.degrees(utm_stream.pitch[record]) == pytest.approx(pitch, abs=1e-12)
    d = np.degrees(utm_stream.heading[record]) - azimuth
    assert abs(d - 360 * round(d / 360)) < 1e-9


def test_project_frame_round_trip_and_convergence(utm_stream):
    mid = len(utm_stream) // 2
    frame = ProjectFrame(float(utm_stream.lat[mid]), float(utm_stream.lon[mid]), float(utm_stream.h[mid]))
    traj = utm_stream.to_project(frame)
    assert isinstance(traj, ProjectTrajectory) and traj.p_P.shape == (len(utm_stream), 3)
    np.testing.assert_allclose(traj.p_P[mid], 0.0, atol=1e-6)
    # the flight goes west about 5 km (azimuth about -90 deg)
    assert traj.p_P[0, 0] - traj.p_P[-1, 0] > 4000.0
    back = GpsImuStream.from_project(traj, frame)
    np.testing.assert_allclose(back.lat, utm_stream.lat, rtol=0, atol=1e-12)  # 6 micrometres
    np.testing.assert_allclose(back.lon, utm_stream.lon, rtol=0, atol=1e-12)
    np.testing.assert_allclose(back.h, utm_stream.h, rtol=0, atol=1e-6)
    for name in ("roll", "pitch", "heading"):
        np.testing.assert_allclose(getattr(back, name), getattr(utm_stream, name), rtol=0, atol=1e-10)
    # at the origin the project NED frame is the local one; elsewhere the heading turns by the
    # meridian convergence, about -dlon sin(lat) (north leans towards the origin's meridian)
    np.testing.assert_allclose(traj.angles_P[mid], [utm_stream.roll[mid], utm_stream.pitch[mid],
                                                    utm_stream.heading[mid]], atol=1e-12)
    for k in (0, len(utm_stream) - 1):
        convergence = -(utm_stream.lon[k] - frame.lon0) * np.sin(frame.lat0)
        turn = traj.angles_P[k, 2] - utm_stream.heading[k]
        assert abs(convergence) > 2e-4
        assert turn == pytest.approx(convergence, rel=0.02)


# --------------------------------------------------------------------------------- lever arm
def level_stream(heading_deg: float, n: int = 3) -> GpsImuStream:
    lat, lon = np.radians(47.0), np.radians(16.0)
    z = np.zeros(n)
    return GpsImuStream(np.arange(n) * 0.01, z + lat, z + lon, z + 1000.0, z, z, z + np.radians(heading_deg))


@pytest.mark.parametrize("heading_deg, expected_enu", [
    (0.0, (2.0, 1.0, -3.0)),    # forward = north, right = east, down = -up
    (90.0, (1.0, -2.0, -3.0)),  # forward = east, right = south
    (180.0, (-2.0, -1.0, -3.0)),
])
def test_lever_arm_on_a_level_sample(heading_deg, expected_enu):
    stream = level_stream(heading_deg)
    frame = ProjectFrame(float(stream.lat[0]), float(stream.lon[0]), 1000.0)
    traj = stream.to_project(frame)
    np.testing.assert_allclose(traj.p_P[0], 0.0, atol=1e-6)
    lever_B = np.array([1.0, 2.0, 3.0])  # forward, right, down (m)
    p_S = traj.sensor_positions(lever_B)
    np.testing.assert_allclose(p_S[0] - traj.p_P[0], expected_enu, atol=1e-9)


def test_lever_arm_with_roll():
    """A 30 deg roll (right wing down), heading north: the body's down axis leans west (left)."""
    stream = level_stream(0.0)
    stream = GpsImuStream(stream.time, stream.lat, stream.lon, stream.h, np.full(3, np.radians(30.0)),
                          stream.pitch, stream.heading)
    frame = ProjectFrame(float(stream.lat[0]), float(stream.lon[0]), 1000.0)
    p_S = stream.to_project(frame).sensor_positions(np.array([0.0, 0.0, 2.0]))
    np.testing.assert_allclose(p_S[0], [-2.0 * np.sin(np.radians(30.0)), 0.0, -2.0 * np.cos(np.radians(30.0))],
                               atol=1e-9)
