"""A project's settings file: ``PROJECT/run.toml`` (or the file given with ``--config``).

One TOML file with a table per stage: ``[match]``, ``[clean]``, ``[compare]``, ``[rectify]``, each
optional. ``scangeo run`` reads it, and so does every stage command (``scangeo match``, ``clean``,
``compare``, ``rectify``): a stage run alone uses the settings it would use in a run, and a flag
given on the command line replaces its key. Each table is the settings dataclass of its stage
(:class:`~scangeo.match.options.MatchOptions`, :class:`~scangeo.strategy.cleaning.CleaningOptions`,
:class:`CompareSettings`, :class:`~scangeo.rectify.options.RectifyOptions`) read through
:mod:`scangeo.io.schema`: an unknown table or key, or a value out of range, is an error naming the
file and the key.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

from scangeo.errors import OptionsError
from scangeo.io.project import Project
from scangeo.io.schema import Rule, check, read, setting
from scangeo.io.toml_config import load_toml
from scangeo.match.options import MatchOptions
from scangeo.rectify.options import RectifyOptions
from scangeo.strategy.cleaning import CleaningOptions

#: The settings file of a project, read when no other is given.
SETTINGS_FILE = "run.toml"


@dataclass(frozen=True)
class CompareSettings:
    """How :func:`scangeo.compare` compares the variants (the ``[compare]`` table).

    Parameters
    ----------
    folds : int
        Folds of the cross-validation over the control points that, weighed with the check points,
        recommends a variant; 0: none (the lowest check-point rms decides).
    """

    schema_error: ClassVar[type[Exception]] = OptionsError

    folds: int = setting(4, rule=Rule(lambda v: v == 0 or v >= 2, "0 (none) or 2 or more"), unit="1",
                         doc="folds of the cross-validation over the control points (0: none)")

    def __post_init__(self) -> None:
        check(self)


@dataclass(frozen=True)
class Settings:
    """The settings of a project's stages: what ``PROJECT/run.toml`` holds (module docstring).

    Parameters
    ----------
    match : MatchOptions
        ``[match]``: point measurement (``scangeo match``, the run's match stage; docs/match.md).
    clean : CleaningOptions
        ``[clean]``: the search for blunders (``scangeo clean``, the run's clean stage).
    compare : CompareSettings
        ``[compare]``: the comparison of the variants (``scangeo compare``, the run's compare stage).
    rectify : RectifyOptions
        ``[rectify]``: the orthoimages (``scangeo rectify``, the run's rectify stage; docs/rectify.md).
    """

    match: MatchOptions = setting(MatchOptions(), doc="[match]: point measurement (docs/match.md)")
    clean: CleaningOptions = setting(CleaningOptions(), doc="[clean]: the search for blunders")
    compare: CompareSettings = setting(CompareSettings(), doc="[compare]: the comparison of the variants")
    rectify: RectifyOptions = setting(RectifyOptions(), doc="[rectify]: the orthoimages (docs/rectify.md)")

    def __post_init__(self) -> None:
        check(self)

    def as_dict(self) -> dict[str, Any]:
        """Every setting, by table.

        Returns
        -------
        dict
            Table -> key -> value (JSON-able: the run's manifest records it).
        """
        return dataclasses.asdict(self)


def settings_file(project: str | Path | Project, file: str | Path | None = None) -> Path | None:
    """The settings file of a project: ``file`` when given, else ``PROJECT/run.toml`` when it exists.

    Parameters
    ----------
    project : str, Path or Project
        The project folder (or its project.toml), or a loaded project.
    file : str or Path, optional
        A settings file given explicitly (``--config``).

    Returns
    -------
    Path or None
        The file to read; None when there is none (every setting at its default).
    """
    if file is not None:
        return Path(file)
    root = project.root if isinstance(project, Project) else Path(project)
    root = root.parent if root.name == "project.toml" else root
    path = root / SETTINGS_FILE
    return path if path.is_file() else None


def read_settings(project: str | Path | Project, file: str | Path | None = None) -> Settings:
    """A project's settings: its ``run.toml`` (or ``file``), every table and key checked.

    Parameters
    ----------
    project : str, Path or Project
        The project folder (or its project.toml), or a loaded project.
    file : str or Path, optional
        Another settings file (``--config``); default ``PROJECT/run.toml`` when it exists.

    Returns
    -------
    Settings
        The settings of every stage; the defaults where the file has no table or key, and all of
        them without a file.

    Raises
    ------
    ProjectFileError
        The file cannot be read or is not TOML; an unknown table or key (the message names the file
        and the key).
    OptionsError
        A value out of range (``run.toml [rectify.max_error_px]: expected a number > 0 (px), found 0``;
        RectifyOptionsError for ``[rectify]``).
    """
    path = settings_file(project, file)
    if path is None:
        return Settings()
    return read(Settings, load_toml(path), str(path))


__all__ = ["CompareSettings", "SETTINGS_FILE", "Settings", "read_settings", "settings_file"]
