"""``scangeo run`` on a platform of a laser and a pushbroom (``platform_quick``): every variant adjusted jointly.

The run's recommended variant, whose orientation.json the run wrote from the joint adjustment of the images'
points and the laser's patches, puts the image strips closer to the simulated truth than the imager alone adjusted
with the same variant; its laser strips' differences on flat cells are no worse than the laser alone's with that
variant; BE, which the joint block cannot take, stands in the comparison as failed with its reason; the report has
the laser section.
"""
from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from scangeo.adjustment.results import run_variant
from scangeo.adjustment.variants import read_variants
from scangeo.io.project import Project
from scangeo.lidar.adjust import build, run
from scangeo.lidar.evaluation import apply, evaluate
from scangeo.lidar.found_io import read_found
from scangeo.lidar.joint import laser_part
from scangeo.lidar.options import LaserOptions
from scangeo.orientation.file import load_orientation
from scangeo.pipeline.laser import FOUND
from scangeo.pipeline.run import run as run_pipeline
from scangeo.pipeline.stages import VARIANTS_MARKER
from scangeo.truth.true_error import Truth

#: BE (refused by the joint block), SE and a degree-1 position polynomial per flight line; two folds (a short run)
VARIANTS = """[defaults]
gps_sigma_m = [0.05, 0.05, 0.10]
imu_sigma_deg = [0.003, 0.003, 0.005]
constant_sigma_m = 5.0
snooping = false

[variants.BE]
strategy = "BE"

[variants.SE]
strategy = "SE"

[variants.P1]
strategy = "P"
position_degree = 1
"""


@pytest.fixture(scope="module")
def platform_run(platform_block, tmp_path_factory):
    """The run to the diagnosis (which writes variants.toml), then with this module's variants to the end."""
    root = tmp_path_factory.mktemp("platform_run") / "platform"
    shutil.copytree(platform_block.root, root)
    (root / "run.toml").write_text("[compare]\nfolds = 2\n")
    diagnosed = run_pipeline(root, until="diagnose")
    written = (root / "variants.toml").read_text(), read_variants(root / "variants.toml")
    (root / "variants.toml").write_text(VARIANTS)
    return root, run_pipeline(root), diagnosed, written


def test_the_diagnosis_adds_the_lasers_variants(platform_run):
    """A variants.toml the run writes on such a platform has the per flight line polynomials the laser observes."""
    _, _, diagnosed, written = platform_run
    assert diagnosed.ran == ["check", "patches", "clean", "diagnose"]
    text, variants = written
    assert text.startswith(VARIANTS_MARKER) and {"SE", "P1_LINES", "P2_LINES"} <= set(variants)
    assert (variants["P1_LINES"].position_degree, variants["P2_LINES"].position_degree) == (1, 2)


def _ground_error(project: Project, truth: Truth, geometry) -> float:
    """rms over the image strips of the true horizontal ground error (m) of an orientation."""
    return float(np.sqrt(np.mean([truth.error(s.id, geometry(s.id)).rms_ground_m ** 2
                                  for s in project.image_strips])))


def test_the_run_takes_the_platform_end_to_end(platform_run):
    root, result, _, _ = platform_run
    assert result.ran == ["compare", "apply", "report"]  # the rest up to date
    compare = result.summary_of("compare")
    assert "joint adjustment takes per flight line models" in compare["variants"]["BE"]["error"]
    assert compare["recommended"] in ("SE", "P1")
    table = (root / "results" / "comparison.md").read_text()
    assert "| BE | BE | failed: variant BE: the joint adjustment" in table
    applied = result.summary_of("apply")
    assert applied["variant"] == compare["recommended"]
    assert all((root / s).exists() for s in applied["strips"]) and len(applied["strips"]) == 3


def test_the_joint_orientation_beats_the_imager_alone(platform_run):
    """The recommended variant's orientation.json (the run's joint adjustment) against the imager alone with the
    same variant, in true ground error over the image strips."""
    root, result, _, _ = platform_run
    name = result.recommended
    project = Project.load(root)
    truth = Truth.load(project)
    joint = _ground_error(project, truth, load_orientation(project, name).geometry)
    alone = run_variant(project, read_variants(root / "variants.toml")[name])
    assert joint < _ground_error(project, truth, alone.geometry)
    true = json.loads((root / "results" / "comparison.json").read_text())
    reported = {v["name"]: v for v in true["variants"]}[name]["strips"]
    # the comparison's true error is that of the written orientation (the same joint solution)
    for s in project.image_strips:
        assert reported[s.id]["true"]["rms_ground_m"] == pytest.approx(
            truth.error(s.id, load_orientation(project, name).geometry(s.id)).rms_ground_m, rel=1e-6)


def test_the_laser_strips_no_worse_than_the_laser_alone(platform_run):
    root, result, _, _ = platform_run
    name = result.recommended
    project = Project.load(root)
    report = json.loads((root / "results" / name / "report.json").read_text())
    mine = report["laser"]["strip_differences_flat_rms_m"]
    view = laser_part(project)
    block = build(view, LaserOptions.from_table(project.adjustment, str(project.file)),
                  read_variants(root / "variants.toml")[name], root / "patches.csv", found=read_found(root / FOUND))
    laser = run(block)
    alone = evaluate(block, laser, apply(block, laser.parameters.values())).summary()["strip_differences_flat_rms_m"]
    # the joint's laser side is what the apply stage measured on the corrected strips
    assert result.summary_of("apply")["strip_differences_flat_rms_m"]["after"] == pytest.approx(mine["after"], rel=1e-9)
    assert mine["after"] <= 1.05 * alone["after"] and mine["after"] < 0.5 * mine["before"]
    strips = report["laser"]["strips"]
    assert set(strips) == {s.id for s in project.laser_strips}
    assert all(s["after_m"] < s["before_m"] for s in strips.values() if s["flat_cells"])


def test_the_report_has_the_laser_section(platform_run):
    root, result, _, _ = platform_run
    html = (root / "results" / "report.html").read_text()
    assert 'id="laser"' in html and "lidar-02" in html
    assert "lidar (laser)" in html  # the platform section's sensors table lists the laser


def test_scangeo_compare_alone_adjusts_jointly_as_the_run_does(platform_run, tmp_path):
    """The compare command on the platform (its own patch search) gives the run's joint figures."""
    import scangeo

    root, result, _, _ = platform_run
    copy = tmp_path / "platform"
    shutil.copytree(root, copy, ignore=shutil.ignore_patterns("results"))
    c = scangeo.compare(copy, variants_file=copy / "variants.toml", names=["SE"], folds=0, report=False).comparison
    assert c.strips == [s.id for s in Project.load(copy).image_strips]
    assert c.variant("SE").sigma0 == pytest.approx(result.summary_of("compare")["variants"]["SE"]["sigma0"], rel=1e-9)
    laser = json.loads((copy / "results" / "SE" / "report.json").read_text())["laser"]
    assert laser["strip_differences_flat_rms_m"]["after"] < 0.5 * laser["strip_differences_flat_rms_m"]["before"]
