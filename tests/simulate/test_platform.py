"""Simulated platforms: several sensors on one GPS/IMU, each flight line flown once and recorded by every sensor.

The presets' fast versions (``pushbroom_pair_quick``, ``platform_quick``) load as platform projects, their
strips share their flight line's trajectory, the points are measured as the keys say, and the truth is
consistent: ground -> image -> ground through each sensor's true orientation, the rendered bands are the
scene's at the pixels' true ground points, and the laser's returns lie on the true terrain.
"""
from __future__ import annotations

import csv
import dataclasses
import json
import warnings

import laspy
import numpy as np
import pytest
import rasterio

from scangeo.cli import main
from scangeo.dtm import DTM
from scangeo.errors import ProjectFileError
from scangeo.io.project import LaserSensor, Project
from scangeo.lidar.georeference import Calibration, TrajectorySampler, georeference, recover
from scangeo.rotation import matrix_to_rph, rph_to_matrix
from scangeo.simulate.block import simulate
from scangeo.simulate.config import load_preset
from scangeo.simulate.scene import dn_to_uint16, to_dn
from scangeo.trajectory.readers import read_trajectory
from scangeo.truth.true_error import Truth


def _rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def test_the_pair_loads_as_a_platform_of_two_pushbrooms(pair_block):
    project = Project.load(pair_block.root)
    assert project.is_platform and list(project.sensors) == ["vnir", "swir"]
    vnir, swir = project.sensors["vnir"], project.sensors["swir"]
    assert (vnir.model.pixels, swir.model.pixels) == (1800, 384)
    assert vnir.line_rate == pytest.approx(250 / 3) and swir.line_rate == pytest.approx(125 / 3)
    assert np.degrees(swir.mounting.boresight) == pytest.approx([-1.5, 0.5, -0.2])  # the nominal, as configured
    assert swir.mounting.lever_arm_B - vnir.mounting.lever_arm_B == pytest.approx([0.0, -0.15, 0.02])
    assert vnir.bands[-1] == swir.bands[0] == "ch8_nir" and len(vnir.bands) == 8 and len(swir.bands) == 3
    assert list(project.flight_lines) == ["01", "02", "03"]
    for fl in project.flight_lines.values():
        assert fl.strips == (f"vnir-{fl.id}", f"swir-{fl.id}")
        assert fl.trajectory == project.root / "nav" / f"{fl.id}.csv"
        a, b = project.timing(f"vnir-{fl.id}"), project.timing(f"swir-{fl.id}")
        assert a.first_line_time == b.first_line_time
        # 800 VNIR lines at 83.33 Hz, 400 SWIR lines at 41.67 Hz: the SWIR's last line within the VNIR's
        assert (project.n_lines(f"vnir-{fl.id}"), project.n_lines(f"swir-{fl.id}")) == (800, 400)
        assert a.first_line_time + 799 / a.line_rate - (b.first_line_time + 399 / b.line_rate) == pytest.approx(
            1.0 / a.line_rate)  # one VNIR line: 799 = 2 x 399 + 1


def test_info_shows_the_platform_and_the_strips_sharing_each_flight_line(pair_block, capsys):
    assert main(["info", str(pair_block.root)]) == 0
    text = capsys.readouterr().out
    assert text.startswith("platform project")
    assert "vnir-02, swir-02" in text and "relative" in text


def test_ground_image_ground_through_each_sensors_true_orientation(pair_block):
    """The truth reader's geometries (truth/trajectory per flight line, the true boresight per sensor) put the
    true points where the simulator measured them without noise, and take them back to the ground."""
    truth = Truth.load(Project.load(pair_block.root))
    points = {r["point"]: r for r in _rows(pair_block.root / "truth" / "points.csv")}
    measured = _rows(pair_block.root / "truth" / "measurements.csv")
    for sid, g in truth.geometries.items():
        rows = [m for m in measured if m["strip"] == sid]
        assert len(rows) > 20
        p_P = np.array([[float(points[m["point"]][k]) for k in ("x_P", "y_P", "z_P")] for m in rows])
        line, pixel, status = g.ground_to_image(p_P)
        assert np.all(status == 0)
        # the true points are written to 0.1 mm: a thousandth of a VNIR pixel (0.12 m across, 0.48 m along)
        assert np.abs(line - [float(m["line_true"]) for m in rows]).max() < 2e-3
        assert np.abs(pixel - [float(m["pixel_true"]) for m in rows]).max() < 5e-3
        back, status = g.image_to_ground(line, pixel, truth.terrain)
        assert np.all(status == 0) and np.abs(back - p_P).max() < 1e-3  # m: on the true terrain (float32 heights)
        l2, p2, _ = g.ground_to_image(back)
        assert np.abs(l2 - line).max() < 1e-6 and np.abs(p2 - pixel).max() < 1e-6


def test_a_sensor_without_control_sees_check_and_tie_points_only(pair_block):
    rows = _rows(pair_block.root / "points.csv")
    kinds = {"vnir": set(), "swir": set()}
    for r in rows:
        kinds[r["strip"].split("-")[0]].add(r["point"][0])
    assert kinds["vnir"] == {"E", "B", "H", "K", "T"} and kinds["swir"] == {"K", "T"}
    # ties between the two sensors of one flight line: a tie point measured by both on the same flight line
    seen: dict[tuple[str, str], set[str]] = {}
    for r in rows:
        sensor, line = r["strip"].split("-")
        seen.setdefault((r["point"], line), set()).add(sensor)
    between = {p for (p, line), s in seen.items() if s == {"vnir", "swir"} and p.startswith("T")}
    assert len(between) >= 3 * 12 * 0.8  # tie_per_flight_line = 12 on each of the 3 flight lines


def test_the_relative_mounting_prior_is_the_true_one_within_its_noise(pair_block):
    info = json.loads((pair_block.root / "truth" / "errors.json").read_text())
    true = info["true_boresight_deg"]
    assert true["swir"] == pytest.approx(np.add([-1.5, 0.5, -0.2], [-0.04, 0.03, 0.05]).tolist())
    R_rel = rph_to_matrix(*np.radians(true["vnir"])).T @ rph_to_matrix(*np.radians(true["swir"]))
    expected = np.degrees(matrix_to_rph(R_rel))
    (rel,) = info["true_relative_mountings"]
    assert rel["boresight_deg"] == pytest.approx(expected, abs=1e-12)
    (prior,) = Project.load(pair_block.root).relative_mountings
    assert (prior.sensor, prior.reference) == ("swir", "vnir")
    assert np.degrees(prior.boresight_sigma) == pytest.approx([0.005, 0.005, 0.01])
    z = (np.degrees(prior.boresight) - expected) / np.degrees(prior.boresight_sigma)
    assert np.all(np.abs(z) < 5) and np.any(z != 0)  # noise of its sigma, not the truth itself
    z = (prior.lever_arm - np.subtract(info["true_lever_arm_m"]["swir"], info["true_lever_arm_m"]["vnir"])) / 0.01
    assert np.all(np.abs(z) < 5) and np.any(z != 0)


def test_each_sensor_renders_its_bands_of_the_same_ground(tmp_path):
    """One flight line with images: each pixel holds the scene's values of the sensor's bands at the pixel's true
    ground point (no noise), and the band both record (ch8) is the same ground in both."""
    config = load_preset("pushbroom_pair_quick", {"flight": {"strips": 1, "lines": 80},
                                                   "gpsimu_errors": {"problem_strip": 0, "breaks_lines": [],
                                                                     "strip": []}})
    block = simulate(tmp_path / "pair", config)
    true_dtm = DTM(block.terrain.true, block.map_frame)
    rng = np.random.default_rng(5)
    for sim, bands in zip(block.strips, ([1, 2, 3, 4, 5, 6, 7, 8], [8, 9, 10])):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)
            with rasterio.open(block.root / "images" / f"{sim.strip_id}.tif") as src:
                assert (src.count, src.height, src.width) == (len(bands), sim.geometry.n_lines,
                                                              sim.geometry.sensor.pixels)
                assert src.descriptions[-1 if bands[-1] == 8 else 0].startswith("ch8_nir")
                image = src.read()
        lines = rng.integers(0, sim.geometry.n_lines, 300).astype(float)
        pixels = rng.integers(0, sim.geometry.sensor.pixels, 300).astype(float)
        ground, status = sim.geometry.image_to_ground(lines, pixels, true_dtm)
        assert np.all(status == 0)
        x, y, _ = block.map_frame.project_to_map(ground)
        expected = dn_to_uint16(to_dn(block.scene.values(x, y)))[:, np.array(bands) - 1]
        assert np.array_equal(image[:, lines.astype(int), pixels.astype(int)].T, expected)


def test_the_platform_flies_a_laser_and_a_pushbroom_on_each_flight_line(platform_block):
    project = Project.load(platform_block.root)
    assert isinstance(project.sensors["lidar"], LaserSensor) and project.sensors["nis"].kind == "pushbroom"
    for fl in project.flight_lines.values():
        assert fl.strips == (f"nis-{fl.id}", f"lidar-{fl.id}")
    span = {s.flight_line: (project.timing(s.id).first_line_time, project.timing(s.id).first_line_time
                            + (project.n_lines(s.id) - 1) / project.timing(s.id).line_rate)
            for s in project.image_strips}
    nav_span = {k: read_trajectory(f.trajectory, crs=project.crs).time[[0, -1]]
                for k, f in project.flight_lines.items()}
    for s in project.laser_strips:
        with laspy.open(str(s.las[0])) as f:
            las = f.read()
        t = np.asarray(las.gps_time)
        # a pulse every 1/40,000 s over the 5.99 s of the imager's 600 lines, every one on the terrain; GPS times
        # covered by the flight line's trajectory
        assert t.size == 599 * 400 + 1 and t[0] == span[s.flight_line][0]
        assert t[-1] <= span[s.flight_line][1] + 1e-9 and nav_span[s.flight_line][0] < t[0] < t[-1] < nav_span[
            s.flight_line][1]
        assert set(np.unique(las.point_source_id)) == {int(s.flight_line)}


def test_control_on_one_third_of_the_flight_lines(platform_block):
    """The image control and height points are measured on flight line 02 only (check and tie points on all), the
    laser's control patches lie in its zone."""
    rows = _rows(platform_block.root / "points.csv")
    control = {r["strip"] for r in rows if r["point"][0] in "EBH"}
    assert control == {"nis-02"}
    assert {r["strip"] for r in rows if r["point"][0] == "K"} == {"nis-01", "nis-02", "nis-03"}
    patches = _rows(platform_block.root / "patches.csv")
    x_02 = platform_block.plan.strips[1].x
    half = platform_block.plan.spacing_m / 2
    c = [float(r["x"]) for r in patches if r["role"] == "control"]
    assert len(c) == 4 * 8 and all(abs(x - x_02) <= half + 3 for x in c)
    assert {round((float(r["x"]) - x_02) / platform_block.plan.spacing_m) for r in patches if r["role"] == "check"} == {
        -1, 0, 1}


def test_the_laser_returns_lie_on_the_true_terrain_through_the_true_orientation(tmp_path):
    """Each LAS point (from the measured GPS/IMU and the nominal calibration) taken back to its range and scan angle
    and through the flight line's true trajectory and the laser's true calibration lands on the true terrain: to
    a millimetre without range noise; the measured points are off by the flight line's GPS/IMU errors."""
    config = load_preset("platform_quick", {"flight": {"strips": 1, "lines": 100},
                                             "output": {"images": False, "truth_ortho": False},
                                             "platform": {"control_flight_lines": []}})
    sensors = tuple(dataclasses.replace(s, range_sigma_m=1e-9) if s.kind == "laser" else s
                    for s in config.platform.sensors)
    block = simulate(tmp_path / "laser", dataclasses.replace(config, platform=dataclasses.replace(
        config.platform, sensors=sensors)))
    project = Project.load(block.root)
    frame = project.map_frame
    info = json.loads((block.root / "truth" / "errors.json").read_text())
    terrain = DTM.open(block.root / "truth" / "terrain.tif", frame)
    (strip,) = project.laser_strips
    sensor = project.sensors["lidar"]
    las = laspy.read(str(strip.las[0]))
    p_las = frame.map_to_project(np.asarray(las.x), np.asarray(las.y), np.asarray(las.z))
    measured = TrajectorySampler(read_trajectory(project.flight_lines["01"].trajectory, crs=project.crs)
                                 .to_project(frame.frame))
    polar = recover(p_las, np.asarray(las.gps_time), measured, Calibration.of(np.radians(sensor.boresight_deg),
                                                                                sensor.lever_arm_m))
    true = Truth.load(project).geometries["nis-01"].spline.evaluate(polar.time)  # the flight line's truth
    cal = Calibration.of(np.radians(info["true_boresight_deg"]["lidar"]), info["true_lever_arm_m"]["lidar"])
    x, y, h = frame.project_to_map(georeference(true[:, :3], true[:, 3:], polar, cal))
    dh = h - terrain.height_at_map(x, y)
    # the LAS holds millimetres (each coordinate rounded by up to 0.5 mm, on slopes up to 0.3)
    assert np.sqrt(np.mean(dh**2)) < 1e-3 and np.abs(dh).max() < 2.5e-3
    dz = np.asarray(las.z) - terrain.height_at_map(np.asarray(las.x), np.asarray(las.y))
    assert np.sqrt(np.mean(dz**2)) > 0.05  # the GPS/IMU errors (datum shift 0.3-1 m, offsets, drift)


def test_platform_keys_are_checked_and_name_the_key():
    base = {"output": {"images": False}}
    sensors = [{"id": "a", "kind": "pushbroom", "pixels": 100}, {"id": "b", "kind": "laser"}]
    with pytest.raises(ProjectFileError, match=r"\[sensor\].*not both"):
        load_preset("small", {**base, "platform": {"sensors": sensors}})
    with pytest.raises(ProjectFileError, match=r"relative_mountings.*'c'"):
        load_preset("pushbroom_pair", {"platform": {"relative_mountings": [{"sensor": "c", "reference": "vnir"}]}})
    with pytest.raises(ProjectFileError, match=r"control_flight_lines.*4 is not a flight line"):
        load_preset("pushbroom_pair", {"platform": {"control_flight_lines": [4]}})
    with pytest.raises(ProjectFileError, match=r"unique, non-empty id"):
        load_preset("pushbroom_pair", {"platform": {"sensors": [sensors[0], {**sensors[0]}]}})
    with pytest.raises(ProjectFileError, match=r"at least one line scanner"):
        load_preset("pushbroom_pair", {"platform": {"sensors": [sensors[1]]}})
    with pytest.raises(ProjectFileError, match=r"need \[\[platform.sensors\]\]"):
        load_preset("small", {"platform": {"tie_per_flight_line": 3}})


def test_a_preset_extends_another(tmp_path):
    mine = tmp_path / "mine.toml"
    mine.write_text('extends = "pushbroom_pair_quick"\n[flight]\nstrips = 2\n')
    config = load_preset(mine)
    assert config.flight.strips == 2 and config.flight.lines == 800 and [s.id for s in config.platform.sensors] == [
        "vnir", "swir"]
    loop = tmp_path / "loop.toml"
    loop.write_text(f'extends = "{loop}"\n')
    with pytest.raises(ProjectFileError, match=r"\[extends\].*extends itself"):
        load_preset(loop)


def test_simulate_and_info_on_a_laser_and_a_pushbroom(tmp_path, capsys):
    out = tmp_path / "platform"
    assert main(["simulate", str(out), "--preset", "platform_quick", "--no-images", "--set", "flight.strips=1",
                 "--set", "flight.lines=100", "--set", "platform.control_flight_lines=[]"]) == 0
    text = capsys.readouterr().out
    # a pulse every 1/40,000 s over the 0.99 s of the imager's 100 lines
    assert ("flight lines: 01, each recorded by nis (pushbroom, 100 lines x 480 pixels), lidar (laser, 39601 returns"
            in text)
    assert main(["info", str(out)]) == 0
    text = capsys.readouterr().out
    assert "nis-01, lidar-01" in text and "kind           laser" in text
