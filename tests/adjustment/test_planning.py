"""Planning (``scangeo plan``): the reliability of a block from its planned geometry, no measurements."""
from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from scangeo.adjustment.planning import plan_block
from scangeo.adjustment.variants import Variant
from scangeo.cli import main

from .test_block import SHIFT_ONLY, _simulate

VARIANT = Variant("SHIFT", "SE", attitude_degree=-1, dtm_heights=True)


@pytest.fixture(scope="module")
def planned(tmp_path_factory):
    """The small simulated block without its measurements: planned trajectories and control only."""
    root = _simulate(tmp_path_factory.mktemp("plan") / "small", SHIFT_ONLY)
    (root / "points.csv").unlink()
    return root


def test_a_plan_needs_no_measurements_and_fits_them_exactly(planned):
    plan = plan_block(planned, VARIANT, tie_spacing_m=300.0)
    assert plan.tie_points >= 8 and plan.control_points >= 10
    stats = plan.result.adjustment.statistics
    assert stats.redundancy > 0 and stats.sigma0 < 1e-2      # the planned measurements are exact
    rel = plan.reliability.reliability
    assert set(rel.ext_positions) == {"01", "02"}
    assert all(np.all(np.isfinite(v)) and v.max() > 0 for v in rel.ext_positions.values())


def test_control_placed_in_the_weakest_area_strengthens_it(planned, tmp_path):
    before = plan_block(planned, VARIANT, tie_spacing_m=300.0)
    rel = before.reliability.reliability
    sid = max(rel.ext_positions, key=lambda s: rel.ext_positions[s].max())
    probe = next(p for p in before.reliability.probes if p.strip == sid)
    k = int(np.argmax(rel.ext_positions[sid]))
    x, y = probe.xy[k] + 0.1 * (probe.xy.mean(axis=0) - probe.xy[k])    # a little inside the image
    project = before.result.block.project
    H = float(project.dtm.height_at_map(np.array([x]), np.array([y]))[0])
    root = tmp_path / "more"
    shutil.copytree(planned, root, ignore=shutil.ignore_patterns("results"))
    with open(root / "ground.csv", "a") as f:
        f.write(f"NEW1,{x:.3f},{y:.3f},{H:.3f},0.05,0.08,control\n")
    after = plan_block(root, VARIANT, tie_spacing_m=300.0)
    new = after.reliability.reliability.ext_positions[sid]
    assert after.control_points == before.control_points + 1
    assert new[k] < 0.7 * rel.ext_positions[sid][k], (new[k], rel.ext_positions[sid][k])


def test_cli_plan_writes_the_weak_area_report(planned, capsys):
    assert main(["plan", str(planned), "--tie-spacing", "300", "--no-progress"]) == 0
    out = planned / "results" / "plan_SE"
    html = (out / "plan.html").read_text()
    assert html.count("<img") == 3 and "Weak areas" in html      # the block map and one map per strip
    summary = json.loads((out / "reliability.json").read_text())
    assert set(summary["positions"]) == {"01", "02"}
    assert (out / "points.csv").read_text().startswith("point,strip,line,pixel")
    assert "shifts its ground positions by up to" in capsys.readouterr().out
