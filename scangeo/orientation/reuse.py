"""A project and its orientations read once per process, for the many tasks of one run.

Matching and rectification run one task per overlap or strip, in this process or in worker
processes. Loading the project (opening the DTM of the whole block) and the variant's
``orientation.json`` (every strip's) for each task would make a run's work grow with the square of
the block. Here the tasks of a process share them through :mod:`scangeo.filecache`: keyed by the
stamps of ``project.toml`` and the DTM, and of ``orientation.json`` (a changed file is read again);
a run clears them at its start (:func:`clear`).
"""
from __future__ import annotations

from pathlib import Path

from scangeo.filecache import FileCache
from scangeo.io.project import Project
from scangeo.orientation.file import FILE_NAME, Orientation, load_orientation

#: the project of this process's tasks (a worker runs the tasks of one project)
_PROJECTS: FileCache[Project] = FileCache("projects", 1)
#: the orientations of the variants its tasks read (a comparison's matching reads one or two)
_ORIENTATIONS: FileCache[Orientation] = FileCache("orientations", 2)


def clear() -> None:
    """Forget the projects and orientations read so far (files may have changed)."""
    _PROJECTS.clear()
    _ORIENTATIONS.clear()


def project_of(path: str | Path) -> Project:
    """``Project.load(path)``, once per process while ``project.toml`` and the DTM are unchanged."""
    root = Path(path)
    file = root / "project.toml" if root.is_dir() else root
    return _PROJECTS.get(str(path), [file], lambda: Project.load(path),
                         derived=lambda p: [getattr(p, "dtm_path", None)])


def orientation_of(project: Project, variant: str) -> Orientation:
    """``load_orientation(project, variant)``, once per process while its file and the project's are
    unchanged (direct georeferencing, without a file, on the strips' trajectories too)."""
    file = project.root / "results" / variant / FILE_NAME
    files = [project.root / "project.toml", file]
    if not file.exists():
        files += [s.trajectory for s in project.strips]
    return _ORIENTATIONS.get((str(project.root), variant), files, lambda: load_orientation(project, variant))


__all__ = ["clear", "orientation_of", "project_of"]
