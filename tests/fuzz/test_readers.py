"""Every reader of a user's file, fed random corruptions of a valid file.

A reader either returns or raises one of scangeo's own errors (ScangeoError): never a raw exception.
The ``ci`` profile runs 200 examples per reader (tests/fuzz/profile.py).
"""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given

from scangeo.errors import ScangeoError
from tests.fuzz.corrupt import corrupted
from tests.fuzz.profile import FUZZ


def trajectory_csv(n: int = 25) -> bytes:
    t = 1000.0 + np.arange(n) * 0.02
    rows = [f"{ti:.3f},{48.2 + 1e-5 * i:.9f},{16.3:.9f},1500.0,0.5,-0.3,{10.0 + 0.1 * i:.3f}"
            for i, ti in enumerate(t)]
    return ("time,lat,lon,h,roll,pitch,heading\n" + "\n".join(rows) + "\n").encode()


def sbet(n: int = 12) -> bytes:
    from scangeo.trajectory.readers import SBET_RECORD

    rec = np.zeros(n, dtype=SBET_RECORD)
    rec["time"] = 5000.0 + np.arange(n) * 0.005
    rec["lat"], rec["lon"], rec["alt"] = 0.84, 0.28, 1500.0
    return rec.tobytes()


POINTS = b"point,strip,line,pixel,sigma_px\nA,1,10.5,20.25,0.3\nA,2,11.0,80.0,0.3\nB,1,100,50,\nB,2,101,51,0.5\n"
GROUND = (b"point,x,y,z,sigma_xy,sigma_z,role\nA,500000.0,5300000.0,200.0,0.05,0.08,control\n"
          b"B,500100.0,5300100.0,201.5,0.05,0.08,check\nC,500200,5300200,199,1,0.1,height\n")
PROJECT = b"""[project]
crs = "EPSG:32633"
dtm = "dtm.tif"
geoid_undulation_m = 45.0
knot_spacing_s = 0.2

[sensor]
kind = "whiskbroom"
pixels = 101
fov_deg = 40.0
line_rate_hz = 10.0
lever_arm_m = [0.1, 0.2, -0.3]
boresight_deg = [0.0, 0.0, 0.0]

[[strips]]
id = "1"
image = "images/1.tif"
trajectory = "nav/1.csv"
first_line_time = 1010.0

[[strips]]
id = "2"
trajectory = "nav/2.csv"
first_line_time = 1010.0
lines = 400
"""
VARIANTS = b"""[defaults]
snooping = true

[variants.SE]
strategy = "SE"
position_degree = 1
gps_sigma_m = [0.1, 0.1, 0.2]
roles = { "C*" = "check" }

[[variants.SE.strip]]
id = "2"
breaks_lines = [100.0, 200.0]

[variants.DG]
strategy = "DG"
snooping = false
"""
LINE_TIMES = b"line,time\n0,1000.0\n1,1000.1\n2,1000.2\n3,1000.31\n4,1000.4\n"


def _run(path, data: bytes, read) -> None:
    path.write_bytes(data)
    try:
        read(path)
    except ScangeoError:
        pass


@FUZZ
@given(data=corrupted(trajectory_csv()))
def test_trajectory_csv(tmp_path, data):
    from scangeo.trajectory.readers import read_trajectory

    _run(tmp_path / "nav.csv", data, read_trajectory)


@FUZZ
@given(data=corrupted(sbet()))
def test_sbet(tmp_path, data):
    from scangeo.trajectory.readers import read_trajectory

    _run(tmp_path / "nav.out", data, read_trajectory)


@FUZZ
@given(data=corrupted(POINTS))
def test_points(tmp_path, data):
    from scangeo.io.points import ImagePoints

    _run(tmp_path / "points.csv", data, ImagePoints.read)


@FUZZ
@given(data=corrupted(GROUND))
def test_ground(tmp_path, data):
    from scangeo.io.points import GroundPoints

    _run(tmp_path / "ground.csv", data, GroundPoints.read)


@FUZZ
@given(data=corrupted(PROJECT))
def test_project_toml(tmp_path, data):
    from scangeo.io.project import Project

    _run(tmp_path / "project.toml", data, Project.load)


@FUZZ
@given(data=corrupted(VARIANTS))
def test_variants_toml(tmp_path, data):
    from scangeo.adjustment.variants import read_variants

    _run(tmp_path / "variants.toml", data, read_variants)


@FUZZ
@given(data=corrupted(LINE_TIMES))
def test_line_times(tmp_path, data):
    from scangeo.timing import LineTiming

    _run(tmp_path / "times.csv", data, LineTiming.from_table_file)


@pytest.fixture(scope="module")
def preset_bytes() -> bytes:
    from scangeo.simulate.config import preset_path

    return preset_path("small").read_bytes()


@FUZZ
@given(edit=corrupted(b"0123456789"))
def test_preset_toml(tmp_path, preset_bytes, edit):
    """A user preset: the small preset with a corruption at a position drawn from ``edit``'s bytes."""
    from scangeo.simulate.config import load_preset

    at = int.from_bytes(edit[:4].ljust(4, b"\0"), "little") % len(preset_bytes)
    _run(tmp_path / "preset.toml", preset_bytes[:at] + edit + preset_bytes[at:], load_preset)


def las_bytes(point_format: int = 1, version: str = "1.2", compress: bool = False) -> bytes:
    import io

    import laspy

    las = laspy.create(point_format=point_format, file_version=version)
    las.header.offsets = [600000.0, 5340000.0, 0.0]
    las.header.scales = [0.01, 0.01, 0.01]
    las.x = 600000.0 + np.arange(8.0)
    las.y = np.full(8, 5340000.0)
    las.z = np.full(8, 200.0)
    las.gps_time = 1000.0 + np.arange(8.0)
    las.point_source_id = np.full(8, 3, dtype=np.uint16)
    buffer = io.BytesIO()
    las.write(buffer, do_compress=compress)
    return buffer.getvalue()


def _read_las(path) -> None:
    """What the laser adjustment does with a strip file: the header checks, then every return."""
    from scangeo.lidar import lasio

    with lasio._open(path) as f:
        lasio.check_header(path, f.header, None)
    lasio.read_strip("3", [path])


@FUZZ
@given(data=corrupted(las_bytes()))
def test_las_header(tmp_path, data):
    """LAS 1.2, point format 1 (uncompressed): corrupted counts, offsets and lengths."""
    _run(tmp_path / "strip.las", data, _read_las)


@FUZZ
@given(data=corrupted(las_bytes(point_format=7, version="1.4", compress=True)))
def test_laz_header(tmp_path, data):
    """LAZ 1.4, point format 7 (layered chunks): the laszip VLR, the chunk table and the chunks' layer sizes."""
    _run(tmp_path / "strip.laz", data, _read_las)
