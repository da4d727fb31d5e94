"""scangeo: georeferencing of airborne line-scanner imagery.

Orientation spline, GPS/IMU models with correction functions, hybrid least-squares adjustment,
ground <-> image on a DTM, and rectification. The documentation is in docs/ of the source tree;
docs/api.md shows the workflow from Python.

The front door: one call per command (:func:`simulate_project`, :func:`match_points`, :func:`clean`,
:func:`diagnose`, :func:`adjust`, :func:`compare`, :func:`report`, :func:`rectify_strips`,
:func:`rectify_in_memory`, :func:`read_orientation`, :func:`lidar_adjust`, and the staged :func:`run`,
docs/run.md), the options they take (:class:`Project`, :class:`Settings` and the options of each step)
and the dataclasses they return; ``__all__`` lists them and docs/api.md documents each. They load on
first use (PEP 562 ``__getattr__``): ``import scangeo`` alone stays cheap
(milliseconds, instead of the seconds numba, GDAL and the adjustment take to import) and has no
process-wide side effects (numba's threading layer is chosen the moment before scangeo's first
parallel kernel runs, ``scangeo.threading_layer``).
"""
from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from scangeo.errors import ScangeoError
from scangeo.version import __version__

#: name -> the module that defines it, imported on first access (module docstring)
_LAZY = {
    # the calls, one per command (scangeo.workflow; the staged run: scangeo.pipeline.run)
    "simulate_project": "scangeo.workflow", "match_points": "scangeo.workflow", "clean": "scangeo.strategy.cleaning",
    "diagnose": "scangeo.workflow", "adjust": "scangeo.workflow", "compare": "scangeo.workflow",
    "report": "scangeo.workflow", "rectify_strips": "scangeo.workflow", "rectify_in_memory": "scangeo.workflow",
    "read_orientation": "scangeo.workflow", "read_settings": "scangeo.pipeline.settings",
    "lidar_adjust": "scangeo.workflow", "run": "scangeo.pipeline.run",
    # what they take
    "Project": "scangeo.io.project", "Settings": "scangeo.pipeline.settings", "MatchOptions": "scangeo.match.options",
    "CleaningOptions": "scangeo.strategy.cleaning", "CompareSettings": "scangeo.pipeline.settings",
    "RectifyOptions": "scangeo.rectify.options", "GeoTiffProfile": "scangeo.rectify.geotiff",
    # what they return
    "SimulatedBlock": "scangeo.simulate.block", "LaserSimulation": "scangeo.workflow",
    "MatchResult": "scangeo.match.run", "Cleaning": "scangeo.strategy.cleaning",
    "DiagnosisRun": "scangeo.workflow", "Diagnosis": "scangeo.adjustment.diagnosis.diagnose",
    "AdjustmentRun": "scangeo.workflow", "VariantResult": "scangeo.adjustment.results",
    "ComparisonRun": "scangeo.workflow", "Comparison": "scangeo.adjustment.summary",
    "ReportFiles": "scangeo.reports.report", "BatchResult": "scangeo.rectify.batch",
    "StripArray": "scangeo.rectify.strip", "Orientation": "scangeo.orientation.document",
    "LaserResult": "scangeo.lidar.result", "RunResult": "scangeo.pipeline.run",
}

__all__ = ["simulate_project", "match_points", "clean", "diagnose", "adjust", "compare", "report", "rectify_strips",
    "rectify_in_memory", "read_orientation", "read_settings", "lidar_adjust", "run", "Project", "Settings",
    "MatchOptions", "CleaningOptions", "CompareSettings", "RectifyOptions", "GeoTiffProfile", "SimulatedBlock",
    "LaserSimulation", "MatchResult", "Cleaning", "DiagnosisRun", "Diagnosis", "AdjustmentRun", "VariantResult",
    "ComparisonRun", "Comparison", "ReportFiles", "BatchResult", "StripArray", "Orientation", "LaserResult",
    "RunResult", "ScangeoError", "__version__"]

if TYPE_CHECKING:
    from scangeo.adjustment.diagnosis.diagnose import Diagnosis
    from scangeo.adjustment.results import VariantResult
    from scangeo.adjustment.summary import Comparison
    from scangeo.io.project import Project
    from scangeo.lidar.result import LaserResult
    from scangeo.match.options import MatchOptions
    from scangeo.match.run import MatchResult
    from scangeo.orientation.document import Orientation
    from scangeo.pipeline.run import RunResult, run
    from scangeo.pipeline.settings import CompareSettings, Settings, read_settings
    from scangeo.rectify.batch import BatchResult
    from scangeo.rectify.geotiff import GeoTiffProfile
    from scangeo.rectify.options import RectifyOptions
    from scangeo.rectify.strip import StripArray
    from scangeo.reports.report import ReportFiles
    from scangeo.simulate.block import SimulatedBlock
    from scangeo.strategy.cleaning import Cleaning, CleaningOptions, clean
    from scangeo.workflow import (
        AdjustmentRun,
        ComparisonRun,
        DiagnosisRun,
        LaserSimulation,
        adjust,
        compare,
        diagnose,
        lidar_adjust,
        match_points,
        read_orientation,
        rectify_in_memory,
        rectify_strips,
        report,
        simulate_project,
    )


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'scangeo' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value  # later look-ups skip this function
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
