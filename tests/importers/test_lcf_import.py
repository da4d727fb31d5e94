"""``scangeo import lcf``: the conventions of lcf_spec, each in a case that fails if it is flipped; the time bases;
the altitude's datum; bad rows; the real Juvika line against its author's world file.

The synthetic lines (tests/importers/sensor_files.py) fly level over a plane at 0 m with a constant attitude:
where each ray meets the plane is a matter of tangents, checked by hand.
"""
from __future__ import annotations

import json
import math

import numpy as np
import pyproj
import pytest

from scangeo.cli import main
from scangeo.errors import ArgumentError, ImportFileError, MissingFileError
from scangeo.importers.lcf import import_lcf
from scangeo.io.project import Project
from tests.conftest import shared_file
from tests.importers.sensor_files import synthetic_line, write_cube

H = 50.0  # the synthetic lines' altitude above the plane (m)


def _ground(out, lines, pixels):
    """Map x, y of the rays of (line, pixel) on the project's DTM, relative to the first record's position."""
    project = Project.load(out)
    strip = project.strips[0].id
    p_P, status = project.geometry(strip).image_to_ground(np.asarray(lines, float), np.asarray(pixels, float),
                                                          project.dtm)
    assert (status == 0).all()
    x, y, _ = project.map_frame.project_to_map(p_P)
    x0, y0 = pyproj.Transformer.from_crs("EPSG:4326", project.crs, always_xy=True).transform(15.005, 67.2156)
    return x - x0, y - y0


def test_right_wing_up_looks_right_nose_up_looks_ahead_and_the_heading_is_from_north(tmp_path):
    """Flying east (heading pi/2) with lcf roll +5 deg (right wing up) and pitch +3 deg (nose up): the centre
    pixel sees the plane 50 tan 5 = 4.37 m to the right (south) and 50 tan 3 = 2.62 m ahead (east); pixel
    numbers grow to the right (south). A flipped roll, pitch or heading puts it elsewhere by metres."""
    files = synthetic_line(tmp_path / "in", samples=61, roll_rad=math.radians(5), pitch_rad=math.radians(3))
    out = tmp_path / "p"
    import_lcf(files["cube"], out, fov_deg=30.0, dtm=0)
    x, y = _ground(out, [0, 0, 0], [30, 0, 60])
    # the centre pixel: a rotation Rz(90) Ry(3) Rx(-5) of the nadir ray (right wing up = scangeo's roll -5)
    d = np.array([math.sin(math.radians(3)) * math.cos(math.radians(5)), math.sin(math.radians(5)),
                  math.cos(math.radians(3)) * math.cos(math.radians(5))])  # body frame x forward, y right, z down
    assert x[0] == pytest.approx(H * d[0] / d[2], abs=0.01) and y[0] == pytest.approx(-H * d[1] / d[2], abs=0.01)
    assert y[0] == pytest.approx(-4.37, abs=0.05) and x[0] == pytest.approx(2.62 / math.cos(math.radians(5)), abs=0.05)
    assert y[2] < y[0] < y[1]  # pixel 60 to the right (south) of pixel 0
    left = tmp_path / "left"
    import_lcf(files["cube"], left, fov_deg=30.0, dtm=0, pixels_increase="left")
    _, y_left = _ground(left, [0, 0], [0, 60])
    assert y_left[0] == pytest.approx(y[2], abs=1e-3) and y_left[1] == pytest.approx(y[1], abs=1e-3)
    decisions = {d["topic"]: d for d in json.loads((out / "import.json").read_text())["decisions"]}
    assert decisions["heading"]["figures"]["heading_minus_course"]["median_deg"] == pytest.approx(0.0, abs=0.1)
    assert abs(decisions["heading"]["alternatives"]["counter-clockwise from east"]["heading_minus_course"]
               ["median_deg"]) > 80


def test_a_northbound_line_looks_east_to_its_right(tmp_path):
    """Heading 0: the right of the flight is east; a heading read from east (the other convention) would fly east."""
    files = synthetic_line(tmp_path / "in", heading_rad=0.0, roll_rad=math.radians(5))
    out = tmp_path / "p"
    import_lcf(files["cube"], out, fov_deg=30.0, dtm=0)
    x, y = _ground(out, [0, 200], [29.5, 29.5])
    assert x[0] == pytest.approx(4.37, abs=0.05) and y[1] - y[0] == pytest.approx(0.9996 * 8.0, abs=0.002)  # 4 m/s, 2 s


def test_the_line_times_meet_the_navigation_at_the_first_record(tmp_path):
    """The .times run on the camera computer's clock (876 s); line k is at the first .lcf record + (times[k] -
    times[0]): line 200 is 2.00 s (8.00 m at 4 m/s) after line 0. Lines taken after the last record are left
    out, and the project reads the cube's first lines through a VRT."""
    files = synthetic_line(tmp_path / "in", extra_s=-0.0449)  # the navigation ends 4.9 ms after line 295
    out = tmp_path / "p"
    result = import_lcf(files["cube"], out, fov_deg=30.0, dtm=0)
    assert result.lines == 296 and "lines 296-299 of the cube were taken after the last navigation record" in \
        result.notes[0]
    x, _ = _ground(out, [0, 200], [29.5, 29.5])
    assert x[1] - x[0] == pytest.approx(0.9996 * 8.0, abs=0.002)  # UTM's scale at its central meridian
    project = Project.load(out)
    times = project.timing(result.strip).time_of_line(np.array([0.0, 200.0]))
    assert times[0] == pytest.approx(487934.235, abs=1e-6) and times[1] - times[0] == pytest.approx(2.0, abs=1e-6)
    import rasterio

    with rasterio.open(project.strip(result.strip).image) as src:  # a raw cube: no georeference
        assert (src.height, src.width, src.count) == (296, 60, 2)
        assert src.read(1)[295, 0] == 295 and src.read(2)[0, 59] == 59  # the cube's own values
    alignment = json.loads((out / "import.json").read_text())["decisions"][2]
    assert alignment["topic"] == "time_alignment" and alignment["figures"]["offset_s"] == pytest.approx(
        487934.235 - 876.386137, abs=1e-6)


@pytest.mark.parametrize("altitude_m, datum, h_m", [(H, "above the geoid", H + 30.0), (H + 30.0, "above the ellipsoid",
                                                                                     H + 30.0)])
def test_the_altitudes_datum_is_the_reading_with_square_pixels(tmp_path, altitude_m, datum, h_m):
    """4 m/s at 100 lines/s is 4 cm along track; 670 pixels over 30 deg are 4 cm across at 50 m. With N = 30 m,
    an altitude of 50 m is square above the geoid (above the ellipsoid the camera would fly at 20 m, pixels 0.4
    as wide as long), and 80 m is square above the ellipsoid: either way the trajectory is 80 m above the
    ellipsoid and the swath 2 x 50 tan 15 = 26.8 m."""
    files = synthetic_line(tmp_path / "in", samples=670, altitude_m=altitude_m, bands=1)
    out = tmp_path / "p"
    result = import_lcf(files["cube"], out, fov_deg=30.0, dtm=0, geoid=30.0)
    decision = result.record.decision("altitude")
    assert decision.choice == datum and not result.warnings
    project = Project.load(out)
    assert project.stream(result.strip).h[0] == pytest.approx(h_m, abs=1e-3)
    _, y = _ground(out, [0, 0], [0, 669])
    # UTM 33N at its central meridian: map distances are 0.9996 of the ground's
    assert y[0] - y[1] == pytest.approx(0.9996 * 2 * H * math.tan(math.radians(15)) * 669 / 670, abs=0.002)
    other = "ellipsoidal" if datum == "above the geoid" else "orthometric"
    assert decision.alternatives[other]["across_over_along"] < 0.7 or decision.alternatives[other][
        "across_over_along"] > 1.4


def test_without_a_geoid_the_altitude_is_taken_as_it_stands_and_said(tmp_path):
    files = synthetic_line(tmp_path / "in")
    result = import_lcf(files["cube"], tmp_path / "p", fov_deg=30.0, dtm=0)
    assert result.record.decision("altitude").choice.startswith("as it stands")
    assert any("no geoid given" in w for w in result.warnings)
    with pytest.raises(ArgumentError, match="geoid undulation"):
        import_lcf(files["cube"], tmp_path / "q", fov_deg=30.0, dtm=0, altitude="ellipsoidal")
    assert not (tmp_path / "q").exists()


def _edit(path, edit):
    rows = path.read_text().splitlines()
    path.write_text("\n".join(edit(rows)) + "\n")


def _field(row: str, k: int, value: str) -> str:
    fields = row.split()
    fields[k] = value
    return "\t".join(fields)


BAD_ROWS = {
    "flag 3": (lambda r: [*r[:9], _field(r[9], 9, "3"), *r[10:]],
               "line.lcf line 10: column 10 is 3, expected 5 (use) or 0 (do not use)"),
    "time backwards": (lambda r: [*r[:19], r[20], r[19], *r[21:]], "line.lcf line 21: time"),
    "NaN roll": (lambda r: [*r[:29], _field(r[29], 1, "nan"), *r[30:]],
                 "line.lcf line 30: roll is not a finite number"),
    "truncated": (lambda r: [*r[:-1], " ".join(r[-1].split()[:4])], "fields, expected 11 as on line 1 (a truncated "
                                                                    "record?)"),
    "degrees": (lambda r: [*r[:4], _field(r[4], 3, "90.0"), *r[5:]], "line.lcf line 5: heading 90 is outside"),
    "gap": (lambda r: r[:100] + r[400:], "line.lcf line 101: a gap of 1.505 s in the navigation"),
}


@pytest.mark.parametrize("case", sorted(BAD_ROWS))
def test_a_bad_row_is_refused_by_its_line_and_nothing_is_written(tmp_path, case, capsys):
    edit, expected = BAD_ROWS[case]
    files = synthetic_line(tmp_path / "in")
    _edit(files["lcf"], edit)
    out = tmp_path / "p"
    with pytest.raises(ImportFileError) as err:
        import_lcf(files["cube"], out, fov_deg=30.0, dtm=0)
    assert expected in str(err.value)
    assert main(["import", "lcf", str(files["cube"]), str(out), "--fov", "30", "--dtm", "0"]) == 1
    message = capsys.readouterr().err
    assert expected in message and "Traceback" not in message
    assert not out.exists() and sorted(p.name for p in tmp_path.iterdir()) == ["in"]


def test_records_flagged_do_not_use_are_set_aside_with_a_note(tmp_path):
    files = synthetic_line(tmp_path / "in")
    _edit(files["lcf"], lambda r: [*r[:49], *(_field(x, 9, "0") for x in r[49:52]), *r[52:]])
    result = import_lcf(files["cube"], tmp_path / "p", fov_deg=30.0, dtm=0)
    assert "3 records of line.lcf flagged 0 (do not use) were set aside (lines 50-52)" in result.notes
    assert len(Project.load(tmp_path / "p").stream(result.strip)) == len(files["lcf"].read_text().splitlines()) - 3


def test_a_camera_of_another_pixel_count_and_bad_cubes_are_refused(tmp_path):
    files = synthetic_line(tmp_path / "in")
    table = tmp_path / "in" / "look.csv"
    table.write_text("pixel,along_deg,across_deg\n" + "".join(f"{j},0,{-10 + j * 0.2}\n" for j in range(50)))
    with pytest.raises(ImportFileError, match="look.csv: 50 pixels, but the cube line.bil.hdr has 60 samples"):
        import_lcf(files["cube"], tmp_path / "p", look_angles=table, dtm=0)
    data = files["cube"].read_bytes()
    files["cube"].write_bytes(data[:-7])
    with pytest.raises(ImportFileError, match=r"line.bil: 71993 bytes, but its header line.bil.hdr says 60 samples x "
                                              r"300 lines x 2 bands of 2-byte uint16 = 72000 bytes \(truncated\)"):
        import_lcf(files["cube"], tmp_path / "p", fov_deg=30.0, dtm=0)
    files["cube"].unlink()
    with pytest.raises(MissingFileError, match=r"line.bil.hdr: no data file beside the header \(looked for line.bil\)"):
        import_lcf(tmp_path / "in" / "line.bil.hdr", tmp_path / "p", fov_deg=30.0, dtm=0)
    assert not (tmp_path / "p").exists()


def test_gcps_given_to_the_import_are_the_projects_and_checked(tmp_path):
    files = synthetic_line(tmp_path / "in")
    ground, points = tmp_path / "in" / "ground.csv", tmp_path / "in" / "points.csv"
    ground.write_text("point,x,y,z,sigma_xy,sigma_z,role\nA,500000,7455000,0,0.02,0.05,control\n")
    points.write_text("point,strip,line,pixel\nA,line,100,30\n")
    result = import_lcf(files["cube"], tmp_path / "p", fov_deg=30.0, dtm=0, ground=ground, points=points)
    assert (result.control, result.check) == (1, 0) and (tmp_path / "p" / "points.csv").exists()
    points.write_text("point,strip,line,pixel\nA,other,100,30\n")
    with pytest.raises(ImportFileError, match="points.csv line 2: strip 'other', expected the line's id 'line'"):
        import_lcf(files["cube"], tmp_path / "q", fov_deg=30.0, dtm=0, ground=ground, points=points)
    points.write_text("point,strip,line,pixel\nA,line,300,30\n")
    with pytest.raises(ImportFileError, match=r"points.csv line 2: line 300, pixel 30 is outside the line's image"):
        import_lcf(files["cube"], tmp_path / "q", fov_deg=30.0, dtm=0, ground=ground, points=points)


def test_run_without_gcps_rectifies_by_direct_georeferencing_and_calls_it_unchecked(tmp_path, capsys):
    files = synthetic_line(tmp_path / "in", samples=40, lines=200)
    out = tmp_path / "p"
    import_lcf(files["cube"], out, fov_deg=30.0, dtm=0, geoid=0.0)
    assert main(["run", str(out), "--no-progress"]) == 0
    printed = capsys.readouterr().out
    assert "compare   not run (cannot run: no points.csv" in printed
    manifest = json.loads((out / "results" / "run.json").read_text())
    assert manifest["recommended"]["variant"] == "DG" and manifest["recommended"]["checked"] is False
    assert "unchecked" in manifest["recommended"]["why"]
    html = (out / "results" / "report.html").read_text()
    assert "Rectified: DG, unchecked" in html and "How the line was imported" in html
    import rasterio

    with rasterio.open(out / "results" / "DG" / "ortho" / "line.tif") as src:
        line = src.read(1, masked=True)
    assert line.count() > 1000 and 0 <= line.min() and line.max() <= 199


# ----------------------------------------------------------------------------------------------- the real line
JUVIKA = "resonon/Juvika_June2022_Pika_L_12"


@pytest.fixture(scope="module")
def juvika(tmp_path_factory):
    """The real .lcf and .times with a stand-in cube of the line's size (the real one is not public)."""
    lcf, times = shared_file(JUVIKA + ".lcf"), shared_file(JUVIKA + ".bil.times")
    folder = tmp_path_factory.mktemp("juvika")
    cube = write_cube(folder / "Juvika_June2022_Pika_L_12.bil", np.zeros((2000, 900, 1), np.uint16))
    return cube, lcf, times, folder


def _corners(out, world):
    project = Project.load(out)
    strip = project.strips[0].id
    n = project.n_lines(strip)
    lines, pixels = np.array([0.0, 0, n - 1, n - 1]), np.array([0.0, 899, 0, 899])
    p_P, _ = project.geometry(strip).image_to_ground(lines, pixels, project.dtm)
    x, y, _ = project.map_frame.project_to_map(p_P)
    a, d, b, e, c, f = world
    return np.hypot(x - (a * pixels + b * lines + c), y - (d * pixels + e * lines + f))


def test_the_juvika_line_imports_with_its_time_base_datum_and_footprint(juvika):
    """GPS time (2022-06-24, not 2012 as Unix time), 109 lines/s, the last line after the navigation's end;
    with EGM96's N = 30.52 m the altitude is above the geoid (38 m above the sea; above the ellipsoid the
    drone would fly at 7 m with pixels 0.15 as wide as long). The footprint's corners on the sea are 3-6 m
    from the author's world file (made 48 m above the water, across the mean track) with the author's pixel
    order (growing to the left); with the other order two corners swap sides (more than 20 m)."""
    cube, lcf, times, folder = juvika
    out = folder / "left"
    r = import_lcf(cube, out, lcf=lcf, times=times, fov_deg=36.5, pixels_increase="left", dtm=0, geoid=30.52)
    base = r.record.decision("time_base")
    assert base.figures["gps_week"] == 2215 and base.figures["gps_date"].startswith("2022-06-24")
    assert base.figures["unix_date"].startswith("2012-06-19")
    assert r.lines == 1999 and r.line_rate_hz == pytest.approx(109.0, abs=0.01)
    altitude = r.record.decision("altitude")
    assert altitude.choice == "above the geoid"
    assert altitude.alternatives["orthometric"]["height_above_ground_m"] == pytest.approx(37.86, abs=0.05)
    assert altitude.alternatives["ellipsoidal"]["across_over_along"] < 0.2
    world = np.loadtxt(shared_file(JUVIKA + ".wld"))
    left = _corners(out, world)
    assert left.max() < 6.0, left
    right = folder / "right"
    import_lcf(cube, right, lcf=lcf, times=times, fov_deg=36.5, pixels_increase="right", dtm=0, geoid=30.52)
    assert np.sort(_corners(right, world))[-2] > 20.0
