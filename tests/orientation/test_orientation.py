"""orientation.json: the adjusted orientation as a file, and the one builder of adjusted geometry.

A variant with a split GPS/IMU model and a calibrated boresight and scan scale is adjusted and
written; the geometry rebuilt from orientation.json alone (no adjustment objects: the project,
points.csv, ground.csv and the file) reproduces the variant's check-point residuals; ``locate
--variant`` answers with it; bad files are named with their key.
"""
from __future__ import annotations

import csv
import dataclasses
import json

import numpy as np
import pytest

from scangeo.adjustment.outputs import write_results
from scangeo.adjustment.results import run_variant
from scangeo.adjustment.variants import StripModels, Variant
from scangeo.cli import main
from scangeo.errors import OrientationFileError
from scangeo.io.points import GroundPoints, ImagePoints
from scangeo.io.project import Project
from scangeo.orientation.file import (
    SCHEMA,
    Orientation,
    SensorSetup,
    StripOrientation,
    direct_orientation,
    load_adjusted_geometry,
    load_orientation,
    read_orientation_file,
    strip_geometries,
    write_orientation,
)
from scangeo.sensors.models import Pushbroom
from scangeo.simulate.block import simulate
from scangeo.simulate.config import load_preset
from scangeo.timing import LineTiming

# no attitude corrections, so that the boresight is determined (not a per-strip roll offset)
VARIANT = Variant("S2CAL", "S", strips=(StripModels("01", position_degree=1, breaks_lines=(200.0,)),),
                  calibrate=("boresight", "scale_error"), attitude_degree=-1)


@pytest.fixture(scope="module")
def adjusted(tmp_path_factory):
    root = tmp_path_factory.mktemp("orientation") / "p"
    simulate(root, load_preset("small", {"output": {"images": False, "truth_ortho": False}}))
    ground = root / "ground.csv"  # sigma_xy 0 of height points is rejected by the reader; it plays no role
    ground.write_text(ground.read_text().replace(",0,0.1,height", ",1,0.1,height"))
    result = run_variant(root, VARIANT)
    write_results(result)
    return root, result


def test_geometry_from_the_file_alone_reproduces_the_check_residuals(adjusted):
    root, result = adjusted
    doc = read_orientation_file(root / "results" / VARIANT.name / "orientation.json")
    assert doc.variant == VARIANT.name and doc.adjusted and doc.calibrated == ("boresight", "scale_error")
    # only the project, its point files and orientation.json
    project = Project.load(root)
    points, ground = ImagePoints.read(root / "points.csv"), GroundPoints.read(root / "ground.csv")
    where = {str(p): i for i, p in enumerate(ground.point)}
    geometries = strip_geometries(doc)
    c = result.checks
    assert (c.status == 0).sum() > 20
    for k in range(c.point.size):
        sel = np.flatnonzero((points.point.astype(str) == c.point[k]) & (points.strip.astype(str) == c.strip[k]))[0]
        x, y, z = ground.xyz[where[c.point[k]]]
        p_P = project.map_frame.map_to_project(np.array([x]), np.array([y]), np.array([z]))
        line, pixel, status = geometries[c.strip[k]].ground_to_image(p_P)
        assert status[0] & ~16 == c.status[k]
        if c.status[k] == 0:
            assert abs((line[0] - points.line[sel]) - c.line[k]) < 1e-9
            assert abs((pixel[0] - points.pixel[sel]) - c.pixel[k]) < 1e-9


def test_the_file_holds_the_adjusted_values_in_si_units(adjusted):
    root, result = adjusted
    data = json.loads((root / "results" / VARIANT.name / "orientation.json").read_text())
    assert data["schema"] == SCHEMA and data["units"] == {"length": "m", "angle": "rad", "time": "s"}
    p = result.adjustment.parameters
    from scangeo.adjustment.keys import Boresight, Knots, ScanScale

    assert data["mounting"]["boresight"] == p[Boresight()].values.tolist()  # radians, exactly
    assert data["sensor"]["scale_error"] == float(p[ScanScale()].values[0]) != 0.0
    strip = next(s for s in data["strips"] if s["id"] == "01")
    assert np.array_equal(np.reshape(strip["spline"]["coefficients"], -1), p[Knots("01")].values)
    models = {m["id"]: m for m in data["gpsimu_models"]}
    assert set(models) == {"01.1", "01.2", "02"} and models["01.2"]["follows"] == "01.1"
    assert data["breaks"]["01"] == [models["01.2"]["t_start"]]
    assert models["01.2"]["names"][0] == "x1"  # the follower's constants are eliminated (continuity)
    # the correction function of the file is the adjustment's
    doc = read_orientation_file(root / "results" / VARIANT.name / "orientation.json")
    s = result.block.strips["01"]
    coef = {m.key: p[m.key].values for m in result.block.models}
    expected = result.block.models.correction("01", s.epochs, s.gpsimu[:, :3], coef)
    assert np.array_equal(doc.correction("01", s.epochs, s.gpsimu[:, :3]), expected)


def test_locate_with_a_variant_uses_its_orientation(adjusted, tmp_path):
    root, _ = adjusted
    project = Project.load(root)
    adj, dg = load_adjusted_geometry(project, VARIANT.name, "01"), load_adjusted_geometry(project, "DG", "01")
    (tmp_path / "img.csv").write_text("point,line,pixel\na,150,300\n")
    xyz = {}
    for variant in ("DG", VARIANT.name):
        out = tmp_path / f"{variant}.csv"
        assert main(["locate", str(root), "--strip", "01", "--variant", variant, "--image", str(tmp_path / "img.csv"),
                     "-o", str(out)]) == 0
        row = next(csv.DictReader(open(out)))
        xyz[variant] = np.array([float(row[k]) for k in ("x", "y", "z")])
    for variant, g in (("DG", dg), (VARIANT.name, adj)):
        p_P, status = g.image_to_ground(np.array([150.0]), np.array([300.0]), project.dtm)
        assert np.allclose(np.column_stack(project.map_frame.project_to_map(p_P))[0], xyz[variant], atol=1e-6)
    assert np.linalg.norm(xyz["DG"] - xyz[VARIANT.name]) > 0.01  # the adjustment moved the point
    assert main(["locate", str(root), "--strip", "01", "--variant", "NOPE", "--image", str(tmp_path / "img.csv")]) == 1


def _broken(tmp_path, adjusted, edit):
    root, _ = adjusted
    data = json.loads((root / "results" / VARIANT.name / "orientation.json").read_text())
    edit(data)
    path = tmp_path / "orientation.json"
    path.write_text(json.dumps(data))
    return path


@pytest.mark.parametrize("edit, key, text", [
    (lambda d: d.update(schema="scangeo.orientation/9"), "[schema]", "'scangeo.orientation/1'"),
    (lambda d: d["strips"][1]["spline"].pop("coefficients"), "[strips[1].spline.coefficients]", "missing"),
    (lambda d: d["mounting"].update(boresight=[0.1, 0.2]), "[mounting.boresight]", "shape 3"),
    (lambda d: d["sensor"].update(fov="42"), "[sensor.fov]", "expected float, got str"),
    (lambda d: d["gpsimu_models"][0].update(coefficients=[1.0]), "[gpsimu_models[0].coefficients]", "shape"),
    (lambda d: d["sensor"].update(kind="frame"), "[sensor.kind]", "unknown sensor kind 'frame'"),
    (lambda d: d["strips"][0]["spline"].update(spacing=-0.2), "[strips[0]]", "knot spacing must be positive"),
    (lambda d: d["gpsimu_models"][1].update(position_degree=11), "[gpsimu_models[1]]", "position_degree"),
])
def test_a_bad_file_is_named_with_its_key(tmp_path, adjusted, edit, key, text):
    path = _broken(tmp_path, adjusted, edit)
    with pytest.raises(OrientationFileError) as err:
        read_orientation_file(path)
    assert str(path) in str(err.value) and key in str(err.value) and text in str(err.value)


def test_unreadable_missing_and_foreign_files(tmp_path, adjusted):
    root, _ = adjusted
    path = tmp_path / "orientation.json"
    path.write_text('{"schema": "scangeo.orientation/1",\n "variant": }')
    with pytest.raises(OrientationFileError, match=r"orientation.json line 2: not JSON"):
        read_orientation_file(path)
    with pytest.raises(OrientationFileError, match="no such file"):
        read_orientation_file(tmp_path / "none.json")
    project = Project.load(root)
    with pytest.raises(OrientationFileError, match=r"no orientation for variant 'P9' \(adjust the variant first"):
        load_orientation(project, "P9")
    # a file written for another project frame is refused, not silently misplaced
    doc = read_orientation_file(root / "results" / VARIANT.name / "orientation.json")
    frame = dataclasses.replace(doc.reference, frame=type(doc.reference.frame)(0.8, 0.2, 0.0))
    other = root / "results" / "MOVED"
    other.mkdir()
    write_orientation(dataclasses.replace(doc, reference=frame), other / "orientation.json")
    with pytest.raises(OrientationFileError, match=r"MOVED/orientation.json \[frame.project_frame\]"):
        load_orientation(project, "MOVED")


def test_an_orientation_loads_from_an_explicit_path(tmp_path, adjusted):
    # a copy outside results/: by the file (a Path or a .json string) or by its folder, the same spline
    root, _ = adjusted
    project = Project.load(root)
    by_name = load_orientation(project, VARIANT.name)
    elsewhere = tmp_path / "kept"
    elsewhere.mkdir()
    (elsewhere / "orientation.json").write_bytes((root / "results" / VARIANT.name / "orientation.json").read_bytes())
    for given in (elsewhere / "orientation.json", str(elsewhere / "orientation.json"), elsewhere):
        doc = load_orientation(project, given)
        assert doc.variant == VARIANT.name
        np.testing.assert_array_equal(doc.strips["01"].spline.coef, by_name.strips["01"].spline.coef)
    with pytest.raises(OrientationFileError, match="no orientation file there"):
        load_orientation(project, tmp_path / "none.json")


def test_pushbroom_tables_and_line_time_tables_round_trip(tmp_path, adjusted):
    root, _ = adjusted
    doc = direct_orientation(Project.load(root))
    n = 64
    sensor = Pushbroom(n, along=np.full(n, 0.01), across=np.linspace(-0.3, 0.3, n) + 1e-3 * np.sin(np.arange(n)))
    s = doc.strips["01"]
    table = s.timing.time_of_line(np.arange(s.lines)) + 1e-4 * np.sin(np.arange(s.lines))
    strips = {"01": StripOrientation("01", s.lines, LineTiming(float(table[0]), 25.0, table), s.spline)}
    doc = Orientation("X", True, {"": SensorSetup(sensor, doc.mounting)}, strips, doc.reference)
    back = read_orientation_file(write_orientation(doc, tmp_path / "orientation.json"))
    g, h = doc.geometry("01"), back.geometry("01")
    line, pixel = np.linspace(0, s.lines - 1, 7), np.linspace(0, n - 1, 7)
    p_S, R = g.pose(g.time_of(line, pixel))
    p_S2, R2 = h.pose(h.time_of(line, pixel))
    assert np.array_equal(p_S, p_S2) and np.array_equal(R, R2)
    assert np.array_equal(g.sensor.look_S(pixel), h.sensor.look_S(pixel))
