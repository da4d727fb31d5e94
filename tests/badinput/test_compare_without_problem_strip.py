"""``scangeo compare`` on a project with no problem strip and no truth: it runs without an
invented --problem-strip, writing default variants without P and S variants."""
from __future__ import annotations

import json
import shutil

from tests.session_projects import copy_project


def test_compare_runs_without_a_problem_strip(small_block, tmp_path, capsys):
    from scangeo.cli import main

    root = copy_project(small_block, tmp_path / "p")
    shutil.rmtree(root / "truth", ignore_errors=True)
    assert main(["compare", str(root), "--only", "DG", "SE", "--no-report", "--no-progress"]) == 0
    text = (root / "variants.toml").read_text()
    assert "no problem strip" in text and "[variants.SE]" in text
    assert "@PROBLEM_STRIP@" not in text.split("[defaults]")[1]
    comparison = json.loads((root / "results" / "comparison.json").read_text())
    assert [(v["name"], v["error"]) for v in comparison["variants"]] == [("DG", None), ("SE", None)]
    assert "error" not in capsys.readouterr().err
