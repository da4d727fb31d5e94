"""The laser adjustment (scangeo.lidar_adjust, scangeo run): bad input gives clear errors, interrupted runs
leave no final files, real data."""

from __future__ import annotations

import json

import laspy
import numpy as np
import pytest

from scangeo.cli import main
from scangeo.errors import InputFileError, LidarError
from scangeo.lidar import lasio
from scangeo.simulate.laser import LaserBlockConfig, simulate_laser
from scangeo.workflow import lidar_adjust
from tests.conftest import shared_file

TINY = LaserBlockConfig(
    strips=2, cross_strip=False, strip_length=240.0, pulse_rate_hz=12000.0, control_patches=3, check_patches=0
)


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    out = tmp_path_factory.mktemp("tiny-laser")
    simulate_laser(out, TINY)
    return out


def _copy(src, dst):
    import shutil

    shutil.copytree(src, dst)
    return dst


def test_las_without_gps_time_is_an_error_naming_the_file(tiny, tmp_path):
    project = _copy(tiny, tmp_path / "p")
    las = laspy.read(project / "strips" / "1.las")
    old = laspy.LasData(laspy.LasHeader(point_format=0, version="1.2"))
    old.header.offsets, old.header.scales = las.header.offsets, las.header.scales
    old.x, old.y, old.z = las.x, las.y, las.z
    old.write(project / "strips" / "1.las")
    with pytest.raises(InputFileError, match=r"1\.las: point format 0 has no GPS time"):
        lidar_adjust(project)
    assert main(["run", str(project), "--no-progress"]) == 1


def test_trajectory_not_covering_a_strip_is_an_error(tiny, tmp_path):
    project = _copy(tiny, tmp_path / "p")
    nav = project / "nav" / "2.csv"
    lines = nav.read_text().splitlines()
    nav.write_text("\n".join(lines[: len(lines) // 2]) + "\n")
    with pytest.raises(LidarError, match=r"strip 2: the returns' GPS times .* not covered by its trajectory .*2\.csv"):
        lidar_adjust(project)


def test_crs_differing_from_the_project_is_an_error(tiny, tmp_path):
    project = _copy(tiny, tmp_path / "p")
    text = (project / "project.toml").read_text().replace('crs = "EPSG:32633"', 'crs = "EPSG:32632"')
    (project / "project.toml").write_text(text)
    with pytest.raises(InputFileError, match=r"1\.las: CRS .*33N differs from the project's .*32N"):
        lidar_adjust(project)


def test_interrupted_run_leaves_no_las_under_a_final_name(tiny, tmp_path, monkeypatch):
    calls = {"n": 0}
    original = lasio.write_corrected

    def failing(files, psid, out, correct):
        def boom(xyz, t):
            calls["n"] += 1
            raise KeyboardInterrupt

        return original(files, psid, out, boom)

    monkeypatch.setattr("scangeo.lidar.evaluation.write_corrected", failing)
    out = tmp_path / "out"
    with pytest.raises(KeyboardInterrupt):
        lidar_adjust(tiny, corrected_strips=out)
    assert calls["n"] == 1
    assert not list(out.glob("*.la[sz]")) and not list(out.rglob(".*"))


def test_trajectory_free_mode_on_the_tiny_block(tiny, tmp_path):
    results = lidar_adjust(tiny, mode="points", patch_size=8.0)
    assert results.mode == "points"
    ev = results.evaluation["strip_differences_flat_rms_m"]
    assert ev["after"] < ev["before"]


def test_autzen_trajectory_free_mode_reports_strip_differences(tmp_path):
    """Real data: Autzen thin-1/thin-2 (nine flight lines, GPS time, no trajectory; NAD83(HARN) Oregon
    Lambert, international feet). At ~1 return per 1000 m^2 patches must be 60 m wide."""
    files = [shared_file("lidar/thin-1.las"), shared_file("lidar/thin-2.las")]
    strips = "".join(
        f'[[strips]]\nid = "{i}"\nlas = ["{files[0]}", "{files[1]}"]\npoint_source_id = {i}\n'
        for i in range(7326, 7335)
    )
    (tmp_path / "project.toml").write_text(
        '[project]\ncrs = "EPSG:2994"\n[sensor]\nkind = "laser"\nrange_sigma_m = 0.05\n'
        "[adjustment]\npatch_size = 60.0\nmax_patch_sigma = 0.15\nmin_patch_points = 8\n" + strips
    )
    results = lidar_adjust(tmp_path)
    assert results.mode == "points" and results.patches["tie"] >= 20
    assert any("grid cells are the patches" in n for n in results.notes)  # no scan lines left in a thinned cloud
    ev = results.evaluation["strip_differences_rms_m"]
    assert ev["cells"] >= 20 and 0.02 < ev["before"] < 0.2
    # no horizontal shift beyond the prior: flat patches do not determine them
    shifts = [abs(e.value) for e in results.corrections if e.component in ("x0", "y0")]
    assert max(shifts) < 1.0
    saved = json.loads(json.dumps(results.to_dict(), default=float))  # results.json
    assert saved["evaluation"]["strip_differences_rms_m"]["after"] == pytest.approx(ev["after"])
    assert np.isfinite(ev["after"])


def test_leeward_recovered_observations_reproduce_the_returns_to_the_documented_floor():
    """The leeward sample (docs/lidar.md section 5): with the boresight fitted there, the observations
    recovered by scangeo.lidar.georeference from points + SBET reproduce the returns from the file's
    whole-degree scan angles to the documented floor (~25 m at 4.7 km range)."""
    from scangeo.frames import MapFrame
    from scangeo.lidar.georeference import Calibration, TrajectorySampler, georeference, recover
    from scangeo.lidar.real_data import consistency, read_leeward_config
    from scangeo.rotation import matrix_to_rph, rph_to_matrix
    from scangeo.trajectory.readers import read_sbet

    sbet, las_path, config_path = (shared_file("lidar/leeward_sbet.out"), shared_file("lidar/leeward_points.las"),
                                   shared_file("lidar/leeward_config.toml"))
    fit = consistency(sbet, las_path, config_path, heading="true")
    config = read_leeward_config(config_path)
    stream = read_sbet(sbet)
    las = laspy.read(las_path)
    frame = MapFrame.centred_on(f"EPSG:{32600 + config.utm_zone}", float(np.mean(las.x)), float(np.mean(las.y)))
    sampler = TrajectorySampler(stream.to_project(frame.frame))
    # leeward's scanner frame (x = beam at scan angle 0, z = beam at +90 deg) from ours (x along, y right, z down)
    P = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    R = rph_to_matrix(*np.radians(list(fit["fit_deg"].values()))) @ rph_to_matrix(*config.boresight) @ P
    cal = Calibration.of(np.array(matrix_to_rph(R)), -np.asarray(config.lever_arm))
    points = frame.frame.geodetic_to_project(*np.radians(pyproj_latlon(las, config.utm_zone)), np.asarray(las.z))
    t = np.asarray(las.gps_time, float)
    polar = recover(points, t, sampler, cal)
    assert np.abs(georeference(*sampler.at(t), polar, cal) - points).max() < 1e-6   # exact with the given time
    polar.angle = np.radians(np.asarray(las.scan_angle_rank, float)) * (1.0 + fit["fit_scan_scale"])
    polar.along[:] = 0.0
    rms = float(np.sqrt(np.mean(np.sum((georeference(*sampler.at(t), polar, cal) - points) ** 2, axis=1))))
    assert rms == pytest.approx(fit["fit_rms_3d_m"], rel=0.05)
    assert 20.0 < rms < 30.0


def pyproj_latlon(las, zone: int):
    import pyproj

    to_geo = pyproj.Transformer.from_crs(32600 + zone, 4326, always_xy=True)
    lon, lat = to_geo.transform(np.asarray(las.x), np.asarray(las.y))
    return np.asarray(lat), np.asarray(lon)
