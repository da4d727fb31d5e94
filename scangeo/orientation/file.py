"""The orientation of a variant as a file: ``PROJECT/results/NAME/orientation.json``.

Everything the strip geometry of a variant is built from, in SI units and radians (schema
``scangeo.orientation/1``, docs/formats.md): per strip the orientation spline (t0, spacing,
coefficients), line timing and number of lines; the sensor model with its calibration (scan index
and scale), the mounting (lever arm, boresight, time offset); the GPS/IMU models with their
correction functions, coefficients and breaks; the project frame, map CRS and geoid. ``scangeo
adjust`` writes it for every variant; other tools can read or write it.

:class:`Orientation` holds one such document and :meth:`Orientation.geometry` is the one place
where an adjusted strip geometry is built: the adjustment's own check points, rectification,
locate, matching, the reports and the true-error table all go through it (an adjustment result
makes its :class:`Orientation` with ``VariantResult.orientation``; a results folder gives it with
:func:`load_orientation`). The document's classes live in :mod:`scangeo.orientation.document`, its
JSON form in :mod:`scangeo.orientation.codec`; this module finds, reads and writes the file (and
names them all, as before the split).
"""
from __future__ import annotations

import json
import os
from collections.abc import Iterator, Mapping
from pathlib import Path

from scangeo.atomic import write_text
from scangeo.errors import OrientationFileError
from scangeo.io.project import Project
from scangeo.orientation.codec import orientation_dict, orientation_from_dict
from scangeo.orientation.document import (
    DIRECT,
    FILE_NAME,
    PLATFORM_SCHEMA,
    SCHEMA,
    MapReference,
    Orientation,
    SensorSetup,
    StripOrientation,
    strip_geometries,
)
from scangeo.sensors.strip import StripGeometry


# --- building it ----------------------------------------------------------------------------------
def map_reference(project: Project) -> MapReference:
    mf = project.map_frame
    return MapReference(mf.frame, mf.crs.to_wkt(), None if project.geoid.path else project.geoid.constant,
                        project.geoid.path)


class _DirectStrips(Mapping[str, StripOrientation]):
    """The strips of direct georeferencing, each fitted to its GPS/IMU when first asked for (a
    worker rectifying one strip reads one trajectory)."""

    def __init__(self, project: Project) -> None:
        self.project = project
        self.ids = [s.id for s in project.image_strips]
        self.cache: dict[str, StripOrientation] = {}

    def __getitem__(self, strip_id: str) -> StripOrientation:
        if strip_id not in self.ids:
            raise KeyError(strip_id)
        if strip_id not in self.cache:
            g = self.project.geometry(strip_id)
            s = self.project.strip(strip_id)
            self.cache[strip_id] = StripOrientation(strip_id, g.n_lines, g.timing, g.spline, s.sensor,
                                                    "" if s.flight_line == strip_id else s.flight_line)
        return self.cache[strip_id]

    def __iter__(self) -> Iterator[str]:
        return iter(self.ids)

    def __len__(self) -> int:
        return len(self.ids)


def project_sensors(project: Project) -> dict[str, SensorSetup]:
    """The line scanners of a project as project.toml gives them (model and mounting), by id."""
    return {sid: SensorSetup(sc.model, sc.mounting) for sid, sc in project.line_scanners.items()}


def direct_orientation(project: Project) -> Orientation:
    """Direct georeferencing: per strip the spline fitted to the GPS/IMU of its flight line as measured
    (when first used), the strip's sensor and mounting as project.toml gives them."""
    return Orientation(DIRECT, False, project_sensors(project), _DirectStrips(project), map_reference(project))


def results_folder(project: Project, variant: str) -> Path:
    return project.root / "results" / variant


def load_orientation(project: Project, variant: str | os.PathLike[str]) -> Orientation:
    """The orientation of ``variant``: ``results/NAME/orientation.json`` when it exists, direct
    georeferencing for ``DG`` without one; any other variant without one is an error.

    ``variant`` may also be an explicit path (a :class:`~pathlib.Path`, or a string naming a ``.json``
    file or holding a path separator): an orientation file, or a folder that holds
    ``orientation.json``. It must have been written for the project's frame.
    """
    if isinstance(variant, os.PathLike) or variant.endswith(".json") or "/" in variant or os.sep in variant:
        path = Path(variant)
        path = path / FILE_NAME if path.is_dir() else path
        if not path.is_file():
            raise OrientationFileError(f"{path}: no orientation file there")
        doc = read_orientation_file(path)
        _check_frame(doc, project)
        return doc
    path = results_folder(project, variant) / FILE_NAME
    if path.exists():
        doc = read_orientation_file(path)
        _check_frame(doc, project)
        return doc
    if variant.upper() == DIRECT:
        return direct_orientation(project)
    folder = path.parent
    older = folder.is_dir() and any(folder.glob("spline_*.json"))
    raise OrientationFileError(
        f"{path}: no orientation for variant {variant!r} "
        + ("(the folder was written by an older scangeo: adjust the variant again)" if older else
           f"(adjust the variant first, or use {DIRECT}: the GPS/IMU as measured)")
    )


def _check_frame(doc: Orientation, project: Project) -> None:
    """The splines are in the project frame the file names: it must be the project's."""
    f, g = doc.reference.frame, project.map_frame.frame
    if abs(f.lat0 - g.lat0) > 1e-12 or abs(f.lon0 - g.lon0) > 1e-12 or abs(f.h0 - g.h0) > 1e-6:
        raise OrientationFileError(
            f"{doc.path} [frame.project_frame]: written for the project frame at {f.to_dict()}, the project's is "
            f"at {g.to_dict()} (its origin or DTM changed since the adjustment: run 'scangeo adjust' again)")


def load_adjusted_geometry(project: Project, variant: str | os.PathLike[str], strip_id: str) -> StripGeometry:
    """The geometry of a strip with the orientation of ``variant`` (see :func:`load_orientation`)."""
    return load_orientation(project, variant).geometry(strip_id)




# --- the file -------------------------------------------------------------------------------------
def write_orientation(doc: Orientation, path: str | Path) -> Path:
    """Write ``doc`` to ``path`` (a temporary name, then renamed); returns the path."""
    path = Path(path)
    write_text(path, json.dumps(orientation_dict(doc), indent=1))
    return path


def read_orientation_file(path: str | Path) -> Orientation:
    """Read an ``orientation.json``; errors name the file and the key."""
    path = Path(path)
    try:
        data = json.loads(path.read_text())
    except FileNotFoundError as exc:
        raise OrientationFileError(f"{path}: no such file") from exc
    except OSError as exc:
        raise OrientationFileError(f"{path}: cannot read ({exc})") from exc
    except json.JSONDecodeError as exc:
        raise OrientationFileError(f"{path} line {exc.lineno}: not JSON ({exc.msg})") from exc
    return orientation_from_dict(data, path)


__all__ = ["SCHEMA", "PLATFORM_SCHEMA", "FILE_NAME", "DIRECT", "SensorSetup", "project_sensors", "Orientation",
           "StripOrientation", "MapReference", "strip_geometries",
           "direct_orientation", "load_orientation", "load_adjusted_geometry", "read_orientation_file",
           "write_orientation", "orientation_dict", "orientation_from_dict", "map_reference", "results_folder"]
