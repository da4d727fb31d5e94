"""Rectify the strips of a project: in parallel, resumable, locally or on a Dask cluster.

Outputs go to ``PROJECT/results/VARIANT/ortho/``: ``<strip>.tif`` (the orthoimage), and as asked
``<strip>.layers.tif``, ``<strip>.glt`` (+ ``.hdr``), ``<strip>.igm`` (+ ``.hdr``), ``mosaic.tif``. A
platform's strips (several sensors) are rectified onto one lattice at one resolution, with a mosaic per
sensor, a VRT per flight line stacking its sensors' bands and, for an adjusted variant, each strip's
co-registration layer (:mod:`scangeo.rectify.platform_products`).
Every strip's outputs carry a fingerprint of their inputs and settings (``scangeo_fingerprint``
tag: input paths relative to the project, sizes and content hashes, so a copied or moved project
keeps its fingerprints and is not redone); the orthoimage is written last, atomically, so a strip
whose orthoimage opens, reads and carries the current fingerprint is complete and is skipped on a
rerun. Anything else is redone.

A strip is a task (:class:`StripTask`, picklable: paths and settings only) that a worker turns
into outputs with :func:`run_strip_task`; the same function runs in-process, in a process pool
(``workers > 1``) or on a Dask distributed cluster (``scheduler``). In-process, the strips are
pipelined: a :class:`~scangeo.rectify.strip.Finaliser` thread compresses and writes one strip's
orthoimage while the next strip's inverse map is computed.
"""
from __future__ import annotations

import hashlib
import json
import logging
import multiprocessing
import time
import warnings
from dataclasses import asdict, dataclass, field
from pathlib import Path

import rasterio
from rasterio.windows import Window

from scangeo.errors import ProjectFileError
from scangeo.filecache import content_stamp
from scangeo.io.project import Project
from scangeo.orientation import reuse
from scangeo.orientation.file import Orientation, load_orientation, results_folder
from scangeo.parallel import run_tasks
from scangeo.progress import ProgressCallback, no_progress
from scangeo.rectify import platform_products as platform
from scangeo.rectify.core_geometry import CoreStripGeometry
from scangeo.rectify.coregistration_layer import CoregistrationGrid, layer_path, read_coregistration
from scangeo.rectify.geolocation import write_igm
from scangeo.rectify.geometry import nadir_ground_pixel
from scangeo.rectify.geotiff import BandInfo, remove_partials
from scangeo.rectify.mosaic import build_mosaic
from scangeo.rectify.options import RectifyOptions
from scangeo.rectify.output_grid import OutputGrid, nice_resolution
from scangeo.rectify.strip import Finaliser, StripResult, rectify_strip
from scangeo.threading_layer import choose_threading_layer
from scangeo.version import __version__

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class StripTask:
    """Everything a worker needs to rectify one strip (picklable)."""

    project: str
    variant: str
    strip: str
    options: RectifyOptions
    output: str
    fingerprint: str
    threads: int = 0
    #: the variant's coregistration.json when the strip has a reference in it (a platform's adjusted variant)
    coregistration: str | None = None


@dataclass
class BatchResult:
    """What :func:`rectify_project` did.

    Parameters
    ----------
    folder : Path
        ``PROJECT/results/VARIANT/ortho/``.
    strips : dict
        Strip id -> ``status`` (``done``, with its file, grid, valid and hidden cells, inverse-map
        error and seconds; or ``skipped``: complete from an earlier run) and ``path``.
    mosaic : Path or None
        ``mosaic.tif``; None without the mosaic, and for a platform (several sensors: ``mosaics``).
    seconds : float
        Wall-clock time.
    mosaics : dict
        Sensor id -> its mosaic (``mosaic-<sensor>.tif``; a one-sensor project: ``"" -> mosaic.tif``).
    stacks : dict
        Flight line id -> the VRT stacking the bands of its sensors' orthoimages (platforms only).
    coregistration : dict
        Strip id -> its co-registration layer's summary: ``reference``, ``flight_line``, ``median_m`` and
        ``max_m`` (the propagated grid's, metres) and ``path`` (``<strip>.coregistration.tif``).
    resolution : float
        The cell size of the run, map units.
    resolution_source : str
        Where it comes from: ``options``, ``nadir pixel of strip ID``, or ``finest sensor ID``.
    """

    folder: Path
    strips: dict[str, dict] = field(default_factory=dict)
    mosaic: Path | None = None
    seconds: float = 0.0
    mosaics: dict[str, Path] = field(default_factory=dict)
    stacks: dict[str, Path] = field(default_factory=dict)
    coregistration: dict[str, dict] = field(default_factory=dict)
    resolution: float = 0.0
    resolution_source: str = ""


def output_folder(project: Project, variant: str) -> Path:
    return results_folder(project, variant) / "ortho"


def fingerprint(project: Project, source: Orientation, strip_id: str, options: RectifyOptions,
                coregistration: Path | None = None) -> str:
    """A hash of everything a strip's outputs depend on: the input files (paths relative to the project,
    sizes and content hashes: the same for a copied or moved project; the co-registration file when the
    strip has a layer), the settings and the version."""
    s = project.strip(strip_id)
    files = [project.root / "project.toml", project.dtm_path, s.trajectory, s.image]
    files += [s.line_times] if s.line_times else []
    files += [source.path] if source.path is not None else []
    files += [coregistration] if coregistration is not None else []
    data = {
        "version": __version__,
        "variant": source.variant,
        "strip": strip_id,
        "options": asdict(options),
        "files": [list(content_stamp(Path(f), project.root)) for f in files if f is not None],
    }
    return hashlib.sha256(json.dumps(data, sort_keys=True, default=str).encode()).hexdigest()[:24]


def is_complete(path: Path, fp: str) -> bool:
    """The orthoimage exists, opens, reads its last block, and carries the fingerprint ``fp``."""
    if not path.exists():
        return False
    try:
        with rasterio.open(path) as src:
            if src.tags().get("scangeo_fingerprint") != fp:
                return False
            h, w = src.height, src.width
            src.read(window=Window(max(w - 8, 0), max(h - 8, 0), min(8, w), min(8, h)))
        return True
    except rasterio.errors.RasterioError:
        return False


def _band_info(project: Project, strip_id: str) -> list[BandInfo] | None:
    """Band names and wavelengths: the strip's sensor's bands, else the image's own."""
    sensor = project.scanner_of(strip_id)
    names, waves = sensor.bands, sensor.wavelengths_nm
    if not names:
        return None
    return [
        BandInfo(n, waves[i] if i < len(waves) else None, "nm" if i < len(waves) else None)
        for i, n in enumerate(names)
    ]


def run_strip_task(task: StripTask, progress: ProgressCallback = no_progress) -> dict:
    """Rectify one strip (in whatever process runs this) and return its summary."""
    return {"strip": task.strip, "status": "done", **start_strip_task(task, progress).summary()}


def start_strip_task(task: StripTask, progress: ProgressCallback = no_progress,
                     finaliser: Finaliser | None = None) -> StripResult:
    """Rectify one strip; with a finaliser the result's outputs are written in its thread
    (``result.wait()``)."""
    if task.threads:
        import cv2
        import numba

        cv2.setNumThreads(task.threads)
        choose_threading_layer()
        numba.set_num_threads(min(task.threads, numba.config.NUMBA_NUM_THREADS))  # type: ignore[attr-defined]
    # shared by the strips this process rectifies: loading them per strip grew with the block
    project = reuse.project_of(task.project)
    source = reuse.orientation_of(project, task.variant)
    geometry = CoreStripGeometry(source.geometry(task.strip), project.dtm)
    cfg = project.strip(task.strip)
    if cfg.image is None:
        raise ProjectFileError(f"{project.root / 'project.toml'} [strips id={task.strip}]: no image to rectify")
    output = Path(task.output)
    if task.options.igm:
        write_igm(geometry, output.with_suffix(".igm"))
    bands = _band_info(project, task.strip)
    if bands is not None:
        with warnings.catch_warnings():  # a raw scanner image has no georeferencing
            warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)
            with rasterio.open(cfg.image) as src:
                count = src.count
        if len(bands) != count:
            table = f"[[sensors]] id={cfg.sensor}" if platform.several_sensors(project) else "[sensor]"
            log.warning("%s has %d bands, %s bands names %d: using the image's", cfg.image, count, table, len(bands))
            bands = None
    tags = {
        "variant": task.variant,
        "strip": task.strip,
        "orientation": "adjusted" if source.adjusted else "direct georeferencing",
        "sigma0": "" if source.sigma0 is None else f"{source.sigma0:.6g}",
        "scangeo_fingerprint": task.fingerprint,
    }
    if platform.several_sensors(project):
        tags.update(sensor=cfg.sensor, flight_line=cfg.flight_line)
    coregistration = None
    if task.coregistration is not None:
        entry = read_coregistration(Path(task.coregistration))[task.strip]
        coregistration = CoregistrationGrid.from_entry(entry, geometry.lines, geometry.pixels,
                                                       f"{task.coregistration} strip {task.strip}")
    # the mosaic needs each strip's view zenith layer; a strip rectified alone writes only the layers asked for
    options = task.options.replace(layers=task.options.strip_layers)
    return rectify_strip(geometry, cfg.image, output, options, tags=tags, bands=bands, progress=progress,
                         finaliser=finaliser, coregistration=coregistration)


def project_resolution(project: Project, source: Orientation, strip_ids: list[str]) -> float:
    """The common resolution of a run: the nadir ground pixel of the first strip, two digits; a platform's
    (several sensors): the finest of its sensors' (:func:`scangeo.rectify.platform_products.finest_resolution`)."""
    return _resolution(project, source, strip_ids)[0]


def _resolution(project: Project, source: Orientation, strip_ids: list[str]) -> tuple[float, str]:
    if platform.several_sensors(project):
        resolution, sensor = platform.finest_resolution(project, source)
        return resolution, f"finest sensor {sensor}"
    geometry = CoreStripGeometry(source.geometry(strip_ids[0]), project.dtm)
    return nice_resolution(nadir_ground_pixel(geometry)), f"nadir pixel of strip {strip_ids[0]}"


def rectify_project(
    project_path: str | Path | Project,
    variant: str,
    strips: list[str] | None = None,
    options: RectifyOptions = RectifyOptions(),  # noqa: B008 (frozen options)
    workers: int = 1,
    scheduler: str | None = None,
    progress: ProgressCallback = no_progress,
) -> BatchResult:
    """Rectify the strips of a project for one variant; skip strips complete from an earlier run.

    Parameters
    ----------
    project_path : the project folder (or its project.toml).
    variant : the variant whose orientation is used (``DG``: the GPS/IMU as measured).
    strips : strip ids (default: all strips with an image).
    options : rectification settings; ``resolution=None`` means the first strip's nadir pixel (a platform's:
        the finest nadir pixel of its sensors).
    workers : strips rectified at once in local processes.
    scheduler : address of a Dask distributed scheduler to run the strips on instead.
    progress : ``callback(done, total, message)``; in strips (fractional within a strip when one
        worker runs them in this process).
    """
    started = time.perf_counter()
    reuse.clear()  # the strip tasks of this run read the project's files afresh
    project = Project.from_user_input(project_path)
    if strips is None:
        ids = [s.id for s in project.strips if s.image is not None]
    else:
        ids = [project.strip(s).id for s in strips]
    if not ids:
        raise ProjectFileError(f"{project.root / 'project.toml'}: no strip has an image to rectify")
    source = load_orientation(project, variant)
    resolution_source = "options"
    if options.resolution is None:
        resolution, resolution_source = _resolution(project, source, ids)
        options = options.replace(resolution=resolution)
    folder = output_folder(project, variant)
    folder.mkdir(parents=True, exist_ok=True)
    result = BatchResult(folder, resolution=float(options.resolution or 0.0), resolution_source=resolution_source)
    co_file, co_entries = platform.coregistration_entries(project, source)
    tasks = []
    for sid in ids:
        out = folder / f"{sid}.tif"
        co = co_file if sid in co_entries else None
        for product in (out, out.with_name(f"{sid}.layers.tif"), out.with_suffix(".glt"), out.with_suffix(".igm"),
                        layer_path(out)):
            remove_partials(product)  # left by a killed run
        fp = fingerprint(project, source, sid, options, co)
        if co is not None:
            result.coregistration[sid] = {**_co_summary(co_entries[sid]), "path": layer_path(out)}
        if is_complete(out, fp):
            result.strips[sid] = {"strip": sid, "status": "skipped", "path": str(out)}
            log.info("strip %s: %s is complete, skipped", sid, out)
        else:
            tasks.append(StripTask(str(project.root), variant, sid, options, str(out), fp,
                                   coregistration=None if co is None else str(co)))
    total = len(ids)
    done = len(ids) - len(tasks)
    progress(done, total, f"rectify {variant}")
    if scheduler:
        summaries = _run_dask(tasks, scheduler, lambda n: progress(done + n, total, f"rectify {variant}"))
    elif workers > 1 and len(tasks) > 1:
        summaries = _run_pool(tasks, workers, lambda n: progress(done + n, total, f"rectify {variant}"))
    else:
        started_strips = []
        with Finaliser() as finaliser:  # leaving it waits for the last strip's outputs
            for i, task in enumerate(tasks):
                started_strips.append((task.strip, start_strip_task(task, _strip_progress(progress, done + i, total,
                                                                                          task.strip), finaliser)))
        summaries = [{"strip": sid, "status": "done", **r.summary()} for sid, r in started_strips]
    for s in summaries:
        result.strips[s["strip"]] = s
    result.strips = {sid: result.strips[sid] for sid in ids}
    if options.mosaic:
        for sensor, strips in platform.strips_by_sensor(project, ids).items():
            result.mosaics[sensor] = build_mosaic([folder / f"{sid}.tif" for sid in strips],
                                                  folder / platform.mosaic_name(project, sensor), options.geotiff)
        if not platform.several_sensors(project):
            result.mosaic = next(iter(result.mosaics.values()))
    result.stacks = platform.write_flight_line_vrts(project, folder, ids, variant)
    result.seconds = time.perf_counter() - started
    return result


def _co_summary(entry: dict) -> dict:
    """The reference, flight line, median and largest sigma (m) of a co-registration entry."""
    return {k: entry.get(k) for k in ("reference", "flight_line", "median_m", "max_m")}


def _strip_progress(progress: ProgressCallback, before: int, strips: int, strip: str) -> ProgressCallback:
    """The batch's progress within one strip (fractional strips after ``before`` complete ones)."""
    def sub(done: float, total: float, message: str = "") -> None:
        progress(before + (done / total if total else 0), strips, f"strip {strip}: {message}")
    return sub


def _threads_per_worker(workers: int) -> int:
    return max(1, multiprocessing.cpu_count() // max(workers, 1))


def _run_pool(tasks: list[StripTask], workers: int, on_done) -> list[dict]:
    threads = _threads_per_worker(workers)
    tasks = [StripTask(**{**asdict_shallow(t), "threads": threads}) for t in tasks]
    return run_tasks(run_strip_task, tasks, workers=workers, on_done=lambda n, t: on_done(n))


def _run_dask(tasks: list[StripTask], address: str, on_done) -> list[dict]:
    return run_tasks(run_strip_task, tasks, scheduler=address, on_done=lambda n, t: on_done(n),
                     key=lambda t, i: f"rectify-{t.variant}-{t.strip}-{t.fingerprint}")


def asdict_shallow(task: StripTask) -> dict:
    return {f: getattr(task, f) for f in task.__dataclass_fields__}


def grid_of(path: Path) -> OutputGrid:
    """The output grid of an existing orthoimage."""
    with rasterio.open(path) as src:
        t = src.transform
        return OutputGrid(src.crs.to_wkt(), float(t.a), float(t.c), float(t.f), src.width, src.height)
