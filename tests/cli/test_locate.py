"""``scangeo locate`` and scangeo.locate on the tiny project: hand-checked points, round trips,
points without an answer, bad input files."""
from __future__ import annotations

import csv

import numpy as np
import pyproj
import pytest

from scangeo.cli import main
from scangeo.errors import ProjectFileError
from scangeo.io import Project
from scangeo.locate import (
    NO_HEIGHT,
    OUTSIDE_IMAGE,
    OUTSIDE_TRAJECTORY,
    image_to_map,
    locate_ground_file,
    locate_image_file,
    map_to_image,
)


def dt_pixel(info) -> float:
    """Whiskbroom time between pixels: one angular step of a mirror turning once per line."""
    return np.radians(info.fov_deg) / info.pixels / (2 * np.pi * info.line_rate)


def pixel_time(info, line, pixel):
    return (
        info.first_line_time
        + np.asarray(line, float) / info.line_rate
        + (np.asarray(pixel, float) - 50) * dt_pixel(info)
    )


def write_csv(path, header, rows):
    with open(path, "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(header)
        w.writerows(rows)
    return path


def read_csv(path):
    with open(path, newline="", encoding="utf-8") as f:
        rows = list(csv.reader(f))
    return rows[0], rows[1:]


def independent_ground_point(info, strip: str, line: float, pixel: float) -> tuple[float, float]:
    """Map x, y where a pixel's ray meets the surface h = ground_H + N, computed from scratch:
    aircraft position from the strip's definition, its NED frame from latitude/longitude, the ray
    in ECEF (pyproj), and a secant search on the ray length for the ellipsoidal height."""
    t = pixel_time(info, line, pixel)
    to_geo = pyproj.Transformer.from_crs(info.crs, "EPSG:4326", always_xy=True)
    to_ecef = pyproj.Transformer.from_crs("EPSG:4979", "EPSG:4978", always_xy=True)
    lon, lat = to_geo.transform(info.easting(strip), float(info.northing(strip, t)))
    origin = np.array(to_ecef.transform(lon, lat, info.flight_h))
    la, lo = np.radians(lat), np.radians(lon)
    north = np.array([-np.sin(la) * np.cos(lo), -np.sin(la) * np.sin(lo), np.cos(la)])
    east = np.array([-np.sin(lo), np.cos(lo), 0.0])
    down = np.array([-np.cos(la) * np.cos(lo), -np.cos(la) * np.sin(lo), -np.sin(la)])
    theta = (pixel - (info.pixels - 1) / 2) * np.radians(info.fov_deg) / info.pixels  # positive to the right
    right = east if strip == "1" else -east  # strip 1 flies north, strip 2 south
    d = np.sin(theta) * right + np.cos(theta) * down
    assert abs(d @ north) < 1e-12

    def height(lam):
        return to_ecef.transform(*(origin + lam * d), direction="INVERSE")[2] - (info.ground_H + info.undulation)

    a, b = 900.0, 1200.0
    for _ in range(30):
        fa, fb = height(a), height(b)
        if fb == fa:
            break
        a, b = b, b - fb * (b - a) / (fb - fa)
    lon_g, lat_g, _ = to_ecef.transform(*(origin + b * d), direction="INVERSE")
    x, y = to_geo.transform(lon_g, lat_g, direction="INVERSE")
    return float(x), float(y)


# ------------------------------------------------------------------------------------ geometry
@pytest.mark.parametrize("strip", ["1", "2"])
def test_nadir_pixel_lands_below_the_aircraft(tiny_project, strip):
    info = tiny_project
    project = Project.load(info.root)
    lines = np.array([0.0, 123.5, 399.0])
    xyz, reasons = image_to_map(project, strip, lines, np.full(3, 50.0))
    assert reasons == ["", "", ""]
    t = info.first_line_time + lines / info.line_rate  # the centre pixel is recorded at the line's time
    np.testing.assert_allclose(xyz[:, 0], info.easting(strip), atol=1e-3)
    np.testing.assert_allclose(xyz[:, 1], info.northing(strip, t), atol=1e-3)
    np.testing.assert_allclose(xyz[:, 2], info.ground_H, atol=1e-3)  # orthometric, geoid removed


@pytest.mark.parametrize("strip, pixel", [("1", 100.0), ("1", 0.0), ("1", 17.25), ("2", 100.0), ("2", 3.0)])
def test_off_nadir_pixels_against_an_independent_ray(tiny_project, strip, pixel):
    info = tiny_project
    project = Project.load(info.root)
    xyz, reasons = image_to_map(project, strip, [200.0], [pixel])
    x, y = independent_ground_point(info, strip, 200.0, pixel)
    assert reasons == [""]
    assert xyz[0, 0] == pytest.approx(x, abs=2e-3) and xyz[0, 1] == pytest.approx(y, abs=2e-3)
    # by hand: k0 H tan(theta) to the right of the track (true east for strip 1, true west for
    # strip 2), later pixels later along the track (the trajectories are straight in grid
    # coordinates); off the central meridian true east is turned by the meridian convergence.
    theta = np.radians(info.fov_deg) / info.pixels * (pixel - 50)
    across = 0.9996 * info.height_above_ground * np.tan(theta)
    sign = 1.0 if strip == "1" else -1.0
    lon, lat = pyproj.Transformer.from_crs(info.crs, "EPSG:4326", always_xy=True).transform(
        info.easting(strip), info.y0
    )
    gamma = np.radians(pyproj.Proj(info.crs).get_factors(lon, lat).meridian_convergence)
    assert (strip == "1") == (abs(gamma) < 1e-12)
    east = sign * across  # true-east offset of the ground point from the track
    t_line = info.first_line_time + 200.0 / info.line_rate
    dy = sign * info.speed * (pixel - 50) * dt_pixel(info) + east * np.sin(gamma)
    assert xyz[0, 0] - info.easting(strip) == pytest.approx(east * np.cos(gamma), abs=0.05)
    assert xyz[0, 1] - info.northing(strip, t_line) == pytest.approx(dy, abs=1e-3)


@pytest.mark.parametrize("strip", ["1", "2"])
def test_image_ground_image_round_trip(tiny_project, strip):
    project = Project.load(tiny_project.root)
    geometry = project.geometry(strip)
    L, J = np.meshgrid(np.linspace(0, 399, 21), np.linspace(0, 100, 11))
    line, pixel = L.ravel(), J.ravel()
    xyz, reasons = image_to_map(project, strip, line, pixel, geometry)
    assert all(r == "" for r in reasons) and np.isfinite(xyz).all()
    line2, pixel2, reasons2 = map_to_image(project, strip, xyz, geometry)
    assert all(r == "" for r in reasons2)
    assert np.abs(line2 - line).max() < 1e-4
    assert np.abs(pixel2 - pixel).max() < 1e-4


def test_points_without_an_answer(tiny_project):
    info = tiny_project
    project = Project.load(info.root)
    # image points outside the image
    xyz, reasons = image_to_map(project, "1", [-1.0, 400.0, 10.0, 10.0, 10.0], [50.0, 50.0, -0.6, 100.6, 100.4])
    assert reasons[:4] == [OUTSIDE_IMAGE] * 4 and reasons[4] == ""
    assert np.isnan(xyz[:4]).all() and np.isfinite(xyz[4]).all()
    ground = np.array(
        [
            [info.x0 + 1500.0, info.y0, info.ground_H],  # 1.5 km east of the track: outside the swath
            [info.x0, info.y0 + 1500.0, info.ground_H],  # under the trajectory's end, after the last line
            [info.x0 + 100.0, info.y0 + 3000.0, np.nan],  # no z and off the DTM
            [info.x0 + 100.0, info.y0, np.nan],  # z from the DTM
        ]
    )
    line, pixel, reasons = map_to_image(project, "1", ground)
    assert reasons == ["outside the swath", "not seen by the strip", NO_HEIGHT, ""]
    assert np.isnan(line[:3]).all() and np.isnan(pixel[:3]).all()
    # y0 is under line 200; pixel j is recorded (j - 50) dt_pixel after its line's time
    assert 50 < pixel[3] < 100
    assert line[3] == pytest.approx(200.0 - (pixel[3] - 50) * dt_pixel(info) * info.line_rate, abs=1e-4)


def test_lines_beyond_the_trajectory(tiny_project):
    """Strip 2 given 700 lines: lines after 500 (t > 1060 s) have no trajectory."""
    info = tiny_project
    toml = info.root / "project.toml"
    toml.write_text(toml.read_text().replace(f"lines = {info.lines}", "lines = 700"))
    project = Project.load(info.root)
    xyz, reasons = image_to_map(project, "2", [450.0, 650.0], [50.0, 50.0])
    assert reasons == ["", OUTSIDE_TRAJECTORY]
    assert np.isfinite(xyz[0]).all() and np.isnan(xyz[1]).all()
    t = info.first_line_time + 650.0 / info.line_rate
    line, pixel, reasons = map_to_image(project, "2", [[info.easting("2"), float(info.northing("2", t)), 200.0]])
    assert reasons == [OUTSIDE_TRAJECTORY] and np.isnan(line[0])


# ------------------------------------------------------------------------------------ files and CLI
def test_cli_image_to_ground_file(tiny_project, tmp_path):
    info = tiny_project
    src = write_csv(
        tmp_path / "img.csv",
        ["point", "line", "pixel", "note"],
        [["a", "200", "50", "x"], ["b", "0", "100", ""], ["c", "-5", "50", ""], ["a", "399", "0", ""]],
    )
    out = tmp_path / "out.csv"
    assert main(["locate", str(info.root), "--strip", "1", "--image", str(src), "-o", str(out)]) == 0
    assert not [p for p in tmp_path.iterdir() if "tmp" in p.name]  # no temporary left
    header, rows = read_csv(out)
    assert header == ["point", "line", "pixel", "x", "y", "z", "reason"]
    assert [r[0] for r in rows] == ["a", "b", "c", "a"]  # one row per input row, in order
    assert float(rows[0][3]) == pytest.approx(info.x0, abs=1e-3)
    assert float(rows[0][4]) == pytest.approx(info.y0, abs=1e-3)
    assert float(rows[0][5]) == pytest.approx(info.ground_H, abs=1e-3)
    assert rows[2][3:] == ["NaN", "NaN", "NaN", OUTSIDE_IMAGE]
    assert all(r[6] == "" for r in rows if r[0] != "c")


def test_cli_ground_to_image_from_a_ground_csv(tiny_project, tmp_path, capsys):
    info = tiny_project
    src = write_csv(
        tmp_path / "ground.csv",
        ["point", "x", "y", "z", "sigma_xy", "sigma_z", "role"],
        [
            ["g1", f"{info.x0}", f"{info.y0}", f"{info.ground_H}", "0.1", "0.1", "control"],
            ["g2", f"{info.x0 + 1500}", f"{info.y0}", f"{info.ground_H}", "0.1", "0.1", "check"],
            ["g3", f"{info.x0}", f"{info.y0 - 500}", "", "0.1", "0.1", "planimetric"],
        ],
    )
    assert main(["locate", str(info.root), "--strip", "1", "--ground", str(src)]) == 0
    captured = capsys.readouterr()
    lines = captured.out.strip().splitlines()
    assert lines[0] == "point,x,y,z,line,pixel,reason"
    g1, g2, g3 = (line.split(",") for line in lines[1:])
    assert float(g1[4]) == pytest.approx(200.0, abs=1e-4) and float(g1[5]) == pytest.approx(50.0, abs=1e-4)
    assert g2[4:] == ["NaN", "NaN", "outside the swath"]
    assert float(g3[3]) == pytest.approx(info.ground_H, abs=1e-4)  # z taken from the DTM
    assert float(g3[4]) == pytest.approx(100.0, abs=1e-4)  # 500 m south of line 200 at 50 m/s, 10 lines/s
    assert "1 of 3 points have no answer" in captured.err


@pytest.mark.parametrize(
    "text, expected",
    [
        ("point,line\na,1\n", "line 1: missing column pixel"),
        ("point,line,pixel\na,1,x\n", "line 2: pixel 'x' is not a number"),
        ("point,line,pixel\na,1,2\nb,1\n", "line 3: 2 fields, expected 3"),
        ("point,line,pixel\n", "no points after the header"),
        ("", "empty"),
    ],
)
def test_bad_image_point_files(tiny_project, tmp_path, text, expected):
    path = tmp_path / "img.csv"
    path.write_text(text)
    with pytest.raises(ProjectFileError) as err:
        locate_image_file(Project.load(tiny_project.root), "1", path)
    assert str(path) in str(err.value) and expected in str(err.value)


def test_bad_ground_point_file_and_strip(tiny_project, tmp_path, capsys):
    path = tmp_path / "g.csv"
    path.write_text("point,x,y,z\np,500000,nan,200\n")
    project = Project.load(tiny_project.root)
    with pytest.raises(ProjectFileError, match=r"g\.csv line 2: y is not finite"):
        locate_ground_file(project, "1", path)
    path.write_text("point,x,y,z\np,500000,5300000,200\n")
    with pytest.raises(ProjectFileError, match=r"no strip '7' \(strips: 1, 2\)"):
        locate_ground_file(project, "7", path)
    assert main(["locate", str(tiny_project.root), "--strip", "7", "--ground", str(path)]) == 1
    assert "no strip '7'" in capsys.readouterr().err
    with pytest.raises(SystemExit):  # exactly one of --image and --ground
        main(["locate", str(tiny_project.root), "--strip", "1", "--image", str(path), "--ground", str(path)])
