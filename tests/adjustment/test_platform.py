"""The platform in the adjustment: flight lines own the orientation and the GPS/IMU corrections, sensors
their mounting; a one-sensor project written as a platform adjusts to the same numbers, a second sensor
on the same flight lines takes the drift corrections of the first, and a relative-mounting prior holds
a sensor without measurements.

The second sensor here is the first one again (the same scanner model and images; its measurements
the first sensor's): what it must get from the platform is then known exactly.
"""
from __future__ import annotations

import re

import numpy as np
import pytest

from scangeo.adjustment.keys import Boresight, Knots
from scangeo.adjustment.results import run_variant
from scangeo.adjustment.variants import Variant
from scangeo.errors import ProjectFileError
from scangeo.io.project import Project
from tests.session_projects import as_platform, copy_project

SE = Variant("SE", "SE")
P2 = Variant("P2", "P", position_degree=2, attitude_degree=1)
#: position corrections per flight line and the boresights calibrated (an attitude constant per flight line
#: and a boresight would be one unknown twice)
BORESIGHT = Variant("SE_B", "SE", attitude_degree=-1, calibrate=("boresight",))


@pytest.fixture(scope="module")
def legacy(small_block, tmp_path_factory):
    root = copy_project(small_block, tmp_path_factory.mktemp("platform") / "legacy", truth=True)
    return {v.name: run_variant(root, v) for v in (SE, P2)}


def test_a_one_sensor_project_as_a_platform_adjusts_to_the_same_numbers(small_block, tmp_path, legacy):
    root = copy_project(small_block, tmp_path / "platform", truth=True)
    as_platform(root)
    project = Project.load(root)
    assert list(project.sensors) == ["a"] and set(project.flight_lines) == {"L01", "L02"}
    assert project.flight_line_of("01").trajectory == project.root / "nav" / "01.csv"
    for v in (SE, P2):
        mine, theirs = run_variant(root, v), legacy[v.name]
        assert Knots("L01") in mine.adjustment.parameters and Boresight("a") in mine.adjustment.parameters
        assert mine.adjustment.statistics.sigma0 == pytest.approx(theirs.adjustment.statistics.sigma0, rel=1e-9)
        assert np.allclose(mine.checks.line, theirs.checks.line, atol=1e-7)
        assert np.allclose(mine.checks.pixel, theirs.checks.pixel, atol=1e-7)
        assert [m.id for m in mine.block.models] == [f"L{m.id}" for m in theirs.block.models]


def test_a_second_sensor_takes_the_drift_corrections_of_its_flight_line(small_block, tmp_path, legacy):
    """Sensor b measures no control point: its strips are held by the flight lines' corrections, which a's
    control determines, and by the tie points it shares with a. With b's measurements a copy of a's, b's
    boresight comes out as a's (its nominal roll was 0.05 deg off) and its check residuals are a's to within
    the relative boresight's precision."""
    root = copy_project(small_block, tmp_path / "pair", truth=True)
    as_platform(root, second="copy", b_offset_deg=0.05)
    result = run_variant(root, BORESIGHT)
    (rel,) = result.relative_mountings()
    assert (rel.sensor, rel.reference) == ("b", "a") and rel.prior is None
    assert np.all(np.abs(rel.boresight) < 3 * rel.boresight_sigma) and np.all(np.degrees(rel.boresight) < 0.005)
    c = result.checks
    for sid in ("01", "02"):
        a, b = c.strip == sid, c.strip == f"b{sid}"
        assert a.sum() == b.sum() > 0
        # b differs from a by the relative boresight the tie points determine (its sigma: a few thousandths of
        # a degree, hundredths of a pixel), far below the check residuals themselves
        for d in (c.pixel[b] - c.pixel[a], c.line[b] - c.line[a]):
            assert np.sqrt(np.mean(d**2)) < 0.05
    doc = result.orientation()
    assert doc.is_platform and set(doc.sensors) == {"a", "b"}
    assert doc.strip("b01").spline is not None and np.array_equal(doc.strip("b01").spline.coef,
                                                                  doc.strip("01").spline.coef)


def test_a_relative_mounting_prior_holds_a_sensor_without_measurements(small_block, tmp_path):
    """Sensor b has only check points: its boresight is the prior's, relative to a, and its precision the
    prior's combined with a's (a priori: the prior's sigma exactly when a's boresight is held fixed)."""
    prior = ('[[relative_mountings]]\nsensor = "b"\nreference = "a"\nboresight_deg = [0.0, 0.0, 0.0]\n'
             'boresight_sigma_deg = [0.002, 0.002, 0.004]\n\n')
    root = copy_project(small_block, tmp_path / "prior", truth=True)
    as_platform(root, second="checks", prior=prior, b_offset_deg=0.3)
    result = run_variant(root, BORESIGHT)
    values = result.adjustment.parameters
    assert np.allclose(values[Boresight("b")].values, values[Boresight("a")].values, atol=1e-8)  # the prior alone
    (rel,) = result.relative_mountings(posterior=False)
    assert (rel.sensor, rel.reference) == ("b", "a") and rel.prior is not None
    sig_a = result.adjustment.statistics.sigmas(Boresight("a"), posterior=False)
    # b = a + w with w the prior's noise (independent of a's): the relative rotation's sigma is the prior's
    assert np.allclose(rel.boresight_sigma, np.radians([0.002, 0.002, 0.004]), rtol=1e-6)
    assert np.all(np.isfinite(sig_a))
    c = result.checks
    a, b = c.strip == "01", c.strip == "b01"
    assert np.allclose(c.pixel[a], c.pixel[b], atol=1e-6)


@pytest.mark.parametrize("edit, message", [
    (lambda t: t.replace('sensor = "b"\nflight_line = "L01"', 'sensor = "c"\nflight_line = "L01"'),
     r"sensor 'c' is not a sensor of the project"),
    (lambda t: t.replace('flight_line = "L02"', 'flight_line = "L09"', 1),
     r"flight_line 'L09' is not a \[\[flight_lines\]\] id"),
    (lambda t: t.replace('sensor = "b"\nflight_line = "L01"', 'flight_line = "L01"'),
     r"missing sensor \(required with several sensors"),
    (lambda t: t + '[[relative_mountings]]\nsensor = "b"\nreference = "a"\nboresight_deg = [0.0, 0.0, 0.0]\n',
     r"\[relative_mountings\[0\]\.boresight_sigma_deg\]: missing"),
    (lambda t: t.replace("[[sensors]]\nid = \"a\"", "[sensor]"), r"expected one \[sensor\] table or \[\[sensors\]\]"),
])
def test_bad_platform_files_are_named_with_their_key(small_block, tmp_path, edit, message):
    root = copy_project(small_block, tmp_path / "bad")
    as_platform(root, second="copy")
    toml = root / "project.toml"
    toml.write_text(edit(toml.read_text()))
    with pytest.raises(ProjectFileError, match=message) as err:
        Project.load(root)
    assert str(toml) in str(err.value)


def test_strips_of_two_sensors_on_one_flight_line_must_overlap_in_time(small_block, tmp_path):
    root = copy_project(small_block, tmp_path / "apart")
    as_platform(root, second="copy")
    toml = root / "project.toml"
    text = toml.read_text()
    first = re.search(r'id = "b01"\n.*?first_line_time = ([0-9.]+)', text, re.S)
    moved = text[:first.start(1)] + str(float(first.group(1)) + 3600.0) + text[first.end(1):]
    toml.write_text(moved)
    with pytest.raises(ProjectFileError, match=r"strip 01 \(a, .*\) and strip b01 \(b, .*\) do not overlap in time"):
        Project.load(root).flight_line_stream("L01")


def test_the_propagation_of_a_displacement_is_the_joint_covariance(small_block, tmp_path):
    """``D Cov(x) D^T`` by the restricted solves equals the joint covariance of the blocks D selects, and a
    strip against itself has no relative displacement."""
    import scipy.sparse as sp

    from scangeo.adjustment.coregistration import _propagate, relative_displacement

    root = copy_project(small_block, tmp_path / "cov", truth=True)
    as_platform(root, second="copy")
    result = run_variant(root, BORESIGHT)
    layout = result.adjustment.solution.layout
    cols = np.concatenate([layout.columns(Boresight("b")), layout.columns(Boresight("a"))])
    D = sp.csr_matrix((np.array([1.0, -1.0, 2.0, 0.5]), (np.array([0, 0, 1, 1]), cols[[0, 3, 1, 5]])),
                      shape=(2, layout.n))
    C = result.adjustment.statistics.joint_covariance([Boresight("b"), Boresight("a")])
    dense = D[:, cols].toarray() @ C @ D[:, cols].toarray().T
    assert np.allclose(_propagate(result, D)[0], dense, rtol=1e-8, atol=1e-18)
    same = relative_displacement(result, "01", "01")
    assert same is not None and same.sigma.size > 0 and np.all(same.sigma < 1e-6)  # metres: the round trip


def test_the_coregistration_of_two_sensors_follows_their_relative_boresight(small_block, tmp_path):
    """Sensor b tied to a by the tie points alone, or by a tight relative-mounting prior: the relative
    displacement of their rays shrinks with the prior's sigma, and is far below each strip's absolute
    precision where b carries no measurement of its own."""
    from scangeo.adjustment.coregistration import coregistration, ground_precision

    loose = copy_project(small_block, tmp_path / "loose", truth=True)
    as_platform(loose, second="copy")
    tight = copy_project(small_block, tmp_path / "tight", truth=True)
    prior = ('[[relative_mountings]]\nsensor = "b"\nreference = "a"\nboresight_deg = [0.0, 0.0, 0.0]\n'
             'boresight_sigma_deg = [0.0001, 0.0001, 0.0001]\n\n')
    as_platform(tight, second="checks", prior=prior)
    by_ties, by_prior = (coregistration(run_variant(r, BORESIGHT)) for r in (loose, tight))
    assert [(c.strip, c.reference) for c in by_ties] == [("b01", "01"), ("b02", "02")]
    for c in by_ties + by_prior:
        assert c.sigma.size > 0 and np.all(np.isfinite(c.sigma)) and np.all(c.sigma > 0)
    assert max(c.summary()["median_m"] for c in by_prior) < min(c.summary()["median_m"] for c in by_ties)
    result = run_variant(tight, BORESIGHT)
    absolute = ground_precision(result, "b01")
    assert absolute is not None and np.median(absolute.sigma) > 5 * by_prior[0].summary()["median_m"]


def test_a_platform_variant_writes_its_mountings_and_coregistration(small_block, tmp_path):
    """report.json's platform section and coregistration.json: what the report and rectify read."""
    import json

    from scangeo.adjustment.outputs import write_results

    prior = ('[[relative_mountings]]\nsensor = "b"\nreference = "a"\nboresight_deg = [0.0, 0.0, 0.0]\n'
             'boresight_sigma_deg = [0.001, 0.001, 0.002]\n\n')
    root = copy_project(small_block, tmp_path / "written", truth=True)
    as_platform(root, second="checks", prior=prior, b_offset_deg=0.2)
    result = run_variant(root, BORESIGHT)
    folder = write_results(result)
    platform = json.loads((folder / "report.json").read_text())["platform"]
    assert set(platform["sensors"]) == {"a", "b"} and platform["flight_lines"] == {"L01": ["01", "b01"],
                                                                                    "L02": ["02", "b02"]}
    (rel,) = platform["relative_mountings"]
    assert rel["prior"]["boresight_sigma_deg"] == pytest.approx([0.001, 0.001, 0.002])
    assert np.allclose(rel["boresight_deg"], 0.0, atol=1e-6)
    b01 = platform["strips"]["b01"]
    assert b01["control_measurements"] == 0 and b01["coregistration"]["reference"] == "01"
    assert b01["ground_precision_m"]["median_m"] > b01["coregistration"]["median_m"] > 0
    grids = json.loads((folder / "coregistration.json").read_text())["strips"]
    assert [g["strip"] for g in grids] == ["b01", "b02"] and len(grids[0]["sigma_m"]) == grids[0]["n"] > 0
    doc = json.loads((folder / "orientation.json").read_text())
    assert doc["schema"] == "scangeo.orientation/2" and [s["id"] for s in doc["sensors"]] == ["a", "b"]
