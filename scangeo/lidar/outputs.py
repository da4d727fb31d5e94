"""Kept for :mod:`scangeo.workflow` until the front door takes the typed result: ``adjust_project``
returns ``results.json`` as a dict. Use :func:`scangeo.lidar.workflow.adjust_laser` (a
:class:`~scangeo.lidar.result.LaserResult`)."""

from __future__ import annotations

from pathlib import Path

from scangeo.lidar.workflow import adjust_laser
from scangeo.progress import ProgressCallback, no_progress


def adjust_project(project_path, out: Path | None, ground: Path | None = None,
                   callback: ProgressCallback = no_progress, write_strips: bool = True, **overrides) -> dict:
    """:func:`scangeo.lidar.workflow.adjust_laser`, its result as ``results.json`` holds it."""
    return adjust_laser(project_path, out, ground, callback, write_strips, **overrides).to_dict()
