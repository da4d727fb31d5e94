"""Small simulated projects built once per test session (registered in tests/conftest.py).

``small_block``: the ``small`` preset cut to 2 strips x 200 lines x 100 pixels, no rendered images
(3 s instead of a minute); each strip gets an 11-band uint8 image of a fixed pattern so that the
commands that read images (rectify) run. Tests copy it (``copy_project``) before changing anything.
"""
from __future__ import annotations

import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest

#: Preset overrides of ``small_block``: the smallest block on which every command runs.
SMALL_BLOCK = {
    "sensor": {"pixels": 100},
    "flight": {"lines": 200},
    "terrain": {"margin_m": 300.0},
    "output": {"images": False, "truth_ortho": False},
}


def write_strip_image(path: Path, lines: int, pixels: int, bands: int = 11, dtype: str = "uint8") -> None:
    """A raw scanner image (no georeferencing) of a fixed pattern."""
    import rasterio

    pattern = (np.arange(lines)[:, None] * 3 + np.arange(pixels)[None, :] * 7) % 251
    path.parent.mkdir(parents=True, exist_ok=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)
        with rasterio.open(path, "w", driver="GTiff", width=pixels, height=lines, count=bands, dtype=dtype) as dst:
            for band in range(bands):
                dst.write(((pattern + 20 * band) % 251).astype(dtype), band + 1)


@pytest.fixture(scope="session")
def small_block(tmp_path_factory) -> Path:
    """The session's small simulated project (read-only: copy it with ``copy_project``)."""
    from scangeo.simulate.block import simulate
    from scangeo.simulate.config import load_preset

    root = tmp_path_factory.mktemp("session") / "small"
    simulate(root, load_preset("small", SMALL_BLOCK))
    text = (root / "project.toml").read_text(encoding="utf-8")
    for sid in ("01", "02"):
        write_strip_image(root / "images" / f"{sid}.tif", SMALL_BLOCK["flight"]["lines"],
                          SMALL_BLOCK["sensor"]["pixels"])
        text = text.replace(f'id = "{sid}"\n', f'id = "{sid}"\nimage = "images/{sid}.tif"\n')
    (root / "project.toml").write_text(text, encoding="utf-8")
    return root


def copy_project(source: Path, target: Path, truth: bool = False) -> Path:
    """A writable copy of a project folder (without truth/ unless asked)."""
    ignore = None if truth else shutil.ignore_patterns("truth")
    shutil.copytree(source, target, ignore=ignore)
    return target


#: Two variants for ``scangeo compare`` on a project without a problem strip (no default variants needed).
TWO_VARIANTS = '[variants.DG]\nstrategy = "DG"\nsnooping = false\n\n[variants.SE]\nstrategy = "SE"\n'


@pytest.fixture(scope="session")
def compared_block(tmp_path_factory, small_block) -> Path:
    """A copy of ``small_block`` compared with DG and SE (results/, no report): read-only."""
    from scangeo.reports.comparison import compare_project
    from scangeo.reports.tables import write_comparison

    root = copy_project(small_block, tmp_path_factory.mktemp("session") / "compared", truth=True)
    (root / "variants.toml").write_text(TWO_VARIANTS, encoding="utf-8")
    write_comparison(compare_project(root))
    return root


#: Overrides of the ``laser`` preset for ``laser_block``: two overlapping strips, 300 m, 80 k returns.
LASER_BLOCK = {"strips": 2, "strip_length": 300.0, "pulse_rate_hz": 8000.0, "cross_strip": False}


@pytest.fixture(scope="session")
def laser_block(tmp_path_factory) -> Path:
    """A small simulated laser project (``scangeo lidar adjust`` runs on it): read-only."""
    from scangeo.cli import main

    root = tmp_path_factory.mktemp("session") / "laser"
    sets = [a for k, v in LASER_BLOCK.items() for a in ("--set", f"laser.{k}={str(v).lower()}")]
    assert main(["simulate", str(root), "--preset", "laser", *sets, "--no-progress"]) == 0
    return root
