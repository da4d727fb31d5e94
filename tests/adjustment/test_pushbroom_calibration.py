"""A pushbroom's own calibration (across-track offset and scale, along-track offset) recovered from a
simulated block: the ``pushbroom`` preset (a HySpex-SWIR-like sensor whose true detector calibration
differs from its look-angle table by known errors), without images.

The variant ``GPSIMU`` trusts the GPS/IMU (no correction models: it observes the splines with its
sigmas) and calibrates the three unknowns: each is determined by the data. Calibrated together with
the boresight and the time offset, the across-track offset is nearly a roll and the along-track offset
nearly a pitch: the outputs show the correlations, the priors keep the system regular.
"""
from __future__ import annotations

import json

import numpy as np
import pytest

from scangeo.adjustment.keys import AcrossOffset, AcrossScale, AlongOffset, TimeOffset
from scangeo.adjustment.outputs import report_dict, write_results
from scangeo.adjustment.results import run_variant
from scangeo.adjustment.variants import Variant
from scangeo.errors import AdjustmentError
from scangeo.orientation.file import read_orientation_file
from scangeo.simulate.block import simulate
from scangeo.simulate.config import load_preset

CALIBRATION = ("across_offset", "across_scale", "along_offset")
GPSIMU = {"strategy": "SE", "position_degree": -1, "attitude_degree": -1}


def _pooled(checks) -> tuple[float, float]:
    ok = checks.status == 0
    return float(np.sqrt(np.mean(checks.line[ok] ** 2))), float(np.sqrt(np.mean(checks.pixel[ok] ** 2)))


@pytest.fixture(scope="module")
def block(tmp_path_factory):
    root = tmp_path_factory.mktemp("pbcal") / "pushbroom"
    simulate(root, load_preset("pushbroom", {"output": {"images": False}}))
    err = json.loads((root / "truth" / "errors.json").read_text())["calibration_error"]
    truth = {"across_offset": np.radians(err["across_offset_deg"]), "across_scale": err["across_scale"],
             "along_offset": np.radians(err["along_offset_deg"])}
    return root, truth


@pytest.fixture(scope="module")
def calibrated(block):
    root, _ = block
    return run_variant(root, Variant("CAL", calibrate=CALIBRATION, **GPSIMU))


def test_detector_calibration_is_recovered_within_three_sigma(block, calibrated):
    _, truth = block
    result = calibrated
    stats = result.adjustment.statistics
    assert result.adjustment.solution.converged and not result.adjustment.solution.regularisation
    assert 0.7 < stats.sigma0 < 1.3
    keys = {"across_offset": AcrossOffset(), "across_scale": AcrossScale(), "along_offset": AlongOffset()}
    for name, key in keys.items():
        est = float(result.adjustment.parameters[key].values[0])
        sigma = float(stats.sigmas(key)[0])
        assert abs(est - truth[name]) < 3 * sigma, (name, est, truth[name], sigma)
        assert abs(truth[name]) > 5 * sigma, (name, truth[name], sigma)  # the injected error is well determined
    # report.json: estimates in degrees, t-tests, priors, data share and the correlation matrix
    cal = report_dict(result)["calibration"]
    rows = {p["name"]: p for p in cal["parameters"]}
    assert set(rows) == set(CALIBRATION) and cal["correlation"]["names"] == list(CALIBRATION)
    assert rows["across_offset"]["unit"] == "deg" and rows["across_scale"]["unit"] == ""
    assert rows["across_offset"]["prior_sigma"] == pytest.approx(0.1)
    for p in rows.values():
        assert p["significant"] and p["t"] > 5 and p["data_share"] > 0.95
    np.testing.assert_allclose(np.diag(cal["correlation"]["matrix"]), 1.0)
    assert not cal["correlated"]  # without boresight and time offset the three are separable (|r| < 0.5)
    assert np.abs(np.array(cal["correlation"]["matrix"]) - np.eye(3)).max() < 0.5
    coefficient_names = {c["name"] for c in report_dict(result)["coefficients"]}
    assert set(CALIBRATION) <= coefficient_names


def test_an_uncalibrated_detector_leaves_residuals_the_calibration_removes(block, calibrated):
    root, _ = block
    plain = run_variant(root, Variant("PLAIN", snooping=False, **GPSIMU))  # no measurement set aside
    along0, across0 = _pooled(plain.checks)
    along1, across1 = _pooled(calibrated.checks)
    # measurement noise 0.3 px: calibrated, the check points reach it; uncalibrated they are off by
    # the along-track offset (0.08 deg at ~700 m: about 1 m, 0.6 lines) and across by offset and scale
    assert along1 < 0.4 and across1 < 0.4, (along1, across1)
    assert along0 > 2 * along1 and across0 > 1.5 * across1, (along0, along1, across0, across1)
    assert plain.adjustment.statistics.sigma0 > 2 * calibrated.adjustment.statistics.sigma0


def test_the_calibrated_sensor_flows_into_the_orientation_file(block, calibrated, tmp_path):
    root, _ = block
    out = write_results(calibrated, tmp_path / "CAL")
    doc = read_orientation_file(out / "orientation.json")
    p = calibrated.adjustment.parameters
    assert set(CALIBRATION) <= set(doc.calibrated)
    assert doc.sensor.across_offset == float(p[AcrossOffset()].values[0]) != 0.0
    assert doc.sensor.across_scale == float(p[AcrossScale()].values[0]) != 0.0
    assert doc.sensor.along_offset == float(p[AlongOffset()].values[0]) != 0.0
    # what rectification and locate use (the file's geometry) projects the check points as the result did
    c = calibrated.checks
    sid = str(c.strip[0])
    sel = c.strip == sid
    ground = {str(r[0]): r for r in np.genfromtxt(root / "ground.csv", delimiter=",", names=True, dtype=None,
                                                  encoding="utf-8")}
    xyz = np.array([[ground[q]["x"], ground[q]["y"], ground[q]["z"]] for q in c.point[sel]])
    frame = calibrated.block.project.map_frame
    line, pixel, status = doc.geometry(sid).ground_to_image(frame.map_to_project(xyz[:, 0], xyz[:, 1], xyz[:, 2]))
    points = calibrated.block.points
    meas = {(str(q), str(s)): (ln, px) for q, s, ln, px in zip(points.point, points.strip, points.line, points.pixel)}
    measured = np.array([meas[(str(q), sid)] for q in c.point[sel]])
    np.testing.assert_allclose(line - measured[:, 0], c.line[sel], atol=1e-5)
    np.testing.assert_allclose(pixel - measured[:, 1], c.pixel[sel], atol=1e-5)


def test_with_boresight_and_time_offset_the_correlations_show_what_is_not_determined(block):
    root, _ = block
    result = run_variant(root, Variant("ALL", calibrate=("boresight", "time_offset", *CALIBRATION), **GPSIMU))
    sol = result.adjustment.solution
    assert sol.converged and not sol.regularisation  # the priors keep the normal equations regular
    cal = report_dict(result)["calibration"]
    names = cal["correlation"]["names"]
    corr = np.array(cal["correlation"]["matrix"])
    r = {(a, b): corr[names.index(a), names.index(b)] for a in names for b in names}
    assert abs(r[("along_offset", "boresight.pitch")]) > 0.95  # one tilt of the plane of sight
    assert abs(r[("across_offset", "boresight.roll")]) > 0.8  # told apart only by the roll's 1 + tan^2
    pairs = {(p["a"], p["b"]) for p in cal["correlated"]}
    assert ("boresight.pitch", "along_offset") in pairs
    share = {p["name"]: p["data_share"] for p in cal["parameters"]}
    assert share["along_offset"] < 0.2  # held by its prior: the pitch takes the tilt
    assert share["across_scale"] > 0.9  # nothing else stretches the swath


def test_detector_calibration_needs_a_pushbroom(tmp_path):
    from tests.session_projects import SMALL_BLOCK

    root = tmp_path / "whisk"
    simulate(root, load_preset("small", SMALL_BLOCK))
    with pytest.raises(AdjustmentError, match="across_offset.*pushbroom"):
        run_variant(root, Variant("X", calibrate=("across_offset",)))


def test_the_calibration_test_keeps_what_the_data_determine_and_fixes_the_rest(block, calibrated):
    """``test_calibration``: the three injected detector errors are significant and kept, with the same
    estimates as without the test; a time offset the simulation did not inject is not significant,
    is fixed at its start value (0) and said so."""
    root, truth = block
    assert json.loads((root / "truth" / "errors.json").read_text()).get("time_offset_s", 0.0) == 0.0
    names = (*CALIBRATION, "time_offset")
    tested = run_variant(root, Variant("TESTED", calibrate=names, test_calibration=names, **GPSIMU))
    tests = {t["unknown"]: t for t in tested.block.calibration_tests}
    assert set(tests) == set(names)
    assert not tests["time_offset"]["kept"] and tests["time_offset"]["t"] < tests["time_offset"]["critical"]
    assert all(tests[n]["kept"] and tests[n]["t"] > 3 * tests[n]["critical"] for n in CALIBRATION)
    assert any("time_offset" in note and "fixed at its start value" in note for note in tested.notes)
    params = tested.adjustment.parameters
    assert not params[TimeOffset()].free.any() and params[TimeOffset()].values[0] == 0.0
    for key in (AcrossOffset(), AcrossScale(), AlongOffset()):
        a, b = float(params[key].values[0]), float(calibrated.adjustment.parameters[key].values[0])
        assert abs(a - b) < 0.5 * float(calibrated.adjustment.statistics.sigmas(key)[0])
