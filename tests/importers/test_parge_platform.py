"""``scangeo import parge VNIR.gcs SWIR.gcs OUT``: the shared HySpex pair as one platform project.

The status files are the shared real pair, as they are or with bytes changed (IDL SAVE keeps its arrays
in the open: roll and pitch zeroed for level flight, the start time or the date of a copy changed).
"""
from __future__ import annotations

import json
import shutil

import numpy as np
import pytest
import scipy.io

from scangeo.cli import main
from scangeo.errors import ArgumentError, ImportFileError
from scangeo.importers.parge import import_parge
from scangeo.importers.parge_platform import (
    import_parge_platform,
    parge_offsets_relative_mounting,
    parse_relative_mounting,
)
from scangeo.io.points import GroundPoints, ImagePoints
from scangeo.io.project import Project
from tests.conftest import shared_file
from tests.importers.pair_split import PAIR, gcp_ids

#: one float32 step of PARGE's STARTTIME (hours) at the pair's 13.18 h, in seconds: the two lines' start
#: times are one float32 value, so their true start times may differ by up to this
STARTTIME_STEP_S = float(np.spacing(np.float32(13.176111)) * 3600.0)


def _status(sensor: str):
    return shared_file(PAIR[sensor])


@pytest.fixture(scope="module")
def pair(tmp_path_factory):
    """The pair imported as it is: (folder, result, import.json)."""
    out = tmp_path_factory.mktemp("pair") / "project"
    result = import_parge_platform([_status("vnir"), _status("swir")], out)
    return out, result, json.loads((out / "import.json").read_text())


def test_the_pair_is_one_flight_line_of_two_sensors_with_each_cameras_gcps(pair):
    out, result, record = pair
    project = Project.load(out)
    assert project.is_platform and set(project.sensors) == {"vnir", "swir"}
    assert list(project.flight_lines) == ["L1"] and set(project.flight_lines["L1"].strips) == {"vnir-L1", "swir-L1"}
    assert project.sensors["vnir"].model.pixels == 1800 and project.sensors["swir"].model.pixels == 384
    assert project.sensors["vnir"].line_rate == pytest.approx(1e6 / 12000) and project.knot_spacing == 0.012
    ground, points = GroundPoints.read(out / "ground.csv"), ImagePoints.read(out / "points.csv")
    for sensor in ("vnir", "swir"):
        st = scipy.io.readsav(str(_status(sensor)), python_dict=True)
        ids, _, _ = gcp_ids(_status(sensor))
        mine = np.array([str(p).startswith(f"{sensor}-") for p in ground.point])
        assert mine.sum() == len(ids) and set(points.strip[[str(p).startswith(sensor) for p in points.point]]) == \
            {f"{sensor}-L1"}
        used = st["gcparr"][:, 5] > 0.5  # PARGE's used GCPs control, its unused ones check, as one line's import
        assert list(ground.role[mine]) == ["control" if u else "check" for u in used]
        np.testing.assert_allclose(ground.xyz[mine], st["gcparr"][:, 2:5], atol=1e-4)
    assert record["thresholds"] and record["flight_lines"]["L1"]["reference"] == "vnir-L1"


def test_the_two_lines_navigation_is_one_ins_with_pargeʼs_offsets_taken_off_the_angles(pair):
    """As given, the attitude arrays differ by PARGE's stored offsets (VNIR minus SWIR: roll 1.54, pitch
    -0.48, heading 0.21 deg in PARGE's signs, roll negated in scangeo's) to 0.001 deg, by less than 0.01 deg
    rms beyond, and the positions by at most 7 cm. With every stored offset added back and the SWIR's times
    moved by less than one float32 step of STARTTIME, the two INS copies agree to 1e-4 deg in the mean:
    the reading of the single-line import (the arrays hold the boresight result, not the later offset
    events) would leave the events' difference, 0.032 deg in pitch."""
    out, result, record = pair
    arrays = record["flight_lines"]["L1"]["arrays"]["swir-L1"]
    difference = record["relative_mountings"]["swir:vnir"]["parge_stored_offsets_difference_deg"]
    # SWIR minus VNIR in scangeo's angles: the arrays are the INS's angles less the offsets
    np.testing.assert_allclose(arrays["attitude_constant_deg"], [-difference[0], difference[1], difference[2]],
                               atol=1e-3)
    assert max(arrays["attitude_rms_deg"]) < 0.01 and arrays["position_max_m"] < 0.07
    a = result.agreements["20200522_Husky_SWIR_boresight_IFSAR.gcs"]
    assert abs(a.time_offset_s) < STARTTIME_STEP_S
    line = record["lines"]["swir-L1"]
    assert line["first_line_time"] == pytest.approx(record["lines"]["vnir-L1"]["first_line_time"] + a.time_offset_s)
    ins = record["flight_lines"]["L1"]["agreement"]["swir-L1"]
    assert max(abs(v) for v in ins["attitude_constant_shifted_deg"]) < 1e-4
    assert max(ins["attitude_rms_shifted_deg"]) < 0.002 and ins["position_max_shifted_m"] < 0.02
    events = np.subtract(record["lines"]["vnir-L1"]["offsets"]["remainder_deg"],
                         record["lines"]["swir-L1"]["offsets"]["remainder_deg"])
    assert abs(events[1]) > 0.03  # what the other reading would leave in pitch


def test_the_relative_mounting_of_pargeʼs_offsets_is_the_imported_one_to_first_order(pair):
    """PARGE's stored offsets as a relative mounting (level flight) against the one the imported mountings
    make: the same signs and within the offset events' 0.04 deg (a sign slip would be 0.4-3 deg off)."""
    out, result, record = pair
    rel = record["relative_mountings"]["swir:vnir"]
    np.testing.assert_allclose(rel["parge_stored_offsets_deg"], rel["imported_deg"], atol=0.04)
    stored = {s: [float(np.degrees(v)) for v in (line["parge_offsets"][k] for k in ("roll", "pitch", "heading"))]
              for s, line in (("vnir", record["lines"]["vnir-L1"]), ("swir", record["lines"]["swir-L1"]))}
    assert parge_offsets_relative_mounting(stored["vnir"], stored["swir"]) == pytest.approx(
        rel["parge_stored_offsets_deg"])
    # a rotation by the reference's offsets composed with the relative one is the sensor's: known answer
    level = parge_offsets_relative_mounting([0.0, 0.0, 0.0], stored["swir"])
    assert level == pytest.approx((stored["swir"][0], -stored["swir"][1], -stored["swir"][2]), abs=1e-3)


def _level_pair(tmp_path):
    """Copies of the pair in level flight (rollarr and pitcharr zero)."""
    paths = {}
    for sensor in ("vnir", "swir"):
        src = _status(sensor)
        data, d = bytearray(src.read_bytes()), scipy.io.readsav(str(src), python_dict=True)
        for key in ("rollarr", "pitcharr"):
            raw = np.asarray(d[key], ">f8").tobytes()
            at = bytes(data).find(raw)
            assert at > 0 and bytes(data).find(raw, at + 1) < 0
            data[at:at + len(raw)] = bytes(len(raw))
        paths[sensor] = tmp_path / f"{sensor}.gcs"
        paths[sensor].write_bytes(bytes(data))
    return paths


def _ground(project: Project, strip: str, line, pixel, check: bool = True) -> np.ndarray:
    p_P = project.geometry(strip, check=check).image_to_ground(line, pixel, project.dtm)[0]
    return np.column_stack(project.map_frame.project_to_map(p_P))


def _positions(project: Project, strip: str):
    n, pixels = project.n_lines(strip), project.scanner_of(strip).model.pixels
    line, pixel = np.meshgrid(np.linspace(1, n - 2, 30), np.linspace(0, pixels - 1, 7))
    return line.ravel(), pixel.ravel()


def test_in_level_flight_each_camera_sees_the_ground_its_single_line_import_sees(tmp_path):
    """Level flight, where PARGE's offsets added to the angles are exactly a constant rotation: the VNIR
    (the flight line's trajectory) through the platform project puts its image positions on the ground
    where its single-line project does, to 0.01 mm on the VNIR's own records; the SWIR's first INS record,
    1.4 ms before the VNIR's and kept for the SWIR's line 0, moves the spline's knots by 1.4 ms against
    the VNIR's records, which costs the VNIR up to 3 mm. The SWIR lands within its navigation's
    disagreement with the VNIR's (positions up to 1.5 cm apart, attitudes 0.0004 deg rms: import.json)
    at 750 m range."""
    paths = _level_pair(tmp_path)
    plane, geoid = 180.0, 5.0
    out = tmp_path / "platform"
    result = import_parge_platform([paths["vnir"], paths["swir"]], out, dtm=plane, geoid=geoid)
    platform = Project.load(out)
    a = result.agreements["swir.gcs"]
    assert -STARTTIME_STEP_S < a.time_offset_s < 0 and [n for n in result.notes if "1 record(s) of swir-L1" in n]
    assert result.sensors["vnir"].departure_deg[1] < 1e-5  # a constant rotation: the arrays' departure vanishes
    without_first = tmp_path / "without_first"  # the flight line's trajectory from the VNIR's records alone
    shutil.copytree(out, without_first)
    nav = without_first / "nav" / "L1.csv"
    rows = nav.read_text().splitlines()
    nav.write_text("\n".join([rows[0], *rows[2:]]) + "\n")
    tolerance = {"vnir": 3e-3,
                 "swir": a.position_max_shifted_m + 750.0 * np.radians(3 * max(a.attitude_rms_shifted_deg))}
    for sensor, path in paths.items():
        single_out = tmp_path / sensor
        import_parge(path, single_out, dtm=plane, geoid=geoid)
        single = Project.load(single_out)
        (strip,) = [s.id for s in single.strips]
        line, pixel = _positions(single, strip)
        expected = _ground(single, strip, line, pixel)
        d = np.linalg.norm(expected - _ground(platform, f"{sensor}-L1", line, pixel), axis=1)
        assert d.max() < tolerance[sensor], (sensor, d.max())
        if sensor == "vnir":
            exact = np.linalg.norm(expected - _ground(Project.load(without_first), "vnir-L1", line, pixel, False),
                                   axis=1)
            assert exact.max() < 1e-5, exact.max()


def test_on_the_real_attitudes_the_cameras_depart_by_what_import_json_says(pair, tmp_path):
    """On the real rolls of +-25 deg PARGE's offsets added to the angles are no constant rotation: each
    camera's single-line attitude departs from its mounting on the INS by some 0.04-0.05 deg rms
    (import.json), and its ground points through the platform by no more than that angle at their
    range (at most 1.2 km at 720 m above ground and 40 deg off nadir) plus the navigation's 2 cm."""
    out, result, _ = pair
    plane, geoid = 180.0, 5.0
    platform_out = tmp_path / "platform"
    import_parge_platform([_status("vnir"), _status("swir")], platform_out, dtm=plane, geoid=geoid)
    platform = Project.load(platform_out)
    for sensor in ("vnir", "swir"):
        departure = result.sensors[sensor].departure_deg
        assert 0.02 < departure[0] < 0.08
        single_out = tmp_path / sensor
        import_parge(_status(sensor), single_out, dtm=plane, geoid=geoid)
        single = Project.load(single_out)
        (strip,) = [s.id for s in single.strips]
        line, pixel = _positions(single, strip)
        d = np.linalg.norm(_ground(single, strip, line, pixel) - _ground(platform, f"{sensor}-L1", line, pixel), axis=1)
        assert d.max() < 1200.0 * np.radians(departure[1]) + 0.02, (sensor, d.max())


def _changed(tmp_path, sensor: str, change, name: str):
    data = bytearray(_status(sensor).read_bytes())
    change(data)
    path = tmp_path / name
    path.write_bytes(bytes(data))
    return path


def _later_start(seconds: float):
    def change(data: bytearray) -> None:
        start = float(scipy.io.readsav(str(_status("swir")), python_dict=True)["image"][0]["STARTTIME"])
        raw = np.array([start], ">f8").tobytes()
        at = bytes(data).find(raw)
        data[at:at + 8] = np.array([start + seconds / 3600.0], ">f8").tobytes()
    return change


def test_lines_whose_navigation_does_not_agree_stay_separate_flight_lines_and_the_import_says_why(tmp_path, capsys):
    """The SWIR's start time 3 s late: its records overlap the VNIR's span, but no time offset within
    0.05 s makes the attitudes agree: two flight lines, a warning with the figures."""
    late = _changed(tmp_path, "swir", _later_start(3.0), "late.gcs")
    out = tmp_path / "project"
    assert main(["import", "parge", str(_status("vnir")), str(late), str(out), "--no-progress"]) == 0
    printed = capsys.readouterr().out
    assert "flight line L1: vnir-L1" in printed and "flight line L2: swir-L2" in printed
    assert "late.gcs and 20200522_Husky_VNIR_boresight_IFSAR.gcs: not one stretch of one GNSS/INS" in printed
    assert "deg rms apart beyond a constant" in printed
    record = json.loads((out / "import.json").read_text())
    (separate,) = record["separate"]
    assert separate["line"] == "late.gcs" and max(separate["figures"]["attitude_rms_shifted_deg"]) > 0.02
    project = Project.load(out)
    assert {f: list(line.strips) for f, line in project.flight_lines.items()} == {"L1": ["vnir-L1"],
                                                                                  "L2": ["swir-L2"]}


def test_status_files_of_other_flights_are_refused_naming_both(tmp_path):
    other_day = _changed(tmp_path, "swir", lambda d: d.__setitem__(slice(None), bytes(d).replace(
        b"2020-05-22", b"2020-05-23")), "other_day.gcs")
    out = tmp_path / "project"
    with pytest.raises(ImportFileError, match=r"20200522_Husky_VNIR_boresight_IFSAR.gcs and .*other_day.gcs are of "
                                              r"different flights \(other days: 2020-05-22 and 2020-05-23\)"):
        import_parge_platform([_status("vnir"), other_day], out)
    assert not out.exists()


def test_a_relative_mounting_prior_is_written_and_read_back(tmp_path, capsys):
    out = tmp_path / "project"
    assert main(["import", "parge", str(_status("vnir")), str(_status("swir")), str(out), "--relative-mounting",
                 "swir:vnir:-1.54,-0.47,0.22:0.03,0.03,0.06", "--no-progress"]) == 0
    (prior,) = Project.load(out).relative_mountings
    assert (prior.sensor, prior.reference) == ("swir", "vnir")
    np.testing.assert_allclose(np.degrees(prior.boresight), [-1.54, -0.47, 0.22])
    np.testing.assert_allclose(np.degrees(prior.boresight_sigma), [0.03, 0.03, 0.06])
    assert "sensor swir (SWIR_384me_SN3107): boresight" in capsys.readouterr().out


@pytest.mark.parametrize("text, message", [
    ("swir:vnir:-1.5,-0.5,0.2:", "no sigma"),
    ("swir:vnir:-1.5,-0.5:0.02", "2 angles and 1 sigmas"),
    ("swir:vnir:-1.5,x,0.2:0.02", "not numbers"),
    ("swir:vnir:-1.5,-0.5,0.2:0", "the sigmas must be positive"),
    ("swir:-1.5,-0.5,0.2:0.02", "expected SENSOR:REFERENCE"),
])
def test_a_malformed_relative_mounting_is_refused(text, message):
    with pytest.raises(ArgumentError, match=message) as info:
        parse_relative_mounting(text)
    assert str(info.value).startswith(f"relative_mounting={text!r}")
