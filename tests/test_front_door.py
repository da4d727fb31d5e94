"""``import scangeo``: the workflow at the package root, typed, loaded on first use."""
from __future__ import annotations

import dataclasses
import importlib.util
import inspect
import subprocess
import sys
import typing

import scangeo
import scangeo.workflow as workflow


def test_every_name_of_the_front_door_resolves_and_none_shadows_a_subpackage():
    for name in scangeo.__all__:
        assert getattr(scangeo, name) is not None
        assert importlib.util.find_spec(f"scangeo.{name}") is None, f"scangeo.{name} is also a module"
    assert scangeo.adjust is workflow.adjust and scangeo.Project.__module__ == "scangeo.io.project"


def test_every_workflow_call_returns_a_dataclass():
    calls = [f for f in vars(workflow).values() if inspect.isfunction(f) and f.__module__ == workflow.__name__
             and not f.__name__.startswith("_")]
    assert {f.__name__ for f in calls} <= set(scangeo.__all__)
    for f in calls:
        returned = typing.get_type_hints(f)["return"]
        for t in typing.get_args(returned) or (returned,):
            assert dataclasses.is_dataclass(t), f"{f.__name__} returns {t}"
    # the staged pipeline is defined in scangeo.pipeline.run and reached through the same door
    assert scangeo.run.__module__ == "scangeo.pipeline.run"
    assert typing.get_type_hints(scangeo.run)["return"] is scangeo.RunResult
    assert dataclasses.is_dataclass(scangeo.RunResult)


def test_import_scangeo_loads_the_workflow_only_when_asked():
    code = ("import sys, scangeo; before = sorted(m for m in sys.modules if m.startswith('scangeo'));"
            "scangeo.compare; print(before, 'scangeo.workflow' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "['scangeo', 'scangeo.errors', 'scangeo.version'] True"
