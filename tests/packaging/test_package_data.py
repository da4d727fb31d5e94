"""Shipped data is package data: found from the package as setuptools builds it, not from the checkout.

``.ci/wheel`` builds the real wheel and runs ``scangeo demo --quick`` from a fresh virtual environment
(minutes); this test builds the wheel alone (the modules and the package data of pyproject.toml),
unpacks it into a temporary folder and reads the presets, the default variants and the STAC schemas
from it in a separate interpreter, away from the checkout (seconds).
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

import pytest

import scangeo
from scangeo.resources import DEFAULT_VARIANTS, PRESETS, preset_file, preset_names

ROOT = Path(scangeo.__file__).resolve().parents[1]


def test_every_shipped_data_file_is_declared_package_data():
    declared = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["package-data"]["scangeo"]
    package = ROOT / "scangeo"
    data_files = {p for p in package.rglob("*") if p.is_file() and p.suffix not in (".py", ".pyc")
                  and "__pycache__" not in p.parts}
    covered = {p for pattern in declared for p in package.glob(pattern)}
    assert data_files - covered == set()
    assert {"quick", "small", "vienna2000", "block24"} <= set(preset_names())
    assert preset_file("no-such-preset") is None
    assert PRESETS.joinpath("quick.toml").is_file() and DEFAULT_VARIANTS.is_file()


def test_nothing_in_the_package_reads_the_top_level_data_folder():
    offenders = [str(p.relative_to(ROOT)) for p in (ROOT / "scangeo").rglob("*.py")
                 if "parents[1]" in p.read_text(encoding="utf-8")]
    assert offenders == []


@pytest.fixture(scope="module")
def built_package(tmp_path_factory):
    """The package tree of the wheel, built from a copy of the sources by pyproject's build backend in
    pip's isolated build environment (setuptools >= 77, whatever this interpreter has) and unpacked."""
    work = tmp_path_factory.mktemp("wheel")
    src = work / "src"
    src.mkdir()
    for name in ("pyproject.toml", "README.md", "LICENSE"):
        shutil.copy(ROOT / name, src / name)
    shutil.copytree(ROOT / "scangeo", src / "scangeo", ignore=shutil.ignore_patterns("__pycache__"))
    run = subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--disable-pip-version-check", "--no-deps",
                          "-w", str(work / "dist"), str(src)], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    (wheel,) = (work / "dist").glob("scangeo-*.whl")
    lib = work / "lib"
    with zipfile.ZipFile(wheel) as z:
        z.extractall(lib)
    return lib


def test_presets_and_variants_are_found_in_the_built_package(built_package, tmp_path):
    code = ("import scangeo, sys; from scangeo.simulate.config import available_presets, load_preset; "
            "from scangeo.resources import DEFAULT_VARIANTS, STAC_SCHEMAS; "
            "from scangeo.reports.stac_validation import EXTENSION_SCHEMAS, schema_registry; "
            "print(scangeo.__file__); print(' '.join(available_presets())); "
            "print(load_preset('quick').flight.lines, load_preset('vienna2000').flight.lines); "
            "print('@PROBLEM_STRIP@' in DEFAULT_VARIANTS.read_text()); "
            "print(' '.join(sorted(p.name for p in STAC_SCHEMAS.iterdir()))); "
            "print(all(schema_registry().contents(u) for u in EXTENSION_SCHEMAS))")
    env = dict(os.environ, PYTHONPATH=str(built_package))
    run = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    where, presets, lines, placeholder, stac, schemas = run.stdout.splitlines()
    assert Path(where).resolve().is_relative_to(built_package.resolve())
    shipped = sorted(p.stem for p in (ROOT / "scangeo" / "data" / "presets").glob("*.toml"))
    assert presets.split() == shipped and {"quick", "small", "vienna2000"} <= set(shipped)
    assert lines == "600 7000" and placeholder == "True"
    # the STAC extensions' schemas with their licences, for the offline validation of the items
    assert stac.split() == sorted(p.name for p in (ROOT / "scangeo" / "data" / "stac").iterdir()) and schemas == "True"
    assert {"LICENSE-projection", "LICENSE-pointcloud", "README.md"} <= set(stac.split())

    listed = subprocess.run([sys.executable, "-m", "scangeo", "simulate", "--list-presets"], cwd=tmp_path,
                            env=env, capture_output=True, text=True)
    assert listed.returncode == 0, listed.stderr
    assert listed.stdout.split() == shipped
