"""Project files: project.toml, points.csv, ground.csv.

``Project``, ``ImagePoints`` and ``GroundPoints`` load on first use (PEP 562): importing a light
module of this package (``scangeo.io.schema``, ``scangeo.io.toml_config``) does not import the
project reader, the DTM and numba with it.
"""
from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from scangeo.io.points import GroundPoints, ImagePoints
    from scangeo.io.project import Project

__all__ = ["Project", "ImagePoints", "GroundPoints"]

_LAZY = {"Project": "scangeo.io.project", "ImagePoints": "scangeo.io.points", "GroundPoints": "scangeo.io.points"}


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'scangeo.io' has no attribute {name!r}")
    return getattr(importlib.import_module(module), name)
