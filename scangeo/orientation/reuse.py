"""A project and its orientations read once per process, for the many tasks of one run.

Matching and rectification run one task per overlap or strip, in this process or in worker
processes. Each task used to load the project (opening the DTM of the whole block) and the
variant's ``orientation.json`` (every strip's): per task work that grows with the block, so a
run's grew with its square. Here the tasks of a process share them, under the modification
times of ``project.toml`` and ``orientation.json`` (a changed file is read again); a run clears
them at its start (:func:`clear`).
"""
from __future__ import annotations

from pathlib import Path

from scangeo.io.project import Project
from scangeo.orientation.file import FILE_NAME, Orientation, load_orientation

_PROJECTS: dict[tuple, Project] = {}
_ORIENTATIONS: dict[tuple, Orientation] = {}


def clear() -> None:
    """Forget the projects and orientations read so far (files may have changed)."""
    _PROJECTS.clear()
    _ORIENTATIONS.clear()


def _stamp(path: Path) -> int | None:
    try:
        return path.stat().st_mtime_ns
    except OSError:
        return None


def project_of(path: str | Path) -> Project:
    """``Project.load(path)``, once per process while ``project.toml`` is unchanged."""
    root = Path(path)
    key = (str(path), _stamp(root / "project.toml" if root.is_dir() else root))
    if key not in _PROJECTS:
        _PROJECTS.clear()
        _PROJECTS[key] = Project.load(path)
    return _PROJECTS[key]


def orientation_of(project: Project, variant: str) -> Orientation:
    """``load_orientation(project, variant)``, once per process while its file is unchanged."""
    key = (str(project.root), variant, _stamp(project.root / "results" / variant / FILE_NAME))
    if key not in _ORIENTATIONS:
        if len(_ORIENTATIONS) >= 2:
            _ORIENTATIONS.pop(next(iter(_ORIENTATIONS)))
        _ORIENTATIONS[key] = load_orientation(project, variant)
    return _ORIENTATIONS[key]


__all__ = ["clear", "orientation_of", "project_of"]
