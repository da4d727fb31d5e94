"""docs/api.md's worked example runs as written: its python blocks, in order, in one namespace."""
from __future__ import annotations

import re
import shutil
from pathlib import Path

import scangeo

PAGE = Path(scangeo.__file__).resolve().parents[1] / "docs" / "api.md"


def python_blocks(text: str) -> list[str]:
    return re.findall(r"^```python\n(.*?)^```", text, flags=re.S | re.M)


def test_the_page_has_the_worked_example():
    blocks = python_blocks(PAGE.read_text(encoding="utf-8"))
    code = "\n".join(blocks)
    assert len(blocks) == 5
    for call in ("simulate_project(", "Project.load(", "adjust(", "compare(", "rectify_in_memory(",
                 "read_orientation("):
        assert f"scangeo.{call}" in code, call


def test_the_worked_example_runs(capsys):
    namespace: dict = {"__name__": "docs_api"}
    try:
        for i, block in enumerate(python_blocks(PAGE.read_text(encoding="utf-8"))):
            exec(compile(block, f"docs/api.md block {i + 1}", "exec"), namespace)  # noqa: S102 (our own page)
        out = capsys.readouterr().out
        assert "SE: sigma0" in out and "seen" in out and "(adjusted: True" in out
        assert namespace["ortho"].values.shape[0] == 11  # every band of the simulated scanner
    finally:
        if "folder" in namespace:
            shutil.rmtree(namespace["folder"], ignore_errors=True)
