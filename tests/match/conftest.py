"""Simulated blocks with rendered images for the matching tests (made once per test session).

Both are the ``small`` preset cut to 300 lines (2 strips x 300 lines x 716 pixels, one overlap of
about 600 m x 750 m): ``landcover_block`` with the procedural scene, ``texture_block`` with the
real orthophoto ../shared/data/ortho/autzen.jpg as the scene (skipped when it is absent).
Tests copy them (``copy_project``) before changing anything.
"""
from __future__ import annotations

from pathlib import Path

import pytest

from tests.conftest import shared_file

#: preset overrides of the matching blocks
MATCH_BLOCK = {"flight": {"lines": 300}, "terrain": {"margin_m": 500.0}}


def _simulate(root: Path, texture: Path | None = None) -> Path:
    from scangeo.simulate.block import simulate
    from scangeo.simulate.config import load_preset

    simulate(root, load_preset("small", MATCH_BLOCK), texture=str(texture) if texture else None)
    return root


@pytest.fixture(scope="session")
def landcover_block(tmp_path_factory) -> Path:
    return _simulate(tmp_path_factory.mktemp("match") / "landcover")


@pytest.fixture(scope="session")
def texture_block(tmp_path_factory) -> Path:
    texture = shared_file("ortho/autzen.jpg")
    return _simulate(tmp_path_factory.mktemp("match") / "texture", texture)
