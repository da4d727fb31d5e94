"""Real inputs: a DTM file for the terrain, an orthophoto for the scene, a real trajectory's dynamics."""
from __future__ import annotations

import warnings

import numpy as np
import rasterio

from scangeo.simulate.block import simulate
from scangeo.simulate.config import TurbulenceConfig, load_preset
from scangeo.simulate.dynamics import ReplayDynamics
from tests.conftest import shared_file


def test_block_on_the_srtm_tile(tmp_path):
    dtm = shared_file("dtm/N44E005.hgt")
    config = load_preset("small", {"output": {"images": False, "truth_ortho": False}, "flight": {"lines": 200}})
    block = simulate(tmp_path / "ventoux", config, dtm_file=str(dtm))
    assert block.map_frame.crs.to_epsg() == 32631  # the UTM zone of 44.5 N 5.5 E, not the preset's
    with rasterio.open(tmp_path / "ventoux" / "truth" / "terrain.tif") as src:
        heights = src.read(1)
    assert 100.0 < heights.min() and heights.max() < 1912.0  # the Ventoux area (SRTM heights)
    assert heights.max() - heights.min() > 50.0
    # the flight is planned over the real terrain: 2200 m above its mean
    assert abs(block.plan.flight_height_m - 2200.0 - block.terrain.mean_height(block.ortho_extent)) < 60.0
    assert len(block.points.m_point) > 20


def test_block_with_an_orthophoto_texture(tmp_path):
    texture = shared_file("ortho/autzen.jpg")
    config = load_preset("small", {"flight": {"lines": 120}, "output": {"truth_ortho": False},
                                   "scene": {"texture_pixel_m": 0.3048}})
    simulate(tmp_path / "autzen", config, texture=str(texture))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)
        with rasterio.open(tmp_path / "autzen" / "images" / "01.tif") as src:
            image = src.read()
    assert image.shape == (11, 120, 716)
    assert image[2].std() > 100  # texture detail in green
    assert np.corrcoef(image[6].ravel(), image[2].ravel())[0, 1] < 0.99  # NIR is not a copy of green


def test_replayed_dynamics_of_the_real_trajectory():
    path = shared_file("trajectory/sbet_047_IGS08-UTM15N-Ellipsoid-trim.txt")
    dyn = ReplayDynamics.from_file(str(path), TurbulenceConfig(kind="replay", period_s=(2.0, 10.0)),
                                   np.random.default_rng(1))
    t = np.arange(0.0, 300.0, 0.02)
    v = dyn(t)
    roll_deg = np.degrees(v[:, 0])
    assert 0.3 < roll_deg.std() < 3.0  # real turbulence, without the turn (roll to -18 deg)
    assert np.abs(roll_deg).max() < 8.0
    assert np.abs(np.diff(roll_deg)).max() < 0.5  # continuous where the record is mirrored
