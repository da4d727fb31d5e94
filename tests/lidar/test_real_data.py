"""Real data: the leeward sample recomputed from its SBET, boresight, scan angles and ranges."""
from __future__ import annotations

import numpy as np
import pytest

from scangeo.errors import InputFileError
from scangeo.lidar.real_data import consistency
from scangeo.trajectory.readers import read_sbet_records


def test_sbet_records_of_the_sample(leeward, tmp_path):
    nav = read_sbet_records(leeward / "leeward_sbet.out")
    assert len(nav) == 200
    assert np.degrees(nav["lat"][0]) == pytest.approx(37.7648, abs=1e-4)
    assert np.degrees(nav["lon"][0]) == pytest.approx(-119.0238, abs=1e-4)
    assert nav["alt"][0] == pytest.approx(6991.65, abs=0.01)
    assert np.degrees(nav["wander"][0]) == pytest.approx(1.0217, abs=1e-3)
    bad = tmp_path / "bad.out"
    bad.write_bytes(b"\0" * 100)
    with pytest.raises(InputFileError, match=r"bad.out record 1: truncated \(100 bytes of 136"):
        read_sbet_records(bad)


def test_leeward_consistency(leeward, run_lidar_json):
    r = run_lidar_json(["lidar", "check-returns", "--sbet", str(leeward / "leeward_sbet.out"),
                        "--las", str(leeward / "leeward_points.las"), "--system", str(leeward / "leeward_config.toml")])
    assert r["returns"] == 1325
    assert r["mean_range_m"] == pytest.approx(4661.5, abs=1.0)
    # with the configured boresight the returns are off by hundreds of metres (mostly north) ...
    assert r["rms_3d_m"] == pytest.approx(325.0, abs=2.0)
    # ... explained by an 11.2 deg yaw and 1.7 deg pitch of the scan plane and a 2.4 % scan-angle scale
    assert r["fit_deg"]["boresight_yaw"] == pytest.approx(11.18, abs=0.05)
    assert r["fit_deg"]["boresight_pitch"] == pytest.approx(-1.71, abs=0.05)
    assert r["fit_scan_scale"] == pytest.approx(0.0241, abs=0.001)
    # after the fit what is left is the rounding of the LAS scan angles to whole degrees
    assert r["fit_rms_3d_m"] == pytest.approx(25.28, abs=0.05)
    assert r["fit_rms_3d_m"] < 1.1 * r["expected_rms_from_whole_degree_scan_angles_m"]


def test_true_heading_fits_the_same_after_boresight_absorbs_wander(leeward):
    d = leeward
    platform = consistency(d / "leeward_sbet.out", d / "leeward_points.las", d / "leeward_config.toml", "platform")
    true = consistency(d / "leeward_sbet.out", d / "leeward_points.las", d / "leeward_config.toml", "true")
    assert true["rms_3d_m"] > platform["rms_3d_m"]            # the heading field fits the points better
    # a constant heading change is a boresight yaw: the fit absorbs the ~1 deg wander angle
    assert true["fit_deg"]["boresight_yaw"] - platform["fit_deg"]["boresight_yaw"] == pytest.approx(1.0, abs=0.1)
    assert true["fit_rms_3d_m"] == pytest.approx(platform["fit_rms_3d_m"], abs=0.05)
