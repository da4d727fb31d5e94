"""Batch rectification of a simulated project: resume, interruption, workers, Dask, mosaic, CLI."""
import json
import os
import shutil
import signal
import subprocess
import sys
import time
import warnings

import numpy as np
import pytest
import rasterio

from scangeo.cli import main
from scangeo.errors import OrientationFileError
from scangeo.rectify.batch import is_complete, rectify_project
from scangeo.rectify.options import RectifyOptions

OPTS = RectifyOptions(resolution=5.0, resampling="bilinear", mosaic=False)


@pytest.fixture(scope="module")
def project(tmp_path_factory):
    from scangeo.simulate.block import simulate
    from scangeo.simulate.config import load_preset

    root = tmp_path_factory.mktemp("batch") / "p"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        simulate(root, load_preset("small", {"flight": {"strips": 2, "lines": 160}}))
    return root


def fresh_copy(project, tmp_path, name="p"):
    dst = tmp_path / name
    shutil.copytree(project, dst, ignore=shutil.ignore_patterns("results"))
    return dst


def outputs(folder):
    """Pixel data and tags of every output (the fingerprint included: it depends on the inputs' paths
    relative to the project and their content, not on where the project lies)."""
    out = {}
    for p in sorted(folder.iterdir()):
        if p.name.startswith(".") or p.suffix != ".tif":
            continue
        with rasterio.open(p) as d:
            out[p.name] = (d.read(), d.tags(), d.transform)
    return out


def same(a, b):
    assert a.keys() == b.keys()
    for k in a:
        assert np.array_equal(a[k][0], b[k][0]) and a[k][1] == b[k][1] and a[k][2] == b[k][2], k


def test_a_second_run_skips_complete_strips_and_redoes_changed_ones(project, tmp_path):
    root = fresh_copy(project, tmp_path)
    first = rectify_project(root, "DG", options=OPTS)
    assert [s["status"] for s in first.strips.values()] == ["done", "done"]
    second = rectify_project(root, "DG", options=OPTS)
    assert [s["status"] for s in second.strips.values()] == ["skipped", "skipped"]
    # other settings, or a strip's input touched: redone
    third = rectify_project(root, "DG", options=OPTS.replace(resampling="nearest"), strips=["02"])
    assert third.strips["02"]["status"] == "done"
    os.utime(root / "nav" / "01.csv")  # touched only: the same content, still complete
    assert rectify_project(root, "DG", options=OPTS, strips=["01"]).strips["01"]["status"] == "skipped"
    nav = root / "nav" / "01.csv"
    text = nav.read_text().rstrip("\n")  # the last digit of the last record changed: redone
    nav.write_text(text[:-1] + ("1" if text[-1] == "0" else "0") + "\n")
    fourth = rectify_project(root, "DG", options=OPTS)
    assert fourth.strips["01"]["status"] == "done" and fourth.strips["02"]["status"] == "done"  # 02: nearest before
    assert [s["status"] for s in rectify_project(root, "DG", options=OPTS).strips.values()] == ["skipped", "skipped"]
    # a damaged output is not taken as complete
    out = first.folder / "01.tif"
    out.write_bytes(out.read_bytes()[:5000])
    assert not is_complete(out, "anything")
    assert rectify_project(root, "DG", options=OPTS).strips["01"]["status"] == "done"


def test_a_rerun_reads_no_input_again_unless_it_changed(project, tmp_path, monkeypatch):
    """The content hashes of the fingerprint are kept in results/.content-hashes.json: a rerun in a
    new process (the in-process cache emptied) hashes nothing; a file rewritten with the same size
    is hashed again and its strips redone; a damaged cache file only costs the hashing."""
    from scangeo import filecache
    from scangeo.rectify import batch

    root = fresh_copy(project, tmp_path)
    rectify_project(root, "DG", options=OPTS)
    cache = root / filecache.HASH_CACHE
    assert {"project.toml", "nav/01.csv", "images/01.tif", "images/02.tif"} <= set(json.loads(cache.read_text()))
    hashed = []
    real = batch.hashlib.sha256

    def counting(*args):
        hashed.append(1)
        return real(*args)

    filecache.clear_all()  # a new process
    monkeypatch.setattr(batch.hashlib, "sha256", counting)
    statuses = [s["status"] for s in rectify_project(root, "DG", options=OPTS).strips.values()]
    assert statuses == ["skipped", "skipped"]
    assert len(hashed) == 2  # the two fingerprints themselves; no file read
    nav = root / "nav" / "01.csv"
    text = nav.read_text()
    nav.write_text(text[:-2] + ("1" if text[-2] == "0" else "0") + "\n")  # same size, other content
    hashed.clear()
    assert rectify_project(root, "DG", options=OPTS).strips["01"]["status"] == "done"
    assert len(hashed) >= 3  # the changed file hashed again, then the fingerprints
    cache.write_text("{not json")
    assert [s["status"] for s in rectify_project(root, "DG", options=OPTS).strips.values()] == ["skipped", "skipped"]


def test_a_copied_or_moved_project_is_complete_and_its_outputs_do_not_name_where_it_lies(project, tmp_path):
    """The fingerprint hashes paths relative to the project and file content: a copy of a
    rectified project in another folder, its files touched, is complete (skipped) with its outputs
    unchanged; the same project rectified from scratch elsewhere gives byte-identical files (tags,
    fingerprint and the GLT's ENVI header included)."""
    opts = OPTS.replace(glt=True)
    root = fresh_copy(project, tmp_path, "here")
    rectify_project(root, "DG", options=opts)
    ortho = "results/DG/ortho"
    files = sorted(p.name for p in (root / ortho).iterdir())
    assert files == ["01.glt", "01.glt.hdr", "01.tif", "02.glt", "02.glt.hdr", "02.tif"]
    moved = tmp_path / "elsewhere" / "renamed"
    shutil.copytree(root, moved)
    later = time.time() + 3600
    for f in moved.rglob("*"):
        os.utime(f, (later, later))
    again = rectify_project(moved, "DG", options=opts)
    assert [s["status"] for s in again.strips.values()] == ["skipped", "skipped"]
    scratch = fresh_copy(project, tmp_path / "other" / "place", "p2")
    assert [s["status"] for s in rectify_project(scratch, "DG", options=opts).strips.values()] == ["done", "done"]
    for name in files:
        data = (root / ortho / name).read_bytes()
        assert (moved / ortho / name).read_bytes() == data, name
        assert (scratch / ortho / name).read_bytes() == data, name
    assert b"here" not in (root / ortho / "01.glt.hdr").read_bytes()


def test_killed_run_leaves_nothing_finished_looking_and_a_rerun_matches_an_uninterrupted_one(project, tmp_path):
    whole = fresh_copy(project, tmp_path, "whole")
    rectify_project(whole, "DG", options=OPTS)
    root = fresh_copy(project, tmp_path, "killed")
    folder = root / "results" / "DG" / "ortho"
    cmd = [sys.executable, "-m", "scangeo", "rectify", str(root), "--variant", "DG", "--resolution", "5",
           "--resampling", "bilinear", "--no-mosaic", "--no-progress"]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 120
    while not (folder / "01.tif").exists() and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.005)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    visible = [p for p in folder.iterdir() if not p.name.startswith(".")]
    assert [p.name for p in visible] == ["01.tif"], "strip 02 must not look finished"
    rerun = rectify_project(root, "DG", options=OPTS)
    assert rerun.strips["01"]["status"] == "skipped" and rerun.strips["02"]["status"] == "done"
    assert not [p for p in folder.iterdir() if p.name.startswith(".")]  # partial files cleared
    same(outputs(folder), outputs(whole / "results" / "DG" / "ortho"))


def test_workers_give_the_same_outputs(project, tmp_path):
    serial = fresh_copy(project, tmp_path, "serial")
    rectify_project(serial, "DG", options=OPTS)
    pool = fresh_copy(project, tmp_path, "pool")
    r = rectify_project(pool, "DG", options=OPTS, workers=2)
    assert [s["status"] for s in r.strips.values()] == ["done", "done"]
    same(outputs(pool / "results/DG/ortho"), outputs(serial / "results/DG/ortho"))
    # the Dask route (a LocalCluster of worker processes, rectify and match): tests/test_parallel.py


def test_mosaic_takes_each_cell_from_the_strip_closest_to_nadir(project, tmp_path):
    root = fresh_copy(project, tmp_path)
    r = rectify_project(root, "DG", options=OPTS.replace(mosaic=True))
    folder = r.folder
    with rasterio.open(r.mosaic) as m:
        mosaic = m.read(1)
        mt = m.transform
        assert m.tags()["strips"] == "01 02" and m.tags(ns="IMAGE_STRUCTURE").get("LAYOUT") == "COG"
    picks = []
    for sid in ("01", "02"):
        with rasterio.open(folder / f"{sid}.tif") as o, rasterio.open(folder / f"{sid}.layers.tif") as lay:
            col0 = int(round((o.transform.c - mt.c) / mt.a))
            row0 = int(round((mt.f - o.transform.f) / mt.a))
            band = np.full(mosaic.shape, 0, mosaic.dtype)
            vz = np.full(mosaic.shape, np.inf)
            band[row0:row0 + o.height, col0:col0 + o.width] = o.read(1)
            names = lay.tags()["layers"].split()
            v = lay.read(names.index("view_zenith") + 1)
            vz[row0:row0 + o.height, col0:col0 + o.width] = np.where(np.isfinite(v), v, np.inf)
            picks.append((band, vz))
    (b1, v1), (b2, v2) = picks
    both = np.isfinite(v1) & np.isfinite(v2)
    assert both.sum() > 1000  # the strips overlap
    expect = np.where(v1 <= v2, b1, b2)
    expect = np.where(np.isfinite(v1) | np.isfinite(v2), expect, 0)
    assert np.array_equal(mosaic, expect)
    assert (mosaic[both & (v1 < v2)] == b1[both & (v1 < v2)]).all()


def test_cli_rectify_and_its_errors(project, tmp_path, capsys):
    root = fresh_copy(project, tmp_path)
    cfg = tmp_path / "rectify.toml"
    cfg.write_text('[rectify]\nresampling = "nearest"\nlayers = ["scan_angle"]\nmosaic = false\n')
    assert main(["rectify", str(root), "--variant", "DG", "--strips", "02", "--resolution", "5",
                 "--config", str(cfg), "--glt", "--igm", "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert "strip 02:" in out and "1 strips" in out
    folder = root / "results/DG/ortho"
    assert {p.name for p in folder.iterdir()} == {"02.tif", "02.layers.tif", "02.glt", "02.glt.hdr", "02.igm",
                                                  "02.igm.hdr"}
    with rasterio.open(folder / "02.tif") as d:
        assert d.tags()["resampling"] == "nearest" and d.tags()["variant"] == "DG"
        assert d.descriptions[0] == "ch1_blue" and float(d.tags(1)["wavelength"]) == 435.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with rasterio.open(folder / "02.igm") as igm:
            assert igm.count == 3 and igm.height == 160 and igm.width == 716
            xyz = igm.read(window=((80, 81), (358, 359)))
    with rasterio.open(folder / "02.tif") as d:  # the IGM's nadir ground point lies in the orthoimage
        col, row = ~d.transform * (xyz[0, 0, 0], xyz[1, 0, 0])
        assert 0 < col < d.width and 0 < row < d.height
    with rasterio.open(folder / "02.tif") as d:
        assert d.tags()["inverse_map_method"] == "refine" and float(d.tags()["inverse_map_max_error_px"]) < 1e-3
        refined = d.read(1)
    # a changed setting (the validation's tolerance) redoes the strip: the same orthoimage, the
    # inverse map being exact at every cell either way
    assert main(["rectify", str(root), "--variant", "DG", "--strips", "02", "--resolution", "5",
                 "--config", str(cfg), "--max-error", "0.02", "--no-progress"]) == 0
    with rasterio.open(folder / "02.tif") as d:
        assert d.tags()["inverse_map_tolerance_px"] == "0.02" and d.tags()["inverse_map_method"] == "refine"
        assert np.array_equal(d.read(1), refined)
    # errors name what is wrong: the lattice method is gone
    with pytest.raises(SystemExit) as exit_:
        main(["rectify", str(root), "--variant", "DG", "--inverse-map", "lattice", "--no-progress"])
    assert exit_.value.code == 2 and "unrecognized arguments: --inverse-map" in capsys.readouterr().err
    cfg.write_text('[rectify]\ninverse_map_method = "lattice"\n')
    assert main(["rectify", str(root), "--variant", "DG", "--config", str(cfg), "--no-progress"]) == 1
    assert "unknown key 'inverse_map_method'" in capsys.readouterr().err
    assert main(["rectify", str(root), "--variant", "P4", "--no-progress"]) == 1
    assert "no orientation for variant 'P4'" in capsys.readouterr().err
    assert main(["rectify", str(root), "--variant", "DG", "--strips", "99", "--no-progress"]) == 1
    assert "no strip '99'" in capsys.readouterr().err
    cfg.write_text("[rectify]\nresolutoin = 3\n")
    assert main(["rectify", str(root), "--variant", "DG", "--config", str(cfg), "--no-progress"]) == 1
    assert "unknown key 'resolutoin'" in capsys.readouterr().err
    with pytest.raises(OrientationFileError, match="no orientation for variant 'S2'"):
        rectify_project(root, "S2", options=OPTS)
