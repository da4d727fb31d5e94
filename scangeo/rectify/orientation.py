"""Old home of the variant's orientation; it now lives in :mod:`scangeo.adjustment.orientation`.

Kept only while callers move over: ``orientation_source(project, variant)`` is
``load_orientation`` and ``core_geometry(project, source, strip)`` is ``source.geometry(strip)``.
"""
from __future__ import annotations

from scangeo.adjustment.orientation import DIRECT, Orientation, load_orientation, results_folder
from scangeo.io.project import Project
from scangeo.sensors.strip import StripGeometry


def orientation_source(project: Project, variant: str) -> Orientation:
    return load_orientation(project, variant)


def core_geometry(project: Project, source: Orientation, strip_id: str) -> StripGeometry:
    return source.geometry(strip_id)


__all__ = ["DIRECT", "core_geometry", "orientation_source", "results_folder"]
