"""Small simulated projects built once per test session (registered in tests/conftest.py).

``problem_small`` (a three-strip block with a problem strip) and ``compared_small`` (it compared with
the default variants and reported) serve the diagnosis, strategy and report tests.

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


@pytest.fixture(scope="session")
def platform_block(tmp_path_factory, small_block) -> Path:
    """``small_block`` written as a platform of two sensors (``as_platform(second="copy")``): read-only."""
    root = copy_project(small_block, tmp_path_factory.mktemp("session") / "platform", truth=True)
    as_platform(root, second="copy")
    return root


def copy_project(source: Path, target: Path, truth: bool = False) -> Path:
    """A writable copy of a project folder (without truth/ unless asked)."""
    ignore = None if truth else shutil.ignore_patterns("truth")
    shutil.copytree(source, target, ignore=ignore)
    return target


def as_platform(root, second: str | None = None, prior: str = "", b_offset_deg: float = 0.0) -> None:
    """Rewrite a one-sensor project as a platform: sensor ``a``, flight lines ``L01``, ``L02`` with the
    strips' trajectories; with ``second``, a sensor ``b`` (the same scanner, its boresight off by
    ``b_offset_deg`` in roll) with strips ``b01``, ``b02`` on the same flight lines, measured as
    ``second`` says: ``"copy"`` (every measurement of a's strips but those of control points) or
    ``"checks"`` (only the check points'). The second sensor is the first one again: what it must get from
    the platform is then known exactly (tests/adjustment/test_platform.py)."""
    import re

    from scangeo.io.points import ImagePoints

    text = (root / "project.toml").read_text()
    sensor = re.search(r"\[sensor\]\n(.*?)\n\n", text, re.S).group(1)
    strips = re.findall(r"\[\[strips\]\]\n(.*?)(?=\n\n|\Z)", text, re.S)
    out = [text[:text.index("[sensor]")], "[[sensors]]\nid = \"a\"\n" + sensor + "\n\n"]
    if second:
        b = re.sub(r"boresight_deg = \[([^,]+),", lambda m: f"boresight_deg = [{float(m.group(1)) + b_offset_deg},",
                   sensor) if "boresight_deg" in sensor else sensor + f"\nboresight_deg = [{b_offset_deg}, 0.0, 0.0]"
        out.append("[[sensors]]\nid = \"b\"\n" + b + "\n\n")
    out.append(prior)
    for body in strips:
        sid = re.search(r'id = "([^"]+)"', body).group(1)
        traj = re.search(r'trajectory = "([^"]+)"', body).group(1)
        out.append(f'[[flight_lines]]\nid = "L{sid}"\ntrajectory = "{traj}"\n\n')
        for name in ("trajectory", "errors"):  # the truth of a simulated block is the flight lines'
            truth = root / "truth" / f"{name}_{sid}.csv"
            if truth.exists():
                shutil.copy(truth, truth.with_name(f"{name}_L{sid}.csv"))
    for body in strips:
        sid = re.search(r'id = "([^"]+)"', body).group(1)
        rest = re.sub(r'trajectory = "[^"]+"\n?', "", body).strip()
        out.append(f"[[strips]]\n{rest}\nsensor = \"a\"\nflight_line = \"L{sid}\"\n\n")
        if second:
            rest_b = rest.replace(f'id = "{sid}"', f'id = "b{sid}"')
            out.append(f"[[strips]]\n{rest_b}\nsensor = \"b\"\nflight_line = \"L{sid}\"\n\n")
    (root / "project.toml").write_text("".join(out))
    if second:
        points = ImagePoints.read(root / "points.csv")
        roles = dict(line.split(",")[0::6] for line in (root / "ground.csv").read_text().splitlines()[1:])
        role = [roles.get(str(p), "tie") for p in points.point]
        keep = [i for i, r in enumerate(role) if r == "check" or (second == "copy" and r != "control")]
        rows = (root / "points.csv").read_text().splitlines()
        extra = []
        for i in keep:
            cells = rows[points.file_line[i] - 1].split(",")
            cells[1] = "b" + cells[1]
            extra.append(",".join(cells))
        (root / "points.csv").write_text("\n".join(rows + extra) + "\n")


#: Two variants for ``scangeo compare`` on a project without a problem strip (no default variants needed).
TWO_VARIANTS = '[variants.DG]\nstrategy = "DG"\nsnooping = false\n\n[variants.SE]\nstrategy = "SE"\n'


@pytest.fixture(scope="session")
def compared_block(tmp_path_factory, small_block) -> Path:
    """A copy of ``small_block`` compared with DG and SE (results/, no report): read-only."""
    from scangeo.reports.tables import write_comparison
    from scangeo.strategy.comparison import compare_project

    root = copy_project(small_block, tmp_path_factory.mktemp("session") / "compared", truth=True)
    (root / "variants.toml").write_text(TWO_VARIANTS, encoding="utf-8")
    write_comparison(compare_project(root))
    return root


#: Preset overrides of ``textured_block``: the ``quick`` preset (rendered landcover images, strip 02 a
#: problem strip) cut to 2 strips x 300 lines x 240 pixels, with 4 blunders among the image measurements
#: and no tie points (``scangeo run`` matches them): the messy project of ``scangeo run``'s tests.
TEXTURED_BLOCK = {
    "sensor": {"pixels": 240},
    "flight": {"lines": 300},
    "gpsimu_errors": {"breaks_lines": [100.0, 200.0]},
    "points": {"blunders": 4, "tie_per_overlap": 0},
}


@pytest.fixture(scope="session")
def textured_block(tmp_path_factory) -> Path:
    """A small simulated project with images, blunders and no tie points (read-only: ``copy_project``)."""
    from scangeo.simulate.block import simulate
    from scangeo.simulate.config import load_preset

    root = tmp_path_factory.mktemp("session") / "textured"
    simulate(root, load_preset("quick", TEXTURED_BLOCK))
    return root


#: Overrides of the ``laser`` preset for ``laser_block``: two overlapping strips, 300 m, 80 k returns.
LASER_BLOCK = {"strips": 2, "strip_length": 300.0, "pulse_rate_hz": 8000.0, "cross_strip": False}


@pytest.fixture(scope="session")
def laser_block(tmp_path_factory) -> Path:
    """A small simulated laser project (``scangeo run`` runs on it): read-only."""
    from scangeo.cli import main

    root = tmp_path_factory.mktemp("session") / "laser"
    sets = [a for k, v in LASER_BLOCK.items() for a in ("--set", f"laser.{k}={str(v).lower()}")]
    assert main(["simulate", str(root), "--preset", "laser", *sets, "--no-progress"]) == 0
    return root


#: The ``small`` preset without images and with three strips, the middle one made a problem strip:
#: height excursions of +-20 m with kinks at two break lines (the pattern of vienna2000 on 600 lines),
#: 40 tie points per overlap (the diagnosis finds the problem strip from them: a strip with one
#: neighbour only cannot be told from it, hence three strips).
PROBLEM_SMALL = {
    "output": {"images": False, "truth_ortho": False},
    "flight": {"strips": 3},
    "gpsimu_errors": {"problem_strip": 2, "breaks_lines": [200.0, 400.0], "strip": [{
        "strip": 2, "shift_m": [1.0, 3.0], "excursion_lines": [0.0, 200.0, 400.0, 599.0],
        "excursion_x_m": [0.0, 3.0, -3.0, 1.0], "excursion_z_m": [4.0, 20.0, -20.0, -4.0]}]},
    "points": {"break_points_per_band_per_strip": 3, "break_band_lines": 60.0, "tie_per_overlap": 40},
}


@pytest.fixture(scope="session")
def problem_small(tmp_path_factory):
    """The simulated project folder (no results yet; tests copy it before writing into it)."""
    from scangeo.simulate.block import simulate
    from scangeo.simulate.config import load_preset

    root = tmp_path_factory.mktemp("reports") / "small"
    simulate(root, load_preset("small", PROBLEM_SMALL))
    return root


@pytest.fixture(scope="session")
def compared_small(tmp_path_factory, problem_small):
    """A copy of ``problem_small`` compared with the default variants and reported.

    Returns (root, comparison, report files).
    """
    from scangeo.reports.report import write_report
    from scangeo.reports.tables import write_comparison
    from scangeo.strategy.comparison import compare_project

    root = tmp_path_factory.mktemp("compared") / "small"
    shutil.copytree(problem_small, root)
    comparison = compare_project(root, folds=2)
    write_comparison(comparison)
    return root, comparison, write_report(root)
