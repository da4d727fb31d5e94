"""Shared test fixtures: the read-only real data in ../shared/data (skipped when absent), a tiny project."""
from __future__ import annotations

import logging
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from scangeo.threading_layer import choose_threading_layer

# Some tests call numba kernels directly, without the entry points that choose the threading layer
# first: choose it for the test process as scangeo's entry points would (workqueue, unless set).
choose_threading_layer()

pytest_plugins = ["tests.session_projects"]  # session-scoped simulated projects (small_block)

SHARED_DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"

#: Session fixtures too costly to build once per worker process (pytest-xdist): every test file that
#: uses one runs in that fixture's group, on one worker.
COSTLY_SESSION_FIXTURES = ("compared_small",)

#: The longest groups (a minute or more on 2 cores), longest first: started first, so that no worker is
#: left with one of them at the end while the other has nothing to do.
LONGEST_GROUPS = (
    "strategy/test_physics.py", "compared_small", "pipeline/test_run.py", "rectify/test_refined_map.py",
    "badinput/test_project_commands.py", "badinput/test_other_commands.py", "rectify/test_block_scale.py",
    "match/test_adjustment.py", "test_parallel.py", "rectify/test_batch.py", "rectify/test_strip.py",
    "importers/test_lcf_simulated.py",
)


@pytest.hookimpl(tryfirst=True)  # before pytest-xdist's own hook, which reads the groups
@pytest.fixture(autouse=True)
def _no_stale_log_handler():
    """scangeo.cli.main() sets up logging once per process (``logging.basicConfig``): its handler writes to the
    stderr of the test that ran it first, which pytest closes after that test. A later test whose command logs
    a warning would read "--- Logging error ---" on its own stderr; so the handler goes with its test."""
    yield
    root = logging.getLogger()
    for handler in [h for h in root.handlers if type(h) is logging.StreamHandler]:
        root.removeHandler(handler)


def pytest_collection_modifyitems(config, items):
    """One pytest-xdist group per test file (``--dist loadgroup`` in pyproject.toml), longest first.

    A worker then runs a whole file, so a module-scoped fixture (a simulated block, an adjustment) is
    built once, as without workers; files sharing a costly session fixture share one group. The order
    of the files changes (``LONGEST_GROUPS`` first), not the order of the tests within a file.
    """
    tests = Path(__file__).parent
    files: dict[Path, str] = {}
    for item in items:
        files.setdefault(item.path, item.path.relative_to(tests).as_posix())
        for name in COSTLY_SESSION_FIXTURES:
            if name in getattr(item, "fixturenames", ()):
                files[item.path] = name
    for item in items:
        if item.get_closest_marker("xdist_group") is None:
            item.add_marker(pytest.mark.xdist_group(files[item.path]))
    rank = {group: i for i, group in enumerate(LONGEST_GROUPS)}
    items.sort(key=lambda item: rank.get(files[item.path], len(rank)))  # stable: files keep their order


@pytest.fixture
def no_network(monkeypatch):
    """Every network connection of this process refused while the test runs (name lookups and
    connects raise OSError); returns the list of the addresses that were tried."""
    import socket

    tried: list[object] = []

    def refuse(*args, **kwargs):
        tried.append(args[1] if len(args) > 1 else args[:1])
        raise OSError("the network is blocked in this test")

    monkeypatch.setattr(socket, "getaddrinfo", lambda *a, **k: refuse(None, a[0]))
    monkeypatch.setattr(socket, "create_connection", lambda address, *a, **k: refuse(None, address))
    monkeypatch.setattr(socket.socket, "connect", refuse)
    monkeypatch.setattr(socket.socket, "connect_ex", refuse)
    return tried


def shared_file(relative: str) -> Path:
    """A file of ../shared/data, or skip the test when it is not there (a user's machine)."""
    path = SHARED_DATA / relative
    if not path.exists():
        pytest.skip(f"shared test data {relative} not available")
    return path


# ------------------------------------------------------------------------------------ tiny project
@dataclass(frozen=True)
class TinyProject:
    """Facts of the tiny project (``tiny_project`` fixture), for hand-computed expectations.

    UTM 33N, a flat DTM at ``ground_H`` (orthometric) with a constant geoid undulation, a 101-pixel
    whiskbroom (40 deg, 10 lines/s, per-pixel timing on), two straight level strips at ellipsoidal
    height ``flight_h`` and ``speed`` m/s: strip "1" flies north along the zone's central meridian
    (x = X0, grid north = true north; lat/lon/h CSV, lines counted from its image
    ``images/1.tif``, 400 x 101 x 3 uint8); strip "2" flies south along x = X0 + 500 (x,y,z CSV in
    the map CRS, ``lines = 400``). Line l of either strip is taken at ``first_line_time + l / 10``.
    """

    root: Path
    crs: str = "EPSG:32633"
    x0: float = 500000.0
    y0: float = 5300000.0
    ground_H: float = 200.0
    undulation: float = 45.0
    flight_h: float = 1245.0  # ellipsoidal: 1000 m above the ground
    speed: float = 50.0
    t_start: float = 1000.0  # trajectories cover t_start .. t_start + 60 s at 50 Hz
    first_line_time: float = 1010.0
    line_rate: float = 10.0
    lines: int = 400
    pixels: int = 101
    fov_deg: float = 40.0
    strip2_dx: float = 500.0

    @property
    def height_above_ground(self) -> float:
        return self.flight_h - self.undulation - self.ground_H

    def northing(self, strip: str, t):
        """Map y (m) of the aircraft of a strip at times t (s)."""
        t = np.asarray(t, dtype=float)
        if strip == "1":
            return self.y0 - 1500.0 + self.speed * (t - self.t_start)
        return self.y0 + 1500.0 - self.speed * (t - self.t_start)

    def easting(self, strip: str) -> float:
        return self.x0 if strip == "1" else self.x0 + self.strip2_dx


def make_tiny_project(root: Path) -> TinyProject:
    """Write the tiny project (see ``TinyProject``) into ``root``."""
    import pyproj
    import rasterio
    from affine import Affine

    info = TinyProject(Path(root))
    root = info.root
    (root / "nav").mkdir(parents=True, exist_ok=True)
    (root / "images").mkdir(exist_ok=True)
    cell = 10.0
    with rasterio.open(
        root / "dtm.tif", "w", driver="GTiff", width=200, height=400, count=1, dtype="float32",
        crs=info.crs, transform=Affine(cell, 0, info.x0 - 1000.0, 0, -cell, info.y0 + 2000.0), nodata=-9999.0,
    ) as dst:
        dst.write(np.full((1, 400, 200), info.ground_H, dtype="float32"))
    t = info.t_start + np.arange(3001) / 50.0
    zeros = np.zeros_like(t)
    to_geo = pyproj.Transformer.from_crs(info.crs, "EPSG:4326", always_xy=True)
    lon, lat = to_geo.transform(np.full_like(t, info.easting("1")), info.northing("1", t))
    rows = np.column_stack([t, lat, lon, zeros + info.flight_h, zeros, zeros, zeros])
    np.savetxt(root / "nav" / "1.csv", rows, delimiter=",", header="time,lat,lon,h,roll,pitch,heading",
               comments="", fmt=["%.3f", "%.11f", "%.11f", "%.3f", "%g", "%g", "%g"])
    rows = np.column_stack([t, zeros + info.easting("2"), info.northing("2", t), zeros + info.flight_h,
                            zeros, zeros, zeros + 180.0])
    np.savetxt(root / "nav" / "2.csv", rows, delimiter=",", header="time,x,y,z,roll,pitch,heading",
               comments="", fmt=["%.3f", "%.4f", "%.4f", "%.3f", "%g", "%g", "%g"])
    image = (np.arange(info.lines)[:, None] + np.arange(info.pixels)[None, :]) % 256
    with warnings.catch_warnings():  # a raw scanner image has no georeferencing
        warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)
        with rasterio.open(root / "images" / "1.tif", "w", driver="GTiff", width=info.pixels,
                           height=info.lines, count=3, dtype="uint8") as dst:
            for band in range(3):
                dst.write(((image + 40 * band) % 256).astype("uint8"), band + 1)
    (root / "project.toml").write_text(f"""\
[project]
crs = "{info.crs}"
dtm = "dtm.tif"
geoid_undulation_m = {info.undulation}

[sensor]
kind = "whiskbroom"
pixels = {info.pixels}
fov_deg = {info.fov_deg}
line_rate_hz = {info.line_rate}

[[strips]]
id = "1"
image = "images/1.tif"
trajectory = "nav/1.csv"
first_line_time = {info.first_line_time}

[[strips]]
id = "2"
trajectory = "nav/2.csv"
first_line_time = {info.first_line_time}
lines = {info.lines}
""", encoding="utf-8")
    return info


@pytest.fixture
def tiny_project(tmp_path) -> TinyProject:
    """A tiny two-strip whiskbroom project in ``tmp_path / "tiny"`` (see ``TinyProject``)."""
    return make_tiny_project(tmp_path / "tiny")
