"""A simulated drone line written as a drone writes it (ENVI cube, .lcf, .times) goes through ``scangeo import lcf``
and ``scangeo run`` to the same orthoimage, with the same true ground error, as the same flight simulated as a
scangeo project.

The ``drone`` preset (cut to 400 lines x 300 pixels) with known truth; tests/importers/sensor_files.py writes its
strip in the drone's formats, by lcf_spec's words (roll right wing up, GPS seconds since the epoch, the line
times on another clock), apart from the importer. Both projects run with the same ground.csv and points.csv.
The true ground error of an orientation: its rays from a grid of image positions on the true terrain, against
the true ground points (truth/), horizontally.
"""
from __future__ import annotations

import json

import numpy as np
import pytest
import rasterio

from scangeo.cli import main
from scangeo.dtm import DTM
from scangeo.io.project import Project
from scangeo.orientation.file import load_adjusted_geometry
from scangeo.simulate.block import simulate
from scangeo.simulate.config import load_preset
from scangeo.truth.true_error import Truth
from tests.importers.sensor_files import lcf_line_of_project


@pytest.fixture(scope="module")
def both(tmp_path_factory):
    """(the simulated project, the imported one), each through scangeo run."""
    root = tmp_path_factory.mktemp("drone")
    sim = root / "simulated"
    simulate(sim, load_preset("drone", {"flight": {"lines": 400}, "sensor": {"pixels": 300}}))
    files = lcf_line_of_project(sim, "01", root / "drone_files")
    imported = root / "imported"
    assert main(["import", "lcf", str(files["cube"]), str(imported), "--look-angles", str(sim / "look_angles.csv"),
                 "--dtm", str(sim / "dtm.tif"), "--geoid", "30.5", "--altitude", "ellipsoidal",
                 "--ground", str(sim / "ground.csv"), "--measurements", str(sim / "points.csv"), "--crs", "EPSG:32633",
                 "--strip", "01", "--knot-spacing", "0.2", "--no-progress"]) == 0
    for project in (sim, imported):
        assert main(["run", str(project), "--no-progress"]) == 0
    return sim, imported


def _ground_error(project: Project, variant: str, truth: Truth) -> float:
    """rms (m) of the orientation's horizontal error on the true terrain over the truth's sample grid."""
    line, pixel, p_true = truth.samples("01")
    x_t, y_t, _ = truth.project.map_frame.project_to_map(p_true)
    g = project.geometry("01") if variant == "DG" else load_adjusted_geometry(project, variant, "01")
    terrain = DTM.open(truth.project.root / "truth" / "terrain.tif", project.map_frame)
    p, status = g.image_to_ground(line, pixel, terrain)
    x, y, _ = project.map_frame.project_to_map(p)
    ok = status == 0
    assert ok.sum() > 0.9 * len(line)
    return float(np.sqrt(np.mean((x[ok] - x_t[ok]) ** 2 + (y[ok] - y_t[ok]) ** 2)))


def test_the_imported_line_is_recommended_and_rectified_as_the_simulated_one(both):
    sim, imported = both
    runs = [json.loads((p / "results" / "run.json").read_text()) for p in both]
    chosen = [r["recommended"]["variant"] for r in runs]
    assert chosen[0] == chosen[1] != "DG"  # adjusted with the GCPs
    check = [r["recommended"]["check_rms_px"] for r in runs]
    assert check[1] == pytest.approx(check[0], rel=0.01)
    name = chosen[0]
    with rasterio.open(sim / "results" / name / "ortho" / "01.tif") as a, \
            rasterio.open(imported / "results" / name / "ortho" / "01.tif") as b:
        assert a.transform == b.transform and a.shape == b.shape and a.count == b.count
        va, vb = a.read(3, masked=True).astype(float), b.read(3, masked=True).astype(float)
    both_valid = ~va.mask & ~vb.mask
    assert both_valid.sum() > 0.99 * (~va.mask).sum()
    # the same cells, to interpolation between two splines of slightly different spans: 1 DN against a scene
    # of 35 DN standard deviation
    assert np.mean(np.abs(va - vb)[both_valid]) < 0.05 * np.std(va[both_valid])


def test_the_true_ground_error_is_that_of_the_simulated_project(both):
    """The same true ground error to 1 %: direct georeferencing (0.73 m: the GNSS's 1-2 m datum shift) and
    the recommended adjustment (0.11 m)."""
    sim, imported = both
    truth = Truth.load(Project.load(sim))
    assert truth is not None
    name = json.loads((sim / "results" / "run.json").read_text())["recommended"]["variant"]
    for variant in ("DG", name):
        e_sim = _ground_error(Project.load(sim), variant, truth)
        e_imp = _ground_error(Project.load(imported), variant, truth)
        assert e_imp == pytest.approx(e_sim, rel=0.01), (variant, e_sim, e_imp)
    assert _ground_error(Project.load(imported), name, truth) < 0.5 * _ground_error(Project.load(imported), "DG",
                                                                                     truth)
