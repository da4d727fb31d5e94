"""``scangeo run`` on a laser project (docs/run.md, "Laser projects"): the stages check, patches, clean,
compare, apply, report on the session's small laser block (two strips, 80 k returns), run once per module."""
from __future__ import annotations

import json
import time

import laspy
import numpy as np
import pystac
import pytest
import rasterio
from pystac.extensions.pointcloud import PointcloudExtension
from pystac.extensions.projection import ProjectionExtension

from scangeo.cli import main
from scangeo.pipeline.laser import LASER_NAMES
from scangeo.pipeline.run import run
from scangeo.reports.stac_validation import validate_items
from tests.rectify.test_cog_properties import check_strict_cog
from tests.session_projects import copy_project


@pytest.fixture(scope="module")
def ran(laser_block, tmp_path_factory):
    root = copy_project(laser_block, tmp_path_factory.mktemp("laser-run") / "p")
    assert main(["run", str(root), "--no-progress"]) == 0
    return root


def test_a_run_writes_every_output(ran):
    manifest = json.loads((ran / "results" / "run.json").read_text())
    assert [n for n in manifest["stages"]] == list(LASER_NAMES)
    assert {s["status"] for s in manifest["stages"].values()} == {"ran"}
    recommended = manifest["recommended"]
    assert recommended["variant"] == "strip"
    assert recommended["corrected_strips"] == ["results/strips/1.laz", "results/strips/2.laz"]
    comparison = json.loads((ran / "results" / "comparison.json").read_text())
    rows = {r["variant"]: r for r in comparison["table"]}
    assert list(rows) == ["strip", "mission", "block"]  # the paper's models (no variants.toml)
    # one mission: the block's model is the mission's, adjusted once
    assert {k: v for k, v in rows["block"].items() if k not in ("variant", "strategy")} == \
        {k: v for k, v in rows["mission"].items() if k not in ("variant", "strategy")}
    assert any("the same adjustment as variant mission" in n for n in comparison["variants"]["block"]["notes"])
    report = (ran / "results" / "report.html").read_text()
    for part in ('id="patch-map"', 'id="strip-differences"', 'id="connectivity"', 'id="laser-t-tests"',
                 'id="laser-check-patches"', 'id="rejections"'):
        assert part in report, part
    with rasterio.open(ran / "results" / "differences.tif") as src:
        assert src.count == 2 and src.descriptions == ("before", "after")
        assert src.tags(ns="IMAGE_STRUCTURE").get("LAYOUT") == "COG"
        before, after = src.read(1), src.read(2)
    ok = np.isfinite(before) & np.isfinite(after)
    assert ok.sum() > 100 and np.sqrt(np.mean(after[ok] ** 2)) < 0.5 * np.sqrt(np.mean(before[ok] ** 2))


def test_the_overlap_height_differences_at_least_halve(ran):
    stages = json.loads((ran / "results" / "run.json").read_text())["stages"]
    applied = stages["apply"]["summary"]
    for key in ("strip_differences_rms_m", "strip_differences_flat_rms_m"):
        assert applied[key]["after"] < 0.5 * applied[key]["before"], key
    # the compare stage's figures are metres too: the recommended variant's are those it applied
    compared = stages["compare"]["summary"]["variants"][stages["apply"]["summary"]["variant"]]
    assert not any(k.endswith("_cm") for k in compared)
    assert compared["strip_differences_flat_rms_m"] == pytest.approx(applied["strip_differences_flat_rms_m"]["after"])
    results = json.loads((ran / "results" / "strip" / "results.json").read_text())
    ties = results["patches"]["tie"]
    assert sum(results["strips_per_patch"].values()) == ties and set(results["strips_per_patch"]) == {"2"}
    assert len([p for p in results["patch_map"] if p["kind"] == "tie"]) == ties


def test_the_items_and_the_difference_grid_are_valid_with_the_network_blocked(ran, no_network):
    items = sorted((ran / "results").rglob("*.stac.json"))
    assert len(items) == 2 and all(schemas[1:] == [PointcloudExtension.get_schema_uri(),
                                                   ProjectionExtension.get_schema_uri()]
                                   for schemas in validate_items(items).values())
    check_strict_cog(ran / "results" / "differences.tif")
    assert no_network == []


def test_corrected_strips_are_laz_with_their_returns_and_stac_items(ran, laser_block):
    for sid in ("1", "2"):
        original = laspy.read(laser_block / "strips" / f"{sid}.las")
        corrected = laspy.read(ran / "results" / "strips" / f"{sid}.laz")
        assert corrected.header.are_points_compressed
        assert np.array_equal(corrected.gps_time, original.gps_time)
        assert corrected.header.parse_crs() == original.header.parse_crs()
        shift = np.hypot(corrected.x - original.x, corrected.z - original.z)
        assert 0.005 < np.median(shift) < 1.0
        item = pystac.Item.from_file(str(ran / "results" / "strips" / f"{sid}.stac.json"))
        pc = PointcloudExtension.ext(item)
        assert pc.count == len(corrected.points) and pc.type == "lidar" and pc.encoding == "LASzip"
        assert "gps_time" in {s.name for s in pc.schemas}
        assert ProjectionExtension.ext(item).code == "EPSG:32633"
        assert item.assets["data"].href.endswith(f"{sid}.laz")
        lon, lat = np.array(item.geometry["coordinates"][0]).T
        assert 14.9 < lon.mean() < 15.1 and 47.8 < lat.mean() < 47.9  # UTM 33N, x 500 km, y 5300 km


def test_a_second_run_does_nothing(ran):
    started = time.process_time()
    result = run(ran)
    assert time.process_time() - started < 60
    assert {s.status for s in result.stages} == {"up to date"}


def test_an_edited_variants_file_reruns_from_clean(ran, tmp_path):
    root = copy_project(ran, tmp_path / "p")
    (root / "variants.toml").write_text('[variants.strip]\nstrategy = "SE"\nposition_degree = 1\nattitude_degree = 1\n')
    result = run(root)
    assert result.ran == ["clean", "compare", "apply", "report"]
    assert json.loads((root / "results" / "comparison.json").read_text())["recommended"] == "strip"
