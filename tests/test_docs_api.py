"""docs/api.md: its reference lists every name of ``scangeo.__all__`` from their numpydoc docstrings (generated,
up to date), and its worked example runs as written: its python blocks, in order, in one namespace."""
from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest

import scangeo
from tests import api_reference

PAGE = Path(scangeo.__file__).resolve().parents[1] / "docs" / "api.md"


@pytest.mark.parametrize("name", scangeo.__all__)
def test_every_name_of_the_front_door_has_parameters_and_returns(name):
    """A call: Parameters and Returns; a class: Parameters (its fields), and Returns in every method and
    property it defines (Parameters too where it takes arguments); ``__version__`` is a string."""
    assert api_reference.missing_sections(name) == []
    obj = getattr(scangeo, name)
    if callable(obj):
        assert api_reference.sections(obj.__doc__ or "")[""], f"{name}: no summary line"


def test_the_checker_finds_a_missing_section():
    def documented(x: int) -> int:
        """Twice.

        Parameters
        ----------
        x : int
            A number.

        Returns
        -------
        int
            ``2 x``.
        """
        return 2 * x

    def undocumented(x: int) -> int:
        """Twice ``x``."""
        return 2 * x

    class Options:
        """Options.

        Parameters
        ----------
        a : int
            A.
        """

        def twice(self, x: int) -> int:
            """``2 x``.

            Returns
            -------
            int
                It.
            """
            return 2 * x

    for value, missing in ((documented, []), (undocumented, ["f: Parameters", "f: Returns"]),
                           (Options, ["f.twice: Parameters"])):
        scangeo.__dict__["f"] = value
        try:
            assert api_reference.missing_sections("f") == missing
        finally:
            del scangeo.__dict__["f"]


def test_the_reference_lists_every_name_and_is_up_to_date():
    text = PAGE.read_text(encoding="utf-8")
    listed = set(re.findall(r"^#### scangeo\.(\w+)$", text, flags=re.M))
    assert listed == set(scangeo.__all__)
    assert api_reference.render(text) == text, "docs/api.md is stale: python -m tests.api_reference"
    assert "<function" not in text and " at 0x" not in text  # nothing of one process's memory


def python_blocks(text: str) -> list[str]:
    return re.findall(r"^```python\n(.*?)^```", text, flags=re.S | re.M)


def test_the_page_has_the_worked_example():
    blocks = python_blocks(PAGE.read_text(encoding="utf-8").split("<!-- api-reference -->")[0])
    code = "\n".join(blocks)
    assert len(blocks) == 5
    for call in ("simulate_project(", "Project.load(", "adjust(", "compare(", "rectify_in_memory(",
                 "read_orientation("):
        assert f"scangeo.{call}" in code, call


def test_the_worked_example_runs(capsys):
    namespace: dict = {"__name__": "docs_api"}
    try:
        for i, block in enumerate(python_blocks(PAGE.read_text(encoding="utf-8").split("<!-- api-reference -->")[0])):
            exec(compile(block, f"docs/api.md block {i + 1}", "exec"), namespace)  # noqa: S102 (our own page)
        out = capsys.readouterr().out
        assert "SE: sigma0" in out and "seen" in out and "(adjusted: True" in out
        assert namespace["ortho"].values.shape[0] == 11  # every band of the simulated scanner
    finally:
        if "folder" in namespace:
            shutil.rmtree(namespace["folder"], ignore_errors=True)
