"""The vienna2000 preset shows the physics the strategy comparison relies on (DESIGN section 7).

Measured with the oracle of scangeo.simulate.verify: the best each correction form can do when all
points act as control, i.e. what the injected GPS/IMU errors allow; an adjustment with real control
reaches at most this.
"""
from __future__ import annotations

import json

from scangeo.simulate.verify import oracle_table


def test_vienna2000_problem_strip_needs_time_dependent_corrections(vienna_geometry):
    root = vienna_geometry.root
    info = json.loads((root / "truth" / "errors.json").read_text())
    assert info["problem_strip"] == "02" and info["breaks_lines"] == [2400.0, 4900.0]
    fits = {(f.strip, f.strategy): f for f in oracle_table(root, ("DG", "SE", "P4", "S2"))}
    # direct georeferencing: several pixels (boresight, datum shifts)
    assert all(fits[(s, "DG")].rms_across > 2.0 for s in ("01", "02", "03"))
    # strip models: good strips below one pixel, the problem strip clearly worse across track
    for s in ("01", "03"):
        assert fits[(s, "SE")].rms_across < 0.6 and fits[(s, "SE")].rms_along < 0.6
    se = fits[("02", "SE")].rms_across
    assert se > 1.5 and se > 3 * max(fits[("01", "SE")].rms_across, fits[("03", "SE")].rms_across)
    # polynomial and split corrections can model it: at least 50 % better, split best
    assert fits[("02", "P4")].rms_across < 0.5 * se
    assert fits[("02", "S2")].rms_across < fits[("02", "P4")].rms_across
    # and the measurement noise (0.3 px) is the floor
    assert fits[("02", "S2")].rms_across > 0.2


def test_vienna2000_point_counts(vienna_geometry):
    pts = vienna_geometry.points
    for k in range(3):
        kinds = pts.kind[pts.m_point[pts.m_strip == k]]
        control_check = sum((kinds == q).sum() for q in "EBK")
        assert 75 <= control_check <= 100, (k, control_check)
    for k in range(2):  # tie points per overlap, each in both strips
        ties = set(pts.m_point[(pts.m_strip == k) & (pts.kind[pts.m_point] == "T")]) & set(
            pts.m_point[(pts.m_strip == k + 1) & (pts.kind[pts.m_point] == "T")])
        assert 55 <= len(ties) <= 60
