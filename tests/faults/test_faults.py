"""Faults: a command killed part-way (SIGKILL of a subprocess), then rerun, gives the same
results as an uninterrupted run, with nothing partial under a final name; a second run on a project
being written is refused (the lock); a full disk gives a clear error and leaves nothing behind.

The kill moments are observed, not timed: the lock file appearing (the run has started) and the first
hidden temporary output appearing (the run is writing).
"""
from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from tests.badinput.runner import final_files
from tests.session_projects import copy_project

LOCK = ".scangeo.lock"


def scangeo(*args: str) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "scangeo", *args, "--no-progress"], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


def kill_when(proc: subprocess.Popen, seen, timeout: float = 120.0) -> bool:
    """SIGKILL ``proc`` as soon as ``seen()`` is true; True when it was still running then."""
    end = time.monotonic() + timeout
    while time.monotonic() < end and proc.poll() is None and not seen():
        time.sleep(0.002)
    running = proc.poll() is None
    proc.send_signal(signal.SIGKILL)
    proc.communicate()
    return running


def hidden(folder: Path, pattern: str):
    return lambda: folder.exists() and any(folder.glob(pattern))


def run_in_process(*args: str) -> None:
    from scangeo.cli import main

    assert main([*args, "--no-progress"]) == 0


def _without_seconds(value):
    if isinstance(value, dict):
        return {k: _without_seconds(v) for k, v in value.items() if k != "seconds"}
    if isinstance(value, list):
        return [_without_seconds(v) for v in value]
    return value


def assert_same_outputs(a: Path, b: Path) -> None:
    """Same files; text and CSV byte-identical, JSON equal but for run times, rasters pixel-identical
    with equal tags, the fingerprint included (it hashes paths relative to the project and content)."""
    assert final_files(a) == final_files(b)
    for rel in sorted(final_files(a)):
        fa, fb = a / rel, b / rel
        if rel.endswith(".json"):
            assert _without_seconds(json.loads(fa.read_text())) == _without_seconds(json.loads(fb.read_text())), rel
        elif rel.endswith((".tif", ".tiff")):
            import rasterio

            with rasterio.open(fa) as sa, rasterio.open(fb) as sb:
                pa, pb = dict(sa.profile), dict(sb.profile)
                na, nb = pa.pop("nodata"), pb.pop("nodata")  # a float layer's NaN nodata equals NaN
                assert pa == pb and (na == nb or (na != na and nb != nb)), rel
                assert sa.tags() == sb.tags(), rel
                assert np.array_equal(sa.read(), sb.read(), equal_nan=True), rel
        else:
            assert fa.read_bytes() == fb.read_bytes(), rel


@pytest.fixture(scope="module")
def adjusted_reference(small_block, tmp_path_factory):
    root = copy_project(small_block, tmp_path_factory.mktemp("faults") / "reference")
    run_in_process("adjust", str(root))
    return root


@pytest.mark.parametrize("moment", ["started", "writing"])
def test_adjust_killed_then_rerun(moment, small_block, adjusted_reference, tmp_path):
    root = copy_project(small_block, tmp_path / "p")
    results = root / "results"
    seen = (lambda: (root / LOCK).exists()) if moment == "started" else hidden(results, ".SE.*")
    kill_when(scangeo("adjust", str(root)), seen)
    if (results / "SE").exists():  # killed after the rename: then it is complete
        assert_same_outputs(adjusted_reference / "results", results)
    run_in_process("adjust", str(root))
    assert not list(results.glob(".*")), "temporary names left after the rerun"
    assert_same_outputs(adjusted_reference / "results", results)


def test_second_run_refused_then_a_killed_run_does_not_block(small_block, tmp_path, capsys):
    from scangeo.cli import main

    root = copy_project(small_block, tmp_path / "p")
    first = scangeo("adjust", str(root))
    end = time.monotonic() + 120
    while not (root / LOCK).exists() and first.poll() is None and time.monotonic() < end:
        time.sleep(0.002)
    assert first.poll() is None, "the first run ended before it could be observed"
    code = main(["adjust", str(root), "--no-progress"])
    err = capsys.readouterr().err
    first.send_signal(signal.SIGKILL)
    first.communicate()
    assert code == 1
    assert "another scangeo run is writing this project" in err and "scangeo adjust, pid" in err
    assert not (root / "results" / "SE").exists() or (root / "results" / "SE" / "report.json").exists()
    run_in_process("adjust", str(root))  # the kernel released the dead run's lock
    assert (root / "results" / "SE" / "report.json").exists() and not (root / LOCK).exists()


@pytest.fixture(scope="module")
def rectified_reference(small_block, tmp_path_factory):
    root = copy_project(small_block, tmp_path_factory.mktemp("faults") / "rectified")
    run_in_process("rectify", str(root), "--variant", "DG", "--strips", "02", "--resolution", "10")
    return root


@pytest.mark.parametrize("moment", ["started", "writing"])
def test_rectify_killed_then_rerun(moment, small_block, rectified_reference, tmp_path):
    root = copy_project(small_block, tmp_path / "p")
    ortho = root / "results" / "DG" / "ortho"
    seen = (lambda: (root / LOCK).exists()) if moment == "started" else hidden(ortho, ".*")
    kill_when(scangeo("rectify", str(root), "--variant", "DG", "--strips", "02", "--resolution", "10"), seen)
    for path in ortho.glob("*.tif") if ortho.exists() else []:  # a final name holds a whole orthoimage
        import rasterio

        with rasterio.open(path) as src:
            src.read()
    run_in_process("rectify", str(root), "--variant", "DG", "--strips", "02", "--resolution", "10")
    assert not [p for p in ortho.iterdir() if p.name.startswith(".")], "temporary names left after the rerun"
    assert_same_outputs(rectified_reference / "results", root / "results")
    import rasterio

    with rasterio.open(ortho / "02.tif") as a, rasterio.open(rectified_reference / "results/DG/ortho/02.tif") as b:
        assert len(a.tags()["scangeo_fingerprint"]) == 24 and a.tags() == b.tags()


def test_simulate_killed_then_rerun(tmp_path):
    from tests.session_projects import SMALL_BLOCK

    sets = ["--set", f"sensor.pixels={SMALL_BLOCK['sensor']['pixels']}", "--set", "flight.lines=50",
            "--set", "terrain.margin_m=300", "--no-images"]
    run_in_process("simulate", str(tmp_path / "reference"), *sets)
    out = tmp_path / "out"
    kill_when(scangeo("simulate", str(out), *sets), hidden(tmp_path, ".out*"))
    assert not out.exists() or (out / "project.toml").exists()
    shutil.rmtree(out, ignore_errors=True) if out.exists() else None
    run_in_process("simulate", str(out), *sets)
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]
    assert_same_outputs(tmp_path / "reference", out)


def test_full_disk(small_block, tmp_path):
    """adjust writing its results onto a 64 KiB tmpfs (mounted as PROJECT/results): a clear error, nothing left
    on the disk."""
    if not shutil.which("unshare"):
        pytest.skip("full disk: no unshare(1) to mount a small tmpfs")
    root = copy_project(small_block, tmp_path / "p")
    disk = root / "results"
    disk.mkdir(exist_ok=True)
    script = (f"mount -t tmpfs -o size=64k tmpfs {disk} || exit 99; "
              f"{sys.executable} -m scangeo adjust {root} --no-progress; echo rc=$?; "
              f"find {disk} -mindepth 1")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    r = subprocess.run(["unshare", "-r", "-m", "sh", "-c", script], capture_output=True, text=True, env=env)
    if r.returncode == 99 or "rc=" not in r.stdout:
        pytest.skip(f"full disk: cannot mount a tmpfs here ({r.stderr.strip()[:200]})")
    rc_line, *left = r.stdout.strip().splitlines()
    assert rc_line == "rc=1"
    assert "No space left on device" in r.stderr and "Traceback" not in r.stderr
    assert left == [], f"left on the full disk: {left}"
