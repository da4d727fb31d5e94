"""Text inputs as editors save them: every text input of every command accepts a UTF-8 byte-order mark
and refuses latin-1 and UTF-16 with the file's name and what was expected (scangeo.textfile).

The refusals are cases of the bad-input matrix (tests/badinput/runner.py: a non-zero exit, the file
named, no traceback, no new file); the acceptance reads each marked file and compares what it holds
with the unmarked file's, and runs a command on a project whose text files all carry the mark.
"""
from __future__ import annotations

import codecs
import dataclasses
import logging

import numpy as np
import pytest
import rasterio

from scangeo.adjustment.variants import read_variants
from scangeo.io.points import GroundPoints, ImagePoints
from scangeo.io.project import Project
from scangeo.trajectory.readers import read_trajectory_csv
from tests.badinput.defects import case, chain, write
from tests.badinput.runner import run_bad
from tests.badinput.test_other_commands import LIDAR_ARGS, SIMULATE_ARGS, _lidar_files, _preset, _two_variants
from tests.session_projects import TWO_VARIANTS, copy_project

#: a non-ASCII text each kind of file may hold: a TOML comment, a point's name, a trajectory column's unit
NON_ASCII = {
    ".toml": lambda t: "# Messflug über Wien, Höhe in m\n" + t,
    "points": lambda t: t.replace("\n", "\nBrücke_", 1),  # the first point renamed
    "nav": lambda t: t.replace("heading", "heading [°]", 1),
    "locate": lambda t: t.replace("A,", "Ä,", 1),
}


def _kind(name: str) -> str:
    if name.endswith(".toml"):
        return ".toml"
    return "nav" if name.startswith("nav/") else "locate" if name in ("q.csv", "g.csv") else "points"


def encoded(name: str, encoding: str):
    """The file, with a non-ASCII text in it, saved in ``encoding`` (``utf-16``: with its mark, as
    Windows Notepad saves "Unicode"; ``utf-8-sig``: UTF-8 with the mark, as spreadsheets save "CSV UTF-8")."""

    def apply(root):
        path = root / name
        path.write_bytes(NON_ASCII[_kind(name)](path.read_text(encoding="utf-8")).encode(encoding))

    return apply


def refused(prefix: str, name: str, *, before=None, args=()):
    """The latin-1 and the UTF-16 case of one file (``before``: a defect that writes the file first)."""
    out = []
    for encoding, expect in (("latin-1", "is not UTF-8"), ("utf-16", "UTF-16 text")):
        defect = encoded(name, encoding) if before is None else chain(before, encoded(name, encoding))
        out.append(case(f"{prefix}-{name}-{encoding}", defect, name, expect, "saved as UTF-8", args=args))
    return out


VARIANT_X = write("variants.toml", '[variants.X]\nstrategy = "SE"\n')
PROJECT_FILES = ["project.toml", "nav/02.csv", "points.csv", "ground.csv"]


@pytest.mark.parametrize("bad", [c for name in PROJECT_FILES for c in refused("adjust", name)]
                         + refused("adjust", "variants.toml", before=VARIANT_X, args=("--variant", "X")))
def test_adjust(bad, small_block, tmp_path, capsys):
    run_bad(["adjust", "{p}", "--no-progress"], bad, small_block, tmp_path, capsys)


@pytest.mark.parametrize("bad", refused("diagnose", "project.toml") + refused("diagnose", "points.csv"))
def test_diagnose(bad, small_block, tmp_path, capsys):
    run_bad(["diagnose", "{p}", "--no-progress"], bad, small_block, tmp_path, capsys)


@pytest.mark.parametrize("bad", refused("compare", "variants.toml") + refused("compare", "ground.csv"))
def test_compare(bad, small_block, tmp_path, capsys):
    run_bad(["compare", "{p}", "--no-report", "--no-progress"], bad, small_block, tmp_path, capsys,
            setup=_two_variants)


@pytest.mark.parametrize("bad", refused("report", "project.toml"))
def test_report(bad, compared_block, tmp_path, capsys):
    run_bad(["report", "{p}", "--no-progress"], bad, compared_block, tmp_path, capsys)


R_TOML = write("r.toml", "[rectify]\nresolution = 20.0\n")


@pytest.mark.parametrize("bad", refused("rectify", "nav/02.csv")
                         + refused("rectify", "r.toml", before=R_TOML, args=("--config", "{p}/r.toml")))
def test_rectify(bad, small_block, tmp_path, capsys):
    run_bad(["rectify", "{p}", "--variant", "DG", "--strips", "02", "--resolution", "20", "--no-progress"], bad,
            small_block, tmp_path, capsys)


M_TOML = write("m.toml", "[match]\nper_overlap = 3\n")


@pytest.mark.parametrize("bad", refused("match", "m.toml", before=M_TOML, args=("--config", "{p}/m.toml")))
def test_match(bad, small_block, tmp_path, capsys):
    run_bad(["match", "{p}", "--no-progress"], bad, small_block, tmp_path, capsys)


RUN_TOML = write("run.toml", "[compare]\nfolds = 0\n")


@pytest.mark.parametrize("bad", refused("run", "run.toml", before=RUN_TOML, args=("--config", "{p}/run.toml")))
def test_run_config(bad, small_block, tmp_path, capsys):
    run_bad(["run", "{p}", "--no-progress"], bad, small_block, tmp_path, capsys)


Q_CSV = write("q.csv", "point,line,pixel\nA,10,20\n")
G_CSV = write("g.csv", "point,x,y\nA,10,20\n")


@pytest.mark.parametrize("bad", refused("locate", "q.csv", before=Q_CSV, args=("--image", "{p}/q.csv"))
                         + refused("locate", "g.csv", before=G_CSV, args=("--ground", "{p}/g.csv")))
def test_locate(bad, small_block, tmp_path, capsys):
    run_bad(["locate", "{p}", "--strip", "02", "--no-progress"], bad, small_block, tmp_path, capsys)


@pytest.mark.parametrize("bad", [c for name in ("nav/02.csv", "points.csv", "ground.csv")
                                 for c in refused("info", name, args=(f"{{p}}/{name}",))])
def test_info(bad, small_block, tmp_path, capsys):
    run_bad(["info"], bad, small_block, tmp_path, capsys)


@pytest.mark.parametrize("bad", refused("simulate", "preset.toml", before=_preset(lambda t: t), args=SIMULATE_ARGS))
def test_simulate(bad, small_block, tmp_path, capsys):
    run_bad(["simulate"], bad, small_block, tmp_path, capsys)


@pytest.mark.parametrize("bad", refused("lidar", "config.toml"))
def test_lidar_check_returns(bad, small_block, tmp_path, capsys):
    run_bad(["lidar", "check-returns", *LIDAR_ARGS], bad, small_block, tmp_path, capsys, setup=_lidar_files)


@pytest.mark.parametrize("bad", refused("laser", "project.toml") + refused("laser", "ground.csv")
                         + refused("laser", "nav/1.csv"))
def test_laser_run(bad, laser_block, tmp_path, capsys):
    run_bad(["run", "{p}", "--no-progress"], bad, laser_block, tmp_path, capsys, kept="results/")


# ------------------------------------------------------------------------------------------ the mark
def test_every_project_file_with_a_byte_order_mark_reads_as_without(small_block, tmp_path):
    plain = copy_project(small_block, tmp_path / "plain")
    (plain / "variants.toml").write_text(TWO_VARIANTS, encoding="utf-8")
    marked = copy_project(plain, tmp_path / "marked")
    names = ["project.toml", "variants.toml", "points.csv", "ground.csv", *(f"nav/{s}.csv" for s in ("01", "02"))]
    for name in names:
        (marked / name).write_bytes(codecs.BOM_UTF8 + (plain / name).read_bytes())
        assert (marked / name).read_bytes()[:3] == codecs.BOM_UTF8
    a, b = Project.load(plain), Project.load(marked)
    assert [(s.id, s.first_line_time, s.trajectory.name, s.image.name) for s in a.strips] == \
        [(s.id, s.first_line_time, s.trajectory.name, s.image.name) for s in b.strips]
    assert (a.crs, a.origin, a.dtm_sigma, a.sensor.line_rate) == (b.crs, b.origin, b.dtm_sigma, b.sensor.line_rate)
    assert read_variants(plain / "variants.toml") == read_variants(marked / "variants.toml")
    for reader, name in ((ImagePoints.read, "points.csv"), (GroundPoints.read, "ground.csv")):
        pa, pb = reader(plain / name), reader(marked / name)
        assert len(pa) > 10
        for f in [f for f in dataclasses.fields(pa) if f.name != "source"]:
            assert np.array_equal(getattr(pa, f.name), getattr(pb, f.name)), (name, f.name)
    for s in ("01", "02"):
        ta, tb = read_trajectory_csv(plain / "nav" / f"{s}.csv"), read_trajectory_csv(marked / "nav" / f"{s}.csv")
        assert len(ta) > 100 and (ta.time == tb.time).all() and (ta.heading == tb.heading).all()


def test_a_command_runs_on_marked_files_and_a_marked_config(small_block, tmp_path, capsys):
    from scangeo.cli import main

    root = copy_project(small_block, tmp_path / "p")
    for name in ["project.toml", "points.csv", "ground.csv", "nav/01.csv", "nav/02.csv"]:
        (root / name).write_bytes(codecs.BOM_UTF8 + (root / name).read_bytes())
    R_TOML(root)
    encoded("r.toml", "utf-8-sig")(root)
    assert (root / "r.toml").read_bytes()[:3] == codecs.BOM_UTF8
    logging.getLogger().handlers.clear()  # main() configures logging for the stderr capsys gives this test
    try:
        assert main(["info", str(root)]) == 0
        assert main(["rectify", str(root), "--config", str(root / "r.toml"), "--variant", "DG", "--strips", "02",
                     "--no-progress"]) == 0
    finally:
        logging.getLogger().handlers.clear()  # no handler left on this test's stream for the next test
    assert "Traceback" not in capsys.readouterr().err
    with rasterio.open(next((root / "results").rglob("02*.tif"))) as src:
        assert src.res == (20.0, 20.0)  # the marked config's resolution
