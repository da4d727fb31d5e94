"""The row-buffer patch search: compiled planes, scan lines, windows, the seeded second pass,
and side by side with the grid cells (the earlier search) on the session's laser block."""

from __future__ import annotations

import json
import logging

import numpy as np
import pytest

from scangeo.adjustment.variants import laser_variant
from scangeo.io.project import Project
from scangeo.lidar.adjust import LaserOptions, build, run
from scangeo.lidar.cells import BoxStream, GridCellStream
from scangeo.lidar.control import read_patch_ground
from scangeo.lidar.evaluation import apply, evaluate
from scangeo.lidar.lasio import StripCloud, iter_returns
from scangeo.lidar.patches import PatchOptions, find_strip_patches
from scangeo.lidar.plane_kernel import fit_planes
from scangeo.lidar.rowbuffer import RowBuffer, search_strip
from scangeo.lidar.search import find_all
from scangeo.lidar.seeded import Seeds, fit_seeds, members
from tests.lidar.test_lidar_adjust import truth_values
from tests.session_projects import laser_block  # noqa: F401  (session fixture)


def test_planes_recover_known_planes_and_snoop_the_blunders():
    """The one plane fit (compiled): known planes come back, the blunders are removed (and few others),
    and absolute coordinates give what coordinates relative to each group give (to 1e-8 m)."""
    rng = np.random.default_rng(3)
    m, per = 300, 40
    g = np.repeat(np.arange(m), per)
    xy = rng.uniform(-3, 3, (g.size, 2)) + rng.uniform(-1e3, 1e3, (m, 2))[g]
    n = rng.normal(0, 0.3, (m, 3)) + [0, 0, 1]
    n /= np.linalg.norm(n, axis=1)[:, None]
    z = 500.0 - (n[g, 0] * xy[:, 0] + n[g, 1] * xy[:, 1]) / n[g, 2] + rng.normal(0, 0.02, g.size)
    blunder = rng.random(g.size) < 0.03
    z[blunder] += np.where(rng.random(int(blunder.sum())) < 0.5, -1.0, 1.0) * rng.uniform(0.5, 1.0, int(blunder.sum()))
    xyz, t = np.column_stack([xy, z]), rng.uniform(0, 10, g.size)
    order = rng.permutation(g.size)
    xyz, g, t, blunder = xyz[order], g[order], t[order], blunder[order]
    b = fit_planes(xyz, g, m, 0.02, t)
    extra = b.rejected - np.bincount(g[blunder], minlength=m)
    assert extra.min() >= 0 and extra.sum() < 0.003 * g.size  # the blunders went, and a few 3.3-sigma returns
    angle = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", b.normal, n), -1, 1)))
    assert np.percentile(angle, 95) < 0.5 and 0.017 < np.median(b.sigma) < 0.022
    height = 500.0 - (n[:, 0] * b.centroid[:, 0] + n[:, 1] * b.centroid[:, 1]) / n[:, 2]
    assert np.abs(b.centroid[:, 2] - height).max() < 0.05  # the centroids lie on the true planes
    first = np.unique(g, return_index=True)[1]
    a = fit_planes(xyz - xyz[first][g], g, m, 0.02, t)
    a.centroid = a.centroid + xyz[first]
    assert np.array_equal(a.count, b.count) and np.array_equal(a.rejected, b.rejected)
    for name in ("centroid", "normal", "axes", "spread", "time", "time_gradient"):
        assert np.allclose(getattr(a, name), getattr(b, name), rtol=0, atol=1e-8), name


def _triangle(t, rate):
    return 4.0 * np.abs((t * rate) % 1.0 - 0.5) - 1.0


def level_strip(plane=(0.05, -0.02, 0.0), noise=0.02, seconds=6.0, heading_north=True, seed=0, dz=0.0):
    """Returns of a level flight (450 m, 60 m/s, 40 kHz, 40 Hz oscillating mirror, +-20 deg) over the
    plane ``z = a x + b y + c`` (map = project, metres); every pulse returns twice (first and last)."""
    rng = np.random.default_rng(seed)
    a, b, c = plane
    t = np.arange(int(seconds * 40000.0)) / 40000.0
    theta = np.radians(20.0) * _triangle(t, 40.0)
    y0 = 60.0 * t - 180.0 if heading_north else 180.0 - 60.0 * t
    lam = (450.0 - c - b * y0) / (np.cos(theta) + a * np.sin(theta))
    x, y = lam * np.sin(theta), y0
    z = a * x + b * y + c + rng.normal(0, noise, t.size) + dz
    xyz = np.repeat(np.column_stack([x, y, z]), 2, axis=0)
    return xyz, np.repeat(t, 2), np.repeat(theta, 2)


def chunks(arrays, size):
    n = arrays[0].shape[0]
    for k in range(0, n, size):
        yield tuple(a[k : k + size] for a in arrays)


def test_scan_lines_of_an_oscillating_and_a_rotating_mirror():
    rng = np.random.default_rng(1)
    t = np.arange(20000) / 10000.0
    for angle, lines in (
        (_triangle(t, 25.0), 100),  # 25 periods, 2 sweeps each
        (((t * 30.0) % 1.0) - 0.5, 60),  # a polygon: 60 sweeps, each jumping back
    ):
        angle = np.repeat(angle, 1 + (rng.random(t.size) < 0.3))  # a third of the pulses return twice
        buffer = RowBuffer("s", PatchOptions(size=6.0), 0.02)
        xyz = np.zeros((angle.size, 3))
        xyz[:, 0] = angle * 100.0
        for part in chunks((xyz, np.arange(angle.size) * 1e-4, angle), 777):
            buffer.feed(*part)
        assert buffer.finish().lines == lines


def test_row_buffer_over_a_plane_is_independent_of_the_chunks():
    plane = (0.05, -0.02, 3.0)
    data = level_strip(plane)
    options = PatchOptions(size=6.0)
    one = search_strip("s", chunks(data, 10**7), options, 0.02)
    many = search_strip("s", chunks(data, 3001), options, 0.02)
    assert one.size == many.size > 1500 and one.returns == data[1].size
    assert np.allclose(one.planes.centroid, many.planes.centroid, atol=1e-9)
    n_true = np.array([-plane[0], -plane[1], 1.0]) / np.linalg.norm([plane[0], plane[1], 1.0])
    assert np.degrees(np.arccos(np.clip(one.planes.normal @ n_true, -1, 1))).max() < 1.5
    assert 0.015 < np.median(one.planes.sigma) < 0.025
    assert one.speed == pytest.approx(60.0, rel=0.02)
    # windows about 6 m on the ground both ways: boxes of a uniformly covered 6 m square
    assert np.allclose(np.median(2 * one.half, axis=0), 6.0, rtol=0.25)


def test_seeded_pass_ties_the_strips_on_the_same_footprint():
    plane = (0.0, 0.03, 0.0)
    strips = {
        "1": level_strip(plane, seed=1),
        "2": level_strip(plane, heading_north=False, seed=2, dz=0.10),  # 10 cm above strip 1
    }
    options = PatchOptions(size=6.0)
    found = {s: search_strip(s, chunks(d, 50000), options, 0.02) for s, d in strips.items()}
    seeds = Seeds.of(found)
    fits = {
        s: fit_seeds(s, chunks(d, 50000), seeds, seeds.inside(found[s].bounds), options, 0.02, found[s].speed)
        for s, d in strips.items()
    }
    tied = members(fits, seeds)
    common, i1, i2 = np.intersect1d(tied["1"].cells, tied["2"].cells, return_indices=True)
    assert common.size > 0.8 * seeds.size  # the strips cover the same ground: almost every seed ties
    p1, p2 = tied["1"].planes.take(i1), tied["2"].planes.take(i2)
    offset = np.einsum("ij,ij->i", p2.centroid - p1.centroid, p1.normal)
    assert np.median(offset) == pytest.approx(0.10 * p1.normal[:, 2].mean(), abs=0.005)
    # the same footprint in both strips: centroids within the returns' spacing
    assert np.median(np.linalg.norm(p2.centroid[:, :2] - p1.centroid[:, :2], axis=1)) < 0.5


def test_rows_and_grid_side_by_side_on_the_laser_block(laser_block):  # noqa: F811
    """The strip differences after either search, on all planar cells and on the cells that are not the
    grid route's own tie patches (there the grid route adjusts the very cells it is measured on)."""
    logging.getLogger("scangeo.lsq.solver").setLevel(logging.ERROR)
    project = Project.load(laser_block)
    truth = json.loads((laser_block / "truth.json").read_text())["truth"]
    after, independent, noise, tie_cells = {}, {}, None, set()
    for method in ("grid", "rows"):
        block = build(project, LaserOptions(patch_search=method), laser_variant(), laser_block / "ground.csv")
        result = run(block)
        ev = evaluate(block, result, apply(block, result.parameters.values()))
        if noise is None:
            noise = evaluate(block, result, apply(block, truth_values(block, truth))).after.rms(True)
            tie_cells = {int(block.found[s].patches.cells[i]) for t in block.ties for s, i in t.members}
        assert ev.before.rms(True) > 2.5 * noise
        after[method] = ev.after.rms(True)
        out = ev.after.flat & ~np.isin(ev.after.cell, list(tie_cells))
        independent[method] = float(np.sqrt(np.mean(ev.after.dz[out] ** 2)))
    # measured (docs/lidar.md 6.2): all cells grid 0.707 cm, rows 0.721 cm, noise floor 0.691 cm; on the 323
    # cells that are not grid tie patches grid 0.7173 cm, rows 0.7169 cm (on its 23 tie cells the grid route
    # has 0.548 cm, in-sample; the noise there 0.566 cm)
    assert after["grid"] < 1.05 * noise and after["rows"] < 1.05 * noise
    assert independent["rows"] <= 1.002 * independent["grid"]


def test_dask_route_gives_the_same_patches(laser_block):  # noqa: F811
    """The patch search per strip on a Dask LocalCluster finds what the in-process route finds."""
    pytest.importorskip("dask.distributed")
    from dask.distributed import LocalCluster

    project = Project.load(laser_block)
    options, prior = LaserOptions().patches, project.laser.range_sigma_m
    local = find_all(project, options, prior, None)
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, dashboard_address=None) as cluster:
        remote = find_all(project, options, prior, None, scheduler=cluster.scheduler_address)
    assert list(remote) == list(local)
    for sid, f in local.items():
        assert f.patches.cells.size > 20
        assert np.array_equal(remote[sid].patches.cells, f.patches.cells)
        assert np.allclose(remote[sid].patches.planes.centroid, f.patches.planes.centroid, rtol=0, atol=1e-9)
        assert remote[sid].candidates.size == f.candidates.size


def test_streamed_cells_and_boxes_equal_the_whole_strip(laser_block):  # noqa: F811
    """Grid cells and control boxes fitted from chunks of 4000 returns, cells let go 1 s after the strip
    left them, are the fits of the whole strip at once; the stream never held half the strip."""
    project = Project.load(laser_block)
    strip = project.strips[0]
    options = LaserOptions().patches
    given = read_patch_ground(laser_block / "ground.csv")
    chunks = list(iter_returns(strip.las, strip.point_source_id, project.crs, 4000))
    cloud = StripCloud(strip.id, np.concatenate([c[0] for c in chunks]), np.concatenate([c[1] for c in chunks]))
    whole = find_strip_patches(cloud, options, 0.02)
    grid = GridCellStream(strip.id, options, 0.02, close_after=1.0)
    boxes = BoxStream(given.centre, given.axes, given.half, options, 0.02)
    for xyz, t, _ in chunks:
        grid.feed(xyz, t)
        boxes.feed(xyz, t)
    streamed = grid.finish()
    assert whole.cells.size > 100 and np.array_equal(streamed.cells, whole.cells)
    for name in ("count", "rejected", "centroid", "normal", "sigma", "time"):
        assert np.allclose(getattr(streamed.planes, name), getattr(whole.planes, name), rtol=0, atol=1e-9), name
    assert grid.peak_pending < 0.5 * cloud.size
    planes, ok = boxes.finish()
    one = BoxStream(given.centre, given.axes, given.half, options, 0.02)
    one.feed(cloud.xyz, cloud.time)
    planes_whole, ok_whole = one.finish()
    assert ok.sum() >= 4 and np.array_equal(ok, ok_whole)
    assert np.allclose(planes.normal[ok], planes_whole.normal[ok], atol=1e-12)
