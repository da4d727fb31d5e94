"""scangeo.parallel.run_tasks, and the cluster route: a small block rectified and matched
through a Dask LocalCluster of two worker processes gives the same outputs as the in-process route."""
from __future__ import annotations

import math
import shutil
import warnings

import numpy as np
import pytest
import rasterio

from scangeo.match.run import match_project
from scangeo.parallel import run_tasks
from scangeo.rectify.batch import rectify_project
from scangeo.rectify.options import RectifyOptions

# a task function from the standard library: the worker processes unpickle it without importing scangeo
TASKS = [0, 1, 15, 16, 99, 100]
EXPECTED = [0, 1, 3, 4, 9, 10]


def test_run_tasks_in_process_and_in_worker_processes_keep_the_task_order():
    seen: list[tuple[int, int]] = []
    assert run_tasks(math.isqrt, TASKS, on_done=lambda n, t: seen.append((n, t))) == EXPECTED
    assert seen == list(zip(range(1, 7), TASKS))
    done: list[int] = []
    assert run_tasks(math.isqrt, TASKS, workers=2, on_done=lambda n, t: done.append(n)) == EXPECTED
    assert done == list(range(1, 7))


@pytest.fixture(scope="module")
def two_strips(tmp_path_factory):
    from scangeo.simulate.block import simulate
    from scangeo.simulate.config import load_preset

    root = tmp_path_factory.mktemp("cluster") / "p"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        simulate(root, load_preset("small", {"flight": {"strips": 2, "lines": 160}}))
    return root


def _rasters(folder):
    out = {}
    for p in sorted(folder.glob("*.tif")):
        with rasterio.open(p) as d:
            out[p.name] = (d.read(), d.tags(), d.transform)
    return out


def test_a_dask_cluster_of_worker_processes_rectifies_and_matches_as_in_process(two_strips, tmp_path):
    from dask.distributed import LocalCluster

    here, there = tmp_path / "here", tmp_path / "there"
    for root in (here, there):
        shutil.copytree(two_strips, root, ignore=shutil.ignore_patterns("results"))
    opts = RectifyOptions(resolution=5.0, resampling="bilinear")
    m_here = match_project(here)
    r_here = rectify_project(here, "DG", options=opts)
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        address = cluster.scheduler_address
        m_there = match_project(there, scheduler=address)
        r_there = rectify_project(there, "DG", options=opts, scheduler=address)
    # equal tie points
    assert (here / "points.csv").read_text() == (there / "points.csv").read_text()
    assert (here / "ground.csv").read_text() == (there / "ground.csv").read_text()
    assert m_here.point_rows == m_there.point_rows and len(m_here.point_rows) > 20
    # byte-equal rasters: pixels, tags (the fingerprint) and georeferencing of every strip
    assert [s["status"] for s in r_there.strips.values()] == ["done", "done"]
    a, b = _rasters(r_here.folder), _rasters(r_there.folder)
    assert a.keys() == b.keys() and len(a) >= 2
    for name in a:
        # layers (the mosaic's view zenith) have NaN where no pixel is seen: NaN there equals NaN
        assert np.array_equal(a[name][0], b[name][0], equal_nan=True) and a[name][1:] == b[name][1:], name
