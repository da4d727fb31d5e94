"""scangeo: georeferencing of airborne line-scanner imagery.

Orientation spline, GPS/IMU models with correction functions, hybrid least-squares adjustment,
ground <-> image on a DTM, and rectification. The documentation is in docs/ of the source tree;
docs/api.md shows the workflow from Python.

The front door (``scangeo.workflow``): :class:`Project`, :func:`simulate_project`,
:func:`match_points`, :func:`adjust`, :func:`compare`, :func:`diagnose`, :func:`rectify_strips`,
:func:`rectify_in_memory`, :func:`read_orientation`, :func:`lidar_adjust` and the staged pipeline
:func:`run` (``scangeo.pipeline.run``, docs/run.md), each returning a dataclass. They load on first use (PEP 562
``__getattr__``): ``import scangeo`` alone stays cheap
(milliseconds, instead of the seconds numba, GDAL and the adjustment take to import) and has no
process-wide side effects (numba's threading layer is chosen the moment before scangeo's first
parallel kernel runs, ``scangeo.threading_layer``).
"""
from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from scangeo.errors import ScangeoError
from scangeo.version import __version__

if TYPE_CHECKING:
    from scangeo.io.project import Project
    from scangeo.pipeline.run import RunResult, run
    from scangeo.workflow import (
        Adjustment,
        ComparisonRun,
        DiagnosisRun,
        LaserResult,
        LaserSimulation,
        adjust,
        compare,
        diagnose,
        lidar_adjust,
        match_points,
        read_orientation,
        rectify_in_memory,
        rectify_strips,
        simulate_project,
    )

__all__ = [
    "Adjustment", "ComparisonRun", "DiagnosisRun", "LaserResult", "LaserSimulation", "Project", "ScangeoError",
    "__version__", "adjust", "compare", "diagnose", "lidar_adjust", "match_points", "read_orientation",
    "rectify_in_memory", "rectify_strips", "simulate_project", "RunResult", "run",
]

# name -> the module that defines it, imported on first access (module docstring)
_LAZY = {name: "scangeo.workflow" for name in __all__ if name not in ("Project", "ScangeoError", "__version__")}
_LAZY["Project"] = "scangeo.io.project"
_LAZY["run"] = _LAZY["RunResult"] = "scangeo.pipeline.run"


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'scangeo' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value  # later look-ups skip this function
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
