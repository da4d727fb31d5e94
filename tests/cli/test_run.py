"""``scangeo run``'s exit codes (docs/run.md) on the session's small block, stopped after the check stage."""
from __future__ import annotations

import json

import pytest

from scangeo.atomic import OutputLock
from scangeo.cli import main
from scangeo.cli.run import EXIT_DONE, EXIT_FAILED, EXIT_INTERRUPTED, EXIT_LOCKED, EXIT_USAGE, STAGE_NAMES
from scangeo.pipeline.stages import NAMES
from tests.session_projects import copy_project


def test_the_cli_lists_the_pipeline_stages():
    assert STAGE_NAMES == NAMES


def test_done_prints_the_summary_and_a_second_call_is_up_to_date(small_block, tmp_path, capsys):
    root = copy_project(small_block, tmp_path / "p")
    assert main(["run", str(root), "--until", "check", "--no-progress"]) == EXIT_DONE
    out = capsys.readouterr().out
    assert "check     ran (" in out and "clean     not run (after --until check)" in out
    assert "match     not run (tie points in points.csv" in out
    assert main(["run", str(root), "--until", "check", "--no-progress"]) == EXIT_DONE
    assert "check     up to date" in capsys.readouterr().out


def test_a_wrong_command_line_is_2(small_block, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["run", str(small_block), "--from", "orthophoto"])
    assert exc.value.code == EXIT_USAGE
    assert "invalid choice: 'orthophoto'" in capsys.readouterr().err


def test_a_failed_stage_is_1_and_recorded(small_block, tmp_path, capsys):
    root = copy_project(small_block, tmp_path / "p")
    text = (root / "ground.csv").read_text(encoding="utf-8").splitlines()
    text[1] = text[1].rsplit(",", 1)[0] + ",kontrol"
    (root / "ground.csv").write_text("\n".join(text) + "\n", encoding="utf-8")
    assert main(["run", str(root), "--until", "check", "--no-progress"]) == EXIT_FAILED
    err = capsys.readouterr().err
    assert "stage check failed" in err and "ground.csv line 2: role 'kontrol'" in err
    record = json.loads((root / "results" / "run.json").read_text(encoding="utf-8"))["stages"]["check"]
    assert record["status"] == "failed" and "kontrol" in record["error"]


def test_a_missing_project_is_1(tmp_path, capsys):
    assert main(["run", str(tmp_path / "nowhere"), "--no-progress"]) == EXIT_FAILED
    assert "nowhere: no such project file" in capsys.readouterr().err


def test_a_locked_project_is_3(small_block, tmp_path, capsys):
    root = copy_project(small_block, tmp_path / "p")
    with OutputLock(root, "another scangeo run"):
        assert main(["run", str(root), "--no-progress"]) == EXIT_LOCKED
    assert "another scangeo run is writing this project" in capsys.readouterr().err
    assert not (root / "results" / "run.json").exists()


def test_an_interrupted_run_is_130(small_block, tmp_path, monkeypatch, capsys):
    import scangeo.pipeline.run

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(scangeo.pipeline.run, "run", interrupted)
    assert main(["run", str(copy_project(small_block, tmp_path / "p")), "--no-progress"]) == EXIT_INTERRUPTED
    assert "interrupted" in capsys.readouterr().err
