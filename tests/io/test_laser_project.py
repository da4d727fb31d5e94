"""One project.toml schema for both sensors: laser projects through :class:`scangeo.io.project.Project`,
their bad input, and laser variants in variants.toml (read, written, read back)."""
from __future__ import annotations

from pathlib import Path

import pytest

from scangeo.adjustment.variants import LASER_DEFAULTS, builtin_variants, laser_variant, laser_variants, read_variants
from scangeo.errors import ProjectFileError
from scangeo.io.project import Project

LASER = """[project]
crs = "EPSG:32633"
origin = [47.85, 15.0, 0.0]

[sensor]
kind = "laser"
boresight_deg = [0.01, 0.0, 0.0]
lever_arm_m = [0.1, -0.2, 0.3]
range_sigma_m = 0.03
fov_deg = 40.0

[adjustment]
patch_size = 8.0

[[strips]]
id = 1
las = "strips/1.laz"
trajectory = "nav/1.csv"
mission = "A"

[[strips]]
id = "2"
las = ["strips/2a.laz", "strips/2b.laz"]
point_source_id = 7
"""


def write(tmp_path: Path, text: str) -> Path:
    (tmp_path / "project.toml").write_text(text, encoding="utf-8")
    return tmp_path


def test_a_laser_project_loads_through_the_one_schema(tmp_path):
    p = Project.load(write(tmp_path, LASER))
    assert p.is_laser and p.kind == "laser" and p.laser.range_sigma_m == 0.03
    assert p.laser.boresight_deg == (0.01, 0.0, 0.0) and p.laser.info == {"fov_deg": 40.0}
    one, two = p.strips
    assert one.id == "1" and one.las == (tmp_path / "strips/1.laz",) and one.mission == "A" and one.has_trajectory
    assert two.las == (tmp_path / "strips/2a.laz", tmp_path / "strips/2b.laz") and two.point_source_id == 7
    assert two.mission == "1" and not two.has_trajectory and not p.has_trajectories
    assert p.adjustment == {"patch_size": 8.0}
    with pytest.raises(ProjectFileError, match=r"project.toml \[project.dtm\]: missing"):
        p.dtm_path  # noqa: B018 (the property raises)
    with pytest.raises(ProjectFileError, match=r"project.toml \[sensor.kind\]: a laser project"):
        p.sensor  # noqa: B018


@pytest.mark.parametrize("old, new, expected", [
    ('las = "strips/1.laz"\n', "", r"\[strips\[0\]\] \(id 1\): missing las"),
    ('las = "strips/1.laz"\n', 'las = []\n', r"\[strips\[0\].las\]: expected a file name"),
    ('mission = "A"\n', 'mission = "A"\nfirst_line_time = 3.0\n', r"first_line_time is not a key of a laser strip"),
    ('range_sigma_m = 0.03\n', 'range_sigma_m = 0.03\npixels = 3\n', r"\[sensor.pixels\]: not a key when kind"),
    ('fov_deg = 40.0\n', 'fov_deg = 40.0\nfocal_length_mm = 3.0\n', r"\[sensor.focal_length_mm\]: not a key"),
    ("patch_size = 8.0\n", 'models = "mission"\n', r"\[adjustment.models\]: a key of the variants"),
    ('kind = "laser"', 'kind = "lidar"', r"\[sensor.kind\]"),
])
def test_bad_laser_projects_are_errors_naming_the_key(tmp_path, old, new, expected):
    assert old in LASER
    root = write(tmp_path, LASER.replace(old, new, 1))
    with pytest.raises(ProjectFileError, match=expected):
        p = Project.load(root)
        from scangeo.strategy.laser import laser_options

        laser_options(p)


def test_image_keys_and_laser_keys_stay_with_their_kind(tmp_path):
    image = ('[project]\ncrs = "EPSG:32633"\ndtm = "dtm.tif"\n[sensor]\nkind = "whiskbroom"\npixels = 10\n'
             'line_rate_hz = 10.0\nfov_deg = 60.0\n[[strips]]\nid = "1"\ntrajectory = "nav/1.csv"\n'
             'first_line_time = 0.0\n')
    p = Project.load(write(tmp_path, image))
    assert p.kind == "whiskbroom" and not p.is_laser and p.strips[0].mission == "1"
    with pytest.raises(ProjectFileError, match=r"a whiskbroom project; this needs a laser project"):
        p.laser  # noqa: B018
    for text, expected in (
        (image.replace('dtm = "dtm.tif"\n', ""), r"\[project.dtm\]: missing \(required for a whiskbroom"),
        (image.replace("pixels = 10\n", ""), r"\[sensor.pixels\]: missing \(required for a whiskbroom\)"),
        (image + 'las = "a.las"\n', r"las is a key of laser strips only"),
        (image + "[adjustment]\npatch_size = 3.0\n", r"\[adjustment\]: a table of laser projects only"),
        (image.replace('trajectory = "nav/1.csv"\n', ""), r"missing trajectory \(required for a whiskbroom\)"),
        (image.replace('fov_deg = 60.0\n', 'fov_deg = 60.0\nrange_sigma_m = 0.1\n'),
         r"\[sensor.range_sigma_m\]: not a key when kind is not 'laser'"),
    ):
        with pytest.raises(ProjectFileError, match=expected):
            Project.load(write(tmp_path, text))


def test_laser_variants_round_trip_with_the_laser_defaults(tmp_path):
    path, paper = laser_variants(tmp_path)  # no variants.toml: the paper's models
    assert path.name == "laser_variants.toml" and list(paper) == ["strip", "mission", "block"]
    assert [v.strategy for v in paper.values()] == ["SE", "ME", "BE"]
    assert builtin_variants("laser") == paper
    strip = paper["strip"]
    assert (strip.position_degree, strip.attitude_degree) == (1, 1) and strip.calibrate == ("boresight",)
    for key, value in LASER_DEFAULTS.items():
        got = getattr(strip, key)
        assert (list(got) if isinstance(got, tuple) else got) == value, key
    assert laser_variant() == paper["strip"].__class__(**{**strip.__dict__, "description": ""})
    # written as a variants.toml of the project, read back: the same variants, the file's [defaults] over the laser's
    (tmp_path / "variants.toml").write_text(
        '[defaults]\ncoefficient_sigma_m = 0.2\n\n[variants.split]\nstrategy = "S"\nposition_degree = 1\n'
        'calibrate = ["boresight", "range_offset"]\n[[variants.split.strip]]\nid = 3\nbreaks_times = [400105.5]\n',
        encoding="utf-8")
    path, mine = laser_variants(tmp_path)
    assert path == tmp_path / "variants.toml" and list(mine) == ["split"]
    split = mine["split"]
    assert split.coefficient_sigma_m == 0.2 and split.coefficient_sigma_deg == 0.01
    assert split.calibrate == ("boresight", "range_offset") and split.strip_models("3").breaks_times == (400105.5,)
    with pytest.raises(ProjectFileError, match=r"\[variants.split.calibrate\]: 'range_offset' is not a calibration "
                                               r"unknown of an image project"):
        read_variants(path)  # an image project reads the same file without the laser's unknowns


def test_a_laser_preset_refuses_image_arguments_naming_them(tmp_path):
    from scangeo.workflow import simulate_project

    for kwargs, name in (({"dtm": "dtm.tif"}, "dtm"), ({"images": False}, "images"), ({"texture": "t.tif"}, "texture")):
        with pytest.raises(ProjectFileError, match=rf"laser.toml: a laser preset has no images, DTM or texture; "
                                                   rf"cannot use {name}"):
            simulate_project(tmp_path / "out", "laser", **kwargs)
        assert not (tmp_path / "out").exists()
    (tmp_path / "full").mkdir()
    (tmp_path / "full" / "x").write_text("x")
    with pytest.raises(ProjectFileError, match=r"full: the folder exists and is not empty"):
        simulate_project(tmp_path / "full", "laser")


def test_info_summarises_a_laser_project(laser_block):
    import laspy

    from scangeo.io.summary import summarise_project, summary_text

    s = summarise_project(laser_block)
    assert s["kind"] == "laser project" and s["sensor"]["kind"] == "laser" and s["crs"] == "EPSG:32633"
    assert [t["id"] for t in s["strips"]] == ["1", "2"]
    for t in s["strips"]:
        f = t["files"][0]
        with laspy.open(f["path"]) as las:
            assert f["returns"] == las.header.point_count > 10000
        assert t["trajectory"]["records"] > 100 and "error" not in t
    assert "laser project:" in summary_text(s)
