"""``scangeo info`` and scangeo.io.summary: trajectories, DTMs, images, point files, projects."""
from __future__ import annotations

import json
import re
import shutil
import struct

import numpy as np
import pyproj
import pytest
import rasterio
from affine import Affine

from scangeo.cli import main
from scangeo.errors import InputFileError, ScangeoError
from scangeo.io.summary import detect_kind, summarise, summary_text

from ..conftest import shared_file


def info_json(capsys, *argv) -> dict:
    assert main(["info", *map(str, argv), "--json"]) == 0
    return json.loads(capsys.readouterr().out)


# ------------------------------------------------------------------------------------ trajectories
def test_trajectory_csv(tiny_project, capsys):
    info = tiny_project
    s = info_json(capsys, info.root / "nav" / "1.csv")
    assert s["kind"] == "trajectory" and s["format"] == "csv"
    assert s["records"] == 3001 and s["rate_hz"] == 50.0
    assert s["time_s"] == {"start": 1000.0, "end": 1060.0, "duration": 60.0}
    assert s["largest_gap_s"] == pytest.approx(0.02)
    to_geo = pyproj.Transformer.from_crs(info.crs, "EPSG:4326", always_xy=True)
    lon, lat = to_geo.transform([info.x0, info.x0], info.northing("1", np.array([1000.0, 1060.0])))
    assert s["lat_deg"]["min"] == pytest.approx(lat[0], abs=1e-9)
    assert s["lat_deg"]["max"] == pytest.approx(lat[1], abs=1e-9)
    assert s["lon_deg"] == {"min": 15.0, "max": 15.0}
    assert s["h_m"] == {"min": info.flight_h, "max": info.flight_h}
    assert s["heading_deg"] == {"min": 0.0, "max": 0.0} and s["roll_deg"] == {"min": 0.0, "max": 0.0}
    # 3000 m of grid northing = 3000 / k0 on the ellipsoid, longer at flying height (R ~ 6.37e6 m)
    assert s["length_m"] == pytest.approx(3000.0 / 0.9996 * (1 + info.flight_h / 6.37e6), abs=0.01)


def test_trajectory_map_csv_needs_a_crs(tiny_project, capsys):
    path = tiny_project.root / "nav" / "2.csv"
    assert main(["info", str(path)]) == 1
    assert "--crs" in capsys.readouterr().err
    s = info_json(capsys, path, "--crs", tiny_project.crs)
    assert s["records"] == 3001
    assert s["heading_deg"] == {"min": 180.0, "max": 180.0}


def test_sbet_and_its_bytes(tmp_path):
    path = shared_file("sbet/2-points.sbet")
    data = path.read_bytes()
    t0, t1 = struct.unpack_from("<d", data, 0)[0], struct.unpack_from("<d", data, 136)[0]
    s = summarise(path)
    assert s["format"] == "sbet" and s["records"] == 2
    assert s["time_s"]["start"] == round(t0, 6) and s["time_s"]["end"] == round(t1, 6)
    # an SBET under another name is recognised by its content (binary, 136-byte records)
    copy = tmp_path / "nav.bin"
    shutil.copy(path, copy)
    assert detect_kind(copy) == "trajectory" and summarise(copy)["records"] == 2


def test_real_trajectory_summary(capsys):
    path = shared_file("trajectory/sbet_047_IGS08-UTM15N-Ellipsoid-trim.txt")
    s = info_json(capsys, path, "--crs", "EPSG:32615")
    assert s["records"] == 14600 and s["rate_hz"] == pytest.approx(200.0)
    assert s["time_s"]["start"] == 407106.003323 and s["time_s"]["end"] == 407178.999343
    rows = np.loadtxt(path, delimiter=",", skiprows=1)
    assert s["h_m"] == {"min": round(rows[:, 3].min(), 3), "max": round(rows[:, 3].max(), 3)}
    assert s["roll_deg"]["min"] == pytest.approx(rows[:, 4].min(), abs=1e-4)
    assert s["pitch_deg"]["max"] == pytest.approx(rows[:, 5].max(), abs=1e-4)
    azimuth = rows[:, 6] % 360  # the flight heads west: 258 .. 273 deg
    assert s["heading_deg"]["min"] == pytest.approx(azimuth.min(), abs=1e-4)
    assert s["heading_deg"]["max"] == pytest.approx(azimuth.max(), abs=1e-4)
    assert 60 < s["speed_mps"] < 75


# ------------------------------------------------------------------------------------ rasters
def test_dtm_with_nodata(tmp_path, capsys):
    values = np.arange(20 * 10, dtype="float32").reshape(20, 10)
    values[:5, :5] = -9999.0  # 25 of 200 cells
    path = tmp_path / "dtm.tif"
    with rasterio.open(path, "w", driver="GTiff", width=10, height=20, count=1, dtype="float32",
                       crs="EPSG:31256", transform=Affine(2.5, 0, 1000.0, 0, -5.0, 2000.0), nodata=-9999.0) as dst:
        dst.write(values, 1)
    s = info_json(capsys, path)
    assert s["kind"] == "dtm" and (s["width"], s["height"]) == (10, 20)
    assert s["epsg"] == 31256 and s["resolution"] == [2.5, 5.0]
    assert s["bounds"] == [1000.0, 1900.0, 1025.0, 2000.0]
    assert s["nodata_fraction"] == 0.125
    valid = values[values != -9999.0]
    assert s["height_m"] == {"min": 5.0, "max": 199.0, "mean": round(float(valid.mean()), 3)}


def test_srtm_tile():
    path = shared_file("dtm/N44E005.hgt")
    s = summarise(path)
    assert s["kind"] == "dtm" and (s["width"], s["height"]) == (1201, 1201) and s["epsg"] == 4326
    assert s["resolution"][0] == pytest.approx(1 / 1200)
    raw = np.fromfile(path, dtype=">i2")  # an .hgt tile: big-endian int16, -32768 = void
    assert raw.size == 1201 * 1201
    valid = raw[raw != -32768]
    assert s["height_m"]["min"] == valid.min() and s["height_m"]["max"] == valid.max()
    assert s["nodata_fraction"] == round(1 - valid.size / raw.size, 6) > 0


def test_image(tiny_project, capsys):
    s = info_json(capsys, tiny_project.root / "images" / "1.tif")
    assert s["kind"] == "image"
    assert (s["lines"], s["pixels"], s["bands"], s["dtype"]) == (400, 101, 3, "uint8")
    assert s["crs"] is None
    assert main(["info", str(tiny_project.root / "images" / "1.tif")]) == 0
    text = capsys.readouterr().out
    assert text.startswith("image: ")
    assert re.search(r"^ +lines +400$", text, re.M) and re.search(r"^ +bands +3$", text, re.M)


# ------------------------------------------------------------------------------------ projects
def test_project_with_points(tiny_project, capsys):
    root = tiny_project.root
    (root / "points.csv").write_text("point,strip,line,pixel\na,1,10,20\na,2,30,40\nb,1,50,60\n")
    (root / "ground.csv").write_text(
        "point,x,y,z,sigma_xy,sigma_z,role\n"
        "a,500000,5300000,200,0.1,0.1,control\nc,500100,5300100,200,0.1,0.1,check\n"
        "d,500200,5300100,200,0.1,0.1,control\n"
    )
    for target in (root, root / "project.toml"):
        s = info_json(capsys, target)
        assert s["kind"] == "project" and s["crs"] == "EPSG:32633" and s["geoid"] == "constant 45 m"
        assert s["sensor"]["kind"] == "whiskbroom" and s["sensor"]["pixels"] == 101
        assert s["sensor"]["fov_deg"] == 40.0 and s["sensor"]["line_rate_hz"] == 10.0
        assert s["dtm"]["height_m"]["min"] == 200.0
        strips = {st["id"]: st for st in s["strips"]}
        assert strips["1"]["lines"] == 400 and strips["2"]["lines"] == 400  # from the image / from lines
        assert strips["1"]["line_time_s"] == {"start": 1010.0, "end": 1049.9}
        assert strips["1"]["trajectory_time_s"] == {"start": 1000.0, "end": 1060.0}
        assert strips["1"]["covered"] and strips["2"]["trajectory_records"] == 3001
        assert s["points"]["measurements"] == 3 and s["points"]["per_strip"] == {"1": 2, "2": 1}
        assert s["ground"]["per_role"] == {"check": 1, "control": 2}
    text = summary_text(summarise(root))
    assert "- id 1" in text and "covered             True" in text


def test_project_strip_problems_are_reported_not_fatal(tiny_project):
    root = tiny_project.root
    (root / "nav" / "2.csv").unlink()
    toml = root / "project.toml"
    toml.write_text(toml.read_text().replace("first_line_time = 1010.0\n", "first_line_time = 1055.0\n", 1))
    s = summarise(root)
    strips = {st["id"]: st for st in s["strips"]}
    assert not strips["1"]["covered"]  # lines until 1094.9 s, trajectory until 1060 s
    assert "nav/2.csv" in strips["2"]["error"] and "cannot read" in strips["2"]["error"]


# ------------------------------------------------------------------------------------ detection
def test_detection_and_errors(tmp_path, capsys):
    folder = tmp_path / "empty"
    folder.mkdir()
    with pytest.raises(InputFileError, match="without project.toml"):
        summarise(folder)
    with pytest.raises(InputFileError, match="no such file"):
        summarise(tmp_path / "absent.csv")
    junk = tmp_path / "junk.dat"
    junk.write_bytes(b"\x00\x01\x02" * 7)
    with pytest.raises(InputFileError, match="cannot tell what this is"):
        summarise(junk)
    text = tmp_path / "nav.dat"
    text.write_text("time,lat,lon,h,roll,pitch,heading\n0,47,16,1,0,0,0\n1,47,16,1,0,0,0\n")
    assert detect_kind(text) == "trajectory" and summarise(text)["records"] == 2
    bad = tmp_path / "bad.csv"
    bad.write_text("time,lat,lon,h,roll,pitch,heading\n0,47,16,1,0,0,0\n0,47,16,1,0,0,0\n")
    assert main(["info", str(bad)]) == 1
    assert f"{bad} line 3: time 0.000000 repeats the previous" in capsys.readouterr().err
    with pytest.raises(ScangeoError, match="unknown kind"):
        summarise(bad, kind="lidar")


def test_the_cli_lists_the_kinds_the_summary_knows():
    from scangeo.cli.info import KINDS
    from scangeo.io.summary import KINDS as SUMMARY_KINDS

    assert KINDS == SUMMARY_KINDS
