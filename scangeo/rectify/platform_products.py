"""The products of a platform (several line scanners on one navigation system) that line up.

* **One grid.** Every strip of a run is rectified at one resolution in the project's CRS, its cell edges on
  multiples of the resolution (:class:`~scangeo.rectify.output_grid.OutputGrid`), so the cells of all
  sensors align exactly. By default a platform's resolution is the *finest* of its line scanners' nadir
  ground pixels (each sensor's from its first image strip, two significant digits): no sensor's bands are
  sampled on cells coarser than its pixels, which would alias them; the coarser sensors are oversampled.
  ``resolution`` (``--resolution``) overrides it. It is chosen from the project's sensors, not from the
  strips of one run, so runs of different strips line up too.
* **A mosaic per sensor** (their bands differ): ``mosaic-<sensor>.tif``; a one-sensor project keeps its
  ``mosaic.tif``.
* **A VRT per flight line** whose strips of at least two sensors were rectified in the run:
  ``<flight line>.vrt`` stacks their bands (:mod:`scangeo.rectify.stack_vrt`).
* **The co-registration layers**: for each strip with a reference on its flight line in the variant's
  ``coregistration.json``, ``<strip>.coregistration.tif`` (:mod:`scangeo.rectify.coregistration_layer`).
"""
from __future__ import annotations

import logging
from pathlib import Path

from scangeo.io.project import Project
from scangeo.orientation.file import Orientation
from scangeo.rectify.core_geometry import CoreStripGeometry
from scangeo.rectify.coregistration_layer import read_coregistration
from scangeo.rectify.geometry import nadir_ground_pixel
from scangeo.rectify.output_grid import nice_resolution
from scangeo.rectify.stack_vrt import StackMember, write_stack_vrt

log = logging.getLogger(__name__)

#: The co-registration file beside a variant's orientation.json (``scangeo.adjustment.outputs`` writes it).
COREGISTRATION_FILE = "coregistration.json"


def several_sensors(project: Project) -> bool:
    """Whether the project's image strips were recorded by more than one line scanner."""
    return len(project.line_scanners) > 1


def finest_resolution(project: Project, source: Orientation) -> tuple[float, str]:
    """The finest nadir ground pixel of the project's line scanners, two significant digits, and its sensor.

    Parameters
    ----------
    project : Project
        The project (its line scanners and their first image strips).
    source : Orientation
        The orientation the strips are rectified with.

    Returns
    -------
    tuple of float and str
        Map units (metres for a projected CRS), and the id of the sensor whose pixel it is.
    """
    pixels = {}
    for sensor in project.line_scanners:
        first = next(s.id for s in project.image_strips if s.sensor == sensor and s.image is not None)
        pixels[sensor] = nadir_ground_pixel(CoreStripGeometry(source.geometry(first), project.dtm))
    sensor = min(pixels, key=lambda k: pixels[k])
    log.info("platform resolution: the finest nadir ground pixel, %s's %.4g (%s)", sensor, pixels[sensor],
             ", ".join(f"{k} {v:.4g}" for k, v in pixels.items()))
    return nice_resolution(pixels[sensor]), sensor


def mosaic_name(project: Project, sensor: str) -> str:
    """``mosaic.tif`` for a one-sensor project, ``mosaic-<sensor>.tif`` for each sensor of a platform."""
    return f"mosaic-{sensor}.tif" if several_sensors(project) else "mosaic.tif"


def strips_by_sensor(project: Project, ids: list[str]) -> dict[str, list[str]]:
    """The strips ``ids`` by the sensor that recorded them (sensors in the project's order)."""
    out: dict[str, list[str]] = {sensor: [] for sensor in project.sensors}
    for sid in ids:
        out[project.strip(sid).sensor].append(sid)
    return {k: v for k, v in out.items() if v}


def stacked_flight_lines(project: Project, ids: list[str]) -> dict[str, list[str]]:
    """The flight lines among ``ids`` with strips of at least two sensors, and those strips (project order)."""
    out: dict[str, list[str]] = {}
    chosen = set(ids)
    for fid, line in project.flight_lines.items():
        strips = [sid for sid in line.strips if sid in chosen]
        if len({project.strip(sid).sensor for sid in strips}) >= 2:
            out[fid] = strips
    return out


def coregistration_file(project: Project, source: Orientation) -> Path | None:
    """The variant's co-registration file when the project is a platform and the file exists (an adjusted
    variant; direct georeferencing has none: no covariance)."""
    if not several_sensors(project) or source.path is None:
        return None
    path = Path(source.path).parent / COREGISTRATION_FILE
    return path if path.is_file() else None


def coregistration_entries(project: Project, source: Orientation) -> tuple[Path | None, dict[str, dict]]:
    """The co-registration file and its entries by strip (none for a one-sensor project or without the file)."""
    path = coregistration_file(project, source)
    if path is None:
        if several_sensors(project) and source.adjusted:
            log.info("no %s beside %s: no co-registration layers", COREGISTRATION_FILE, source.path)
        return None, {}
    return path, read_coregistration(path)


def write_flight_line_vrts(project: Project, folder: Path, ids: list[str], variant: str) -> dict[str, Path]:
    """``<flight line>.vrt`` in ``folder`` for every flight line of :func:`stacked_flight_lines`.

    Parameters
    ----------
    project : Project
        The project.
    folder : Path
        The orthoimages' folder (``results/VARIANT/ortho``).
    ids : list of str
        The strips of the run.
    variant : str
        The variant (recorded in the VRT's metadata).

    Returns
    -------
    dict of str to Path
        Flight line id -> its VRT.
    """
    out = {}
    for fid, strips in stacked_flight_lines(project, ids).items():
        members = [StackMember(folder / f"{sid}.tif", project.strip(sid).sensor, sid) for sid in strips]
        tags = {"flight_line": fid, "variant": variant, "strips": " ".join(strips),
                "sensors": " ".join(dict.fromkeys(m.sensor for m in members))}
        out[fid] = write_stack_vrt(folder / f"{fid}.vrt", members, tags)
    return out


__all__ = ["COREGISTRATION_FILE", "coregistration_entries", "coregistration_file", "finest_resolution", "mosaic_name",
           "several_sensors", "stacked_flight_lines", "strips_by_sensor", "write_flight_line_vrts"]
