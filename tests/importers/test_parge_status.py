"""PARGE status files and HySpex sensor models: the shared real lines read, and bad files refused.

Every bad input gets an error naming the file and what is wrong, and ``scangeo import parge`` leaves
nothing in OUT. The bad status files are the real ones with bytes changed: IDL SAVE files keep
variable names as text, so renaming one (same length) removes that variable and nothing else.
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import scipy.io

from scangeo.cli import main
from scangeo.errors import ParGeFileError
from scangeo.importers.hyspex import HySpexSensorModel
from scangeo.importers.parge import _hypotheses, import_parge
from scangeo.importers.parge_status import OffsetEvent, ParGeStatus, parse_events
from tests.conftest import shared_file

SWIR = "hyspex/20200522_Husky_SWIR_boresight_IFSAR.gcs"
VNIR = "hyspex/20200522_Husky_VNIR_boresight_IFSAR.gcs"
SWIR_MODEL = "hyspex/sensormodel_SWIR_384_sn3107_FOVexp_180deg_rotated.txt"
VNIR_MODEL = "hyspex/sensormodel_VNIR_1800_sn0812_FOVexp_180deg_rotated.txt"


def test_the_shared_lines_read_with_their_counts_rates_and_history():
    swir, vnir = ParGeStatus.read(shared_file(SWIR)), ParGeStatus.read(shared_file(VNIR))
    assert (swir.pixels, swir.lines, swir.bands, len(swir.gcps), int(swir.gcps.used.sum())) == (384, 2177, 288, 54, 42)
    assert (vnir.pixels, vnir.lines, vnir.bands, len(vnir.gcps), int(vnir.gcps.used.sum())) == (1800, 4356, 182, 66, 43)
    # the camera's frame period, not PARGE's nominal 25 Hz: both cameras then span the same 52.3 s of one track
    assert swir.scan_frequency_hz == vnir.scan_frequency_hz == 25.0
    assert swir.line_rate_hz == pytest.approx(1e6 / 24000) and vnir.line_rate_hz == pytest.approx(1e6 / 12000)
    assert swir.lines / swir.line_rate_hz == pytest.approx(vnir.lines / vnir.line_rate_hz, abs=0.05)
    # PARGE's offsets are the boresight result plus the three offset events that followed it
    assert [e.kind for e in swir.events] == ["crossbore", "offset", "offset", "offset"]
    total = np.sum([e.degrees for e in swir.events], axis=0)
    parge = np.degrees([swir.offsets["roll"], swir.offsets["pitch"], swir.offsets["heading"]])
    np.testing.assert_allclose(total, parge, atol=1e-6)
    # navarr's height is the GNSS altitude less PARGE's height offset, on every record
    np.testing.assert_allclose(swir.altitude - swir.height, swir.offsets["height"], atol=1e-6)


def test_the_history_parser_reads_boresight_results_and_offset_events_oldest_first():
    history = [
        "2020-07-27T15:19:55       M_OFFSET_EVENT: Offsetted Heading Parameter by  -0.0049999999deg",
        "2020-07-27T15:18:59       M_OFFSET_EVENT: Offsetted Roll Parameter by  0.013000000deg",
        "2020-06-24T22:23:53         GC_CROSSBORE:    Resulting boresights (rph) [deg]:   -0.31719138,  0.14414367, "
        "-0.15533988",
        "2020-06-24T22:21:04           GC_PROCESS: completed PARGE processing successfully",
    ]
    events = parse_events(history)
    assert [e.kind for e in events] == ["crossbore", "offset", "offset"]
    assert events[0].degrees == (-0.31719138, 0.14414367, -0.15533988)
    assert events[1].degrees == (0.013, 0.0, 0.0) and events[2].degrees == (0.0, 0.0, -0.0049999999)


def test_the_sensor_model_files_are_the_status_files_look_angles():
    st = ParGeStatus.read(shared_file(SWIR))
    model = HySpexSensorModel.read(shared_file(SWIR_MODEL), pixels=st.pixels)
    np.testing.assert_allclose(model.vinkelx, st.look_across, atol=1e-6)
    np.testing.assert_allclose(model.vinkely, st.look_along, atol=1e-6)
    assert np.degrees(model.vinkely[0]) == pytest.approx(0.1597, abs=1e-4)  # the SWIR's along-track angle


def _bad(tmp_path, change) -> str:
    data = bytearray(shared_file(SWIR).read_bytes())
    change(data)
    path = tmp_path / "bad.gcs"
    path.write_bytes(bytes(data))
    return str(path)


def _rename(data: bytearray, old: bytes, new: bytes, last: bool = False) -> None:
    at = data.rfind(old) if last else data.find(old)
    assert at > 0 and len(old) == len(new)
    data[at:at + len(old)] = new


def _gcp_values(data: bytearray) -> int:
    """Offset of gcparr's values in the file (big-endian float64, 54 x 6 in numpy's order)."""
    g = scipy.io.readsav(str(shared_file(SWIR)), python_dict=True)["gcparr"]
    at = bytes(data).find(np.asarray(g, ">f8").tobytes())
    assert at > 0
    return at


#: the variables image, sensor, aux and pr renamed (sensor's last occurrence: image has a field SENSOR)
NO_PARGE = ((b"\x00\x05IMAGE", b"\x00\x05IMAGX"), (b"\x00\x06SENSOR", b"\x00\x06SENSOX", True),
            (b"\x00\x03AUX", b"\x00\x03AUY"), (b"\x00\x02PR", b"\x00\x02PX"))

BAD_STATUS = {
    "truncated": (lambda d: d.__delitem__(slice(150_000, None)), "truncated or damaged"),
    "not an IDL SAVE file": (lambda d: d.__setitem__(slice(0, 2), b"PK"), "not an IDL SAVE file"),
    "no PARGE structures": (lambda d: [_rename(d, *r) for r in NO_PARGE], "not a PARGE status"),
    "missing rollarr": (lambda d: _rename(d, b"ROLLARR", b"ROLLXRR"), "missing the array rollarr"),
    "GCP outside the line": (lambda d: d.__setitem__(slice(_gcp_values(d), _gcp_values(d) + 8),
                                                     np.array([5000.0], ">f8").tobytes()),
                             "GCP 1 at pixel 5000, line 618 is outside the line's image"),
}


@pytest.mark.parametrize("case", sorted(BAD_STATUS))
def test_a_bad_status_file_is_refused_naming_it_and_nothing_is_written(tmp_path, case, capsys):
    change, expected = BAD_STATUS[case]
    path = _bad(tmp_path, change)
    with pytest.raises(ParGeFileError, match="bad.gcs") as err:
        ParGeStatus.read(path)
    assert expected in str(err.value)
    out = tmp_path / "project"
    assert main(["import", "parge", path, str(out)]) == 1
    message = capsys.readouterr().err
    assert "bad.gcs" in message and expected in message and "Traceback" not in message
    assert not out.exists() and not any(p.name.startswith(".project") for p in tmp_path.iterdir())


def test_a_sensor_model_of_another_camera_is_refused(tmp_path):
    out = tmp_path / "project"
    with pytest.raises(ParGeFileError, match=r"1800 pixels, but the image has 384"):
        import_parge(shared_file(SWIR), out, sensor_model=shared_file(VNIR_MODEL))
    assert not out.exists()


@pytest.mark.parametrize("text, expected", [
    ("pixel vinkelx\n0 0.1\n", "expected the header 'pixel vinkelx vinkely'"),
    ("pixel vinkelx vinkely\n0 0.1 0.0\n2 0.2 0.0\n", "the pixel column is not 0, 1, ..., 1 in order"),
    ("pixel vinkelx vinkely\n0 0.1 x\n", "line 2: '0 0.1 x' is not three numbers"),
    ("pixel vinkelx vinkely\n0 12.0 0.0\n", "expected radians"),
])
def test_a_bad_sensor_model_names_the_file_and_line(tmp_path, text, expected):
    path = tmp_path / "model.txt"
    path.write_text(text)
    with pytest.raises(ParGeFileError, match="model.txt") as err:
        HySpexSensorModel.read(path)
    assert expected in str(err.value)


def test_an_existing_folder_with_files_is_not_overwritten(tmp_path):
    out = tmp_path / "project"
    out.mkdir()
    (out / "mine.txt").write_text("keep")
    assert main(["import", "parge", str(shared_file(SWIR)), str(out)]) == 1
    assert (out / "mine.txt").read_text() == "keep" and len(list(out.iterdir())) == 1


def test_the_offset_hypotheses_read_the_history_as_added_and_as_set():
    """Two boresight results and an offset event: read as added, the offsets are their sum; read as
    set, the second result replaced the first. PARGE's offsets decide nothing here: every state of
    either reading is a candidate, each once, with none and all of the offsets among them."""
    st = ParGeStatus.read(shared_file(SWIR))
    events = (OffsetEvent("t1", "crossbore", (0.2, 0.1, -0.1), "GC_CROSSBORE"),
              OffsetEvent("t2", "crossbore", (0.25, 0.12, -0.08), "GC_CROSSBORE"),
              OffsetEvent("t3", "offset", (0.0, 0.01, 0.0), "M_OFFSET_EVENT"))
    total = np.array([0.25, 0.13, -0.08])  # set by the second result, plus the event
    status = dataclasses.replace(st, events=events, offsets={**st.offsets, **dict(zip(
        ("roll", "pitch", "heading"), np.radians(total)))})
    remainders = [np.round(h.remainder_deg, 6) for h in _hypotheses(status, -st.roll, st.pitch, st.heading)]
    # none held; the older offsets (added: total - the three changes); the second result and the event
    # to apply (after the second result, both readings); all; the first result set, the rest to apply
    expected = ([0.25, 0.13, -0.08], [0.45, 0.23, -0.18], [0.0, 0.01, 0.0], [0.0, 0.0, 0.0], [0.05, 0.03, 0.02])
    assert len(remainders) == len(expected)
    for want in expected:
        assert any(np.allclose(r, want, atol=1e-6) for r in remainders), (want, remainders)
