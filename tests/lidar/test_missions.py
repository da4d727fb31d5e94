"""Missions in a laser project.toml and the GPS/IMU model variants built by the shared builder
(scangeo.orientation.models): per strip, per mission, for the block; control patches with a check
point and height-only control planes."""

from __future__ import annotations

import json
import logging
import shutil

import numpy as np
import pytest

from scangeo.adjustment.variants import laser_variant, read_variants
from scangeo.errors import ProjectFileError
from scangeo.io.project import Project
from scangeo.lidar.adjust import LaserOptions, build, run
from scangeo.lidar.evaluation import control_check_points
from scangeo.orientation.models import Correction
from scangeo.strategy.laser import compare_laser, write_laser_comparison
from tests.session_projects import laser_block  # noqa: F401  (session fixture)


def with_missions(src, dst, missions: dict[str, str]):
    """A copy of a laser project whose [[strips]] carry ``mission = ...``."""
    shutil.copytree(src, dst)
    text = (dst / "project.toml").read_text()
    for sid, mission in missions.items():
        text = text.replace(f'[[strips]]\nid = "{sid}"\n', f'[[strips]]\nid = "{sid}"\nmission = "{mission}"\n')
    (dst / "project.toml").write_text(text)
    return dst


@pytest.fixture(scope="module")
def found(laser_block):  # noqa: F811
    """The patches of the session's laser block, found once for every variant below."""
    logging.getLogger("scangeo.lsq.solver").setLevel(logging.ERROR)
    return build(Project.load(laser_block), LaserOptions(), laser_variant(), laser_block / "ground.csv").found


def estimate(root, found, models):
    project = Project.load(root)
    strategy = {"strip": "SE", "mission": "ME", "block": "BE"}[models]
    variant = laser_variant(models, strategy=strategy, position_degree=0, attitude_degree=0)
    block = build(project, LaserOptions(), variant, root / "ground.csv", found=found)
    return block, run(block)


def test_one_strip_per_mission_is_the_strip_model(laser_block, found, tmp_path):  # noqa: F811
    root = with_missions(laser_block, tmp_path / "p", {"1": "A", "2": "B"})
    assert [s.mission for s in Project.load(root).strips] == ["A", "B"]
    by_strip, r_strip = estimate(root, found, models="strip")
    by_mission, r_mission = estimate(root, found, models="mission")
    assert [m.id for m in by_mission.models] == ["mission A", "mission B"]
    v_s, v_m = r_strip.parameters.values(), r_mission.parameters.values()
    for sid, mission in (("1", "A"), ("2", "B")):
        assert np.allclose(v_s[Correction(sid)], v_m[Correction(f"mission {mission}")], atol=1e-9)
    assert r_strip.statistics.sigma0 == pytest.approx(r_mission.statistics.sigma0, rel=1e-9)


def test_one_mission_for_all_strips_is_the_block_model(laser_block, found):  # noqa: F811
    project = Project.load(laser_block)  # no mission keys: every strip in mission "1"
    assert {s.mission for s in project.strips} == {"1"}
    block_b, r_block = estimate(laser_block, found, models="block")
    block_m, r_mission = estimate(laser_block, found, models="mission")
    assert len(block_m.models) == 1 and block_m.models.models["mission 1"].strips == ("1", "2")
    assert np.allclose(r_block.parameters.values()[Correction("block")],
                       r_mission.parameters.values()[Correction("mission 1")], atol=1e-9)
    # one shift and misalignment for both strips fits worse than one per strip
    _, r_strip = estimate(laser_block, found, models="strip")
    assert r_mission.statistics.sigma0 > 1.05 * r_strip.statistics.sigma0


def test_a_mission_that_is_not_a_name_is_an_error(laser_block, tmp_path):  # noqa: F811
    root = tmp_path / "p"
    shutil.copytree(laser_block, root)
    text = (root / "project.toml").read_text()
    text = text.replace('[[strips]]\nid = "1"\n', '[[strips]]\nid = "1"\nmission = [1]\n')
    (root / "project.toml").write_text(text)
    with pytest.raises(ProjectFileError, match=r"mission"):
        Project.load(root)


def test_fourth_roof_point_as_check_and_height_control_planes(laser_block, found, tmp_path):  # noqa: F811
    """The paper's control: four surveyed points per roof patch, the fourth a check point; flat control
    patches turned into height-only control planes (sports fields)."""
    lines = (laser_block / "ground.csv").read_text().splitlines()
    out = [lines[0]]
    for line in lines[1:]:
        cells = line.split(",")
        if cells[1] in ("C3", "C6"):  # the flat control patches (every third patch is on open ground)
            cells[-1] = "height"
        elif cells[-1] == "control" and cells[0].endswith(".4"):
            cells[-1] = "check"
        out.append(",".join(cells))
    ground = tmp_path / "ground.csv"
    ground.write_text("\n".join(out) + "\n")
    block = build(Project.load(laser_block), LaserOptions(), laser_variant(), ground, found=found)
    kinds = dict(zip(block.frames.ids, block.kinds))
    assert kinds.get("C3") == "height" and kinds.get("C1") == "control"
    assert {g.name for g in block.groups} >= {"control patches", "height control planes"}
    result = run(block)
    before = control_check_points(block, block.parameters.values())
    after = control_check_points(block, result.parameters.values())
    assert set(after) == {f"C{i}.4" for i in (1, 2, 4, 5, 7, 8) if f"C{i}" in kinds}
    rms = np.sqrt(np.mean(np.square(list(after.values()))))
    assert rms < 0.02 and np.sqrt(np.mean(np.square(list(before.values())))) > 2 * rms


def test_variants_side_by_side(laser_block, found, tmp_path):  # noqa: F811
    """The paper's variants on the same patches, one table (strategy.laser; scangeo run's compare stage)."""
    variants = tmp_path / "variants.toml"
    variants.write_text('[variants.mission]\nstrategy = "ME"\nposition_degree = 0\nattitude_degree = 0\n\n'
                        '[variants.strip]\nstrategy = "SE"\nposition_degree = 1\nattitude_degree = 1\n')
    comparison = compare_laser(laser_block, read_variants(variants, "laser"), found=found)
    write_laser_comparison(tmp_path, comparison)
    saved = json.loads((tmp_path / "results" / "comparison.json").read_text())
    assert list(saved["variants"]) == ["mission", "strip"] and saved["sensor"] == "laser"
    assert saved["variants"]["mission"]["options"]["strategy"] == "ME"
    keys = [p["key"] for p in saved["variants"]["mission"]["parameters"] if p["component"] == "x0"]
    assert keys == ["Correction(model=mission 1)"]
    # one shift and misalignment for both strips leaves more of the strip differences than a model per strip
    flat = {n: r["evaluation"]["strip_differences_flat_rms_m"]["after"] for n, r in saved["variants"].items()}
    assert flat["strip"] < flat["mission"]
    assert saved["recommended"] == "strip" and "strip differences" in saved["why"]
    assert (tmp_path / "results" / "strip" / "results.json").exists()
    bad = tmp_path / "bad.toml"
    bad.write_text('[variants.x]\nstrategy = "SE"\ncalibrate = ["time_offset"]\n')
    with pytest.raises(ProjectFileError, match=r"bad.toml \[variants.x.calibrate\].*laser"):
        read_variants(bad, "laser")
