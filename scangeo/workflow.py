"""The workflow in one place: what ``import scangeo`` offers (``scangeo.adjust``, ``scangeo.compare`` ...).

Every function is what one ``scangeo`` command does, without the printing: the command line
(``scangeo/cli/``) parses its arguments, calls one of these and prints the result. Each returns a
dataclass. docs/api.md is the reference (generated from these docstrings) and a worked example.

One meaning per argument name, in every call:

* ``project``: a project folder (with ``project.toml``), its ``project.toml``, or a loaded
  :class:`~scangeo.io.project.Project` (used as it is, not read again);
* ``variant``: the name of an adjustment variant (``variants.toml``'s or a built-in one: DG, BE, SE);
* ``variants_file``: a variants file (default ``PROJECT/variants.toml``);
* ``options``: the settings dataclass of the step (``MatchOptions``, ``CleaningOptions``,
  ``RectifyOptions``), checked when built as a file's keys are checked;
* ``progress``: a ``callback(done, total, message)`` (``scangeo.progress``).

Paths may be strings or :class:`~pathlib.Path`. Outputs go under ``PROJECT/results/``. An argument
that cannot apply raises :class:`~scangeo.errors.ArgumentError`; nothing is silently ignored.

Three verbs carry a noun (``simulate_project``, ``match_points``, ``rectify_strips``) and the
orientation is read with ``read_orientation``: the bare words name scangeo's sub-packages
(``scangeo.simulate``, ``scangeo.match``, ``scangeo.rectify``, ``scangeo.orientation``), and a function
of the same name at the package root would be replaced by the sub-package once it is imported.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from scangeo.adjustment.diagnosis.diagnose import Diagnosis
from scangeo.adjustment.diagnosis.diagnose import diagnose as _diagnose
from scangeo.adjustment.diagnosis.output import write_diagnosis
from scangeo.adjustment.diagnosis.patterns import SelectionOptions
from scangeo.adjustment.diagnosis.refine import DEFAULT_REFINE
from scangeo.adjustment.outputs import write_results
from scangeo.adjustment.results import VariantResult, run_variant
from scangeo.adjustment.summary import Comparison
from scangeo.adjustment.variants import find_variant
from scangeo.errors import ArgumentError, OptionsError, ProjectFileError
from scangeo.io.project import Project
from scangeo.lidar.result import LaserResult
from scangeo.match.options import MatchOptions
from scangeo.match.run import MatchResult, match_project
from scangeo.orientation.file import Orientation, load_orientation
from scangeo.pipeline.settings import CompareSettings, Settings, read_settings
from scangeo.progress import ProgressCallback, no_progress
from scangeo.rectify.batch import BatchResult, rectify_project
from scangeo.rectify.core_geometry import CoreStripGeometry
from scangeo.rectify.options import RectifyOptions
from scangeo.rectify.strip import StripArray, rectify_strip_array
from scangeo.reports.report import ReportFiles, write_report
from scangeo.reports.tables import write_comparison
from scangeo.simulate.block import SimulatedBlock
from scangeo.simulate.block import simulate as _simulate_block
from scangeo.simulate.config import load_preset, merge, preset_path
from scangeo.simulate.laser import is_laser_preset, load_laser_config, simulate_laser
from scangeo.strategy.cleaning import Cleaning, CleaningOptions, clean
from scangeo.strategy.comparison import compare_project
from scangeo.strategy.default_variants import write_diagnosed_variants
from scangeo.strategy.laser import adjust_laser_variant
from scangeo.strategy.platform import joins_a_laser, joint_runner


@dataclass
class LaserSimulation:
    """A simulated laser block (:func:`simulate_project` with a laser preset).

    Parameters
    ----------
    root : Path
        The project folder written.
    seed : int
        The random seed used.
    summary : dict
        What ``truth.json`` holds: the configuration, every strip's true errors, the buildings.
    """

    root: Path
    seed: int
    summary: dict


def simulate_project(out: str | Path, preset: str | Path = "small", *, seed: int | None = None,
                     overrides: dict | None = None, images: bool = True, dtm: str | Path | None = None,
                     texture: str | Path | None = None, overwrite: bool = False,
                     progress: ProgressCallback = no_progress) -> SimulatedBlock | LaserSimulation:
    """Simulate a project with known truth from a preset into the folder ``out`` (docs/simulate.md).

    Parameters
    ----------
    out : str or Path
        The project folder to write (with a ``truth/`` folder of the true orientation and points).
    preset : str or Path
        A shipped preset (``quick``, ``small``, ``vienna2000``, ``block24``, ``laser``, ...) or a TOML
        file of the same keys.
    seed : int, optional
        The random seed (default: the preset's).
    overrides : dict, optional
        Nested preset keys replacing the preset's, e.g. ``{"flight": {"lines": 1200}}``. A laser
        preset (one with a ``[laser]`` table) takes only ``{"laser": {...}}``.
    images : bool
        Render the strip images and the true orthoimage (False: geometry and points only; not for a
        laser preset).
    dtm : str or Path, optional
        A real DTM raster (with a CRS) for the true terrain (not for a laser preset).
    texture : str or Path, optional
        An RGB orthophoto for the scene instead of the procedural land cover (not for a laser preset).
    overwrite : bool
        Replace ``out`` if it exists.
    progress : callable
        ``progress(done, total, message)``.

    Returns
    -------
    SimulatedBlock or LaserSimulation
        The simulated block (also written to ``out``); a :class:`LaserSimulation` for a laser preset.

    Raises
    ------
    ProjectFileError
        An unknown preset, or a preset key that is unknown or out of range (names the file and key); an
        image argument (``images``, ``dtm``, ``texture``) with a laser preset.
    """
    overrides = dict(overrides or {})
    path = preset_path(preset)
    if is_laser_preset(path):
        laser = dict(overrides.pop("laser", {}))
        if overrides:
            raise ProjectFileError(f"a laser preset has only [laser] keys; cannot set {', '.join(overrides)}")
        given = [name for name, value, default in (("images", images, True), ("dtm", dtm, None),
                                                   ("texture", texture, None)) if value != default]
        if given:
            raise ProjectFileError(f"{path}: a laser preset has no images, DTM or texture; cannot use "
                                   f"{', '.join(given)} (laser presets take seed, overwrite and [laser] keys)")
        target = Path(out)
        if target.exists() and any(target.iterdir()) and not overwrite:
            raise ProjectFileError(f"{target}: the folder exists and is not empty (choose another or overwrite it)")
        if seed is not None:
            laser["seed"] = seed
        config = load_laser_config(path, laser)
        return LaserSimulation(target, config.seed, simulate_laser(target, config))
    if not images:
        overrides = merge(overrides, {"output": {"images": False, "truth_ortho": False}})
    return _simulate_block(out, load_preset(preset, overrides), seed=seed,
                           dtm_file=str(dtm) if dtm is not None else None,
                           texture=str(texture) if texture is not None else None,
                           overwrite=overwrite, progress=progress)


def _one_way_to_run(workers: int, scheduler: str | None) -> None:
    """``workers`` local processes or a Dask ``scheduler``: one of the two."""
    if workers < 1:
        raise ArgumentError("{workers}: expected 1 or more", workers=workers)
    if scheduler is not None and workers > 1:
        raise ArgumentError("{workers} and {scheduler}: give one (the scheduler's workers run the tasks)",
                            workers=workers, scheduler=scheduler)


def _needs_references(references: Sequence[str | Path], **given: object) -> None:
    """The heights of control points (``reference_dtm``, its sigma) apply only with reference orthoimages."""
    given = {name: value for name, value in given.items() if value is not None}
    if given and not references:
        raise ArgumentError(" and ".join(f"{{{name}}}" for name in given) + ": the heights of control points, which "
                            "come only with reference orthoimages ({references})", **given, references=[])


def match_points(project: str | Path | Project, variant: str = "DG", *, references: Sequence[str | Path] = (),
                 reference_dtm: str | Path | None = None, reference_dtm_sigma: float | None = None,
                 options: MatchOptions | None = None, workers: int = 1, scheduler: str | None = None,
                 progress: ProgressCallback = no_progress) -> MatchResult:
    """Measure tie points between overlapping strips, and control and check points against reference
    orthoimages (docs/match.md).

    The matched rows of ``points.csv`` and ``ground.csv`` are replaced, other rows kept; the report goes
    to ``PROJECT/results/match_report.json`` and ``match_cells.csv``.

    Parameters
    ----------
    project : str, Path or Project
        The project.
    variant : str
        The orientation that predicts where to look (DG: the GPS/IMU as measured).
    references : sequence of str or Path
        Reference orthoimages (any raster with a CRS) for control and check points; none: tie points only.
    reference_dtm : str or Path, optional
        Heights of the control points (default: the project's DTM).
    reference_dtm_sigma : float, optional
        Accuracy of those heights, metres (default: the project's ``dtm_sigma_m``).
    options : MatchOptions, optional
        Matching settings (default ``MatchOptions()``; a project's ``[match]`` table:
        ``read_settings(project).match``).
    workers : int
        Tasks run at once in local processes.
    scheduler : str, optional
        Address of a Dask distributed scheduler that runs the tasks instead (then ``workers`` stays 1).
    progress : callable
        ``progress(done, total, message)``, in tasks.

    Returns
    -------
    MatchResult
        The files written, the rows matched and the report (what match_report.json holds).

    Raises
    ------
    ArgumentError
        ``workers`` below 1, or both ``workers`` and ``scheduler``; ``reference_dtm`` or
        ``reference_dtm_sigma`` without ``references``.
    ProjectFileError
        No strip has an image; a file of the project is malformed.
    """
    _one_way_to_run(workers, scheduler)
    _needs_references(references, reference_dtm=reference_dtm, reference_dtm_sigma=reference_dtm_sigma)
    return match_project(project, variant, references=references, reference_dtm=reference_dtm,
                         reference_dtm_sigma=reference_dtm_sigma, options=options, workers=workers,
                         scheduler=scheduler, progress=progress)


@dataclass
class AdjustmentRun:
    """One variant adjusted by :func:`adjust`: the full result and the folder its files went to.

    Parameters
    ----------
    result : VariantResult
        The adjustment: unknowns, statistics, residuals, check points, the adjusted orientation.
    folder : Path or None
        ``PROJECT/results/NAME/`` with its files (orientation.json, residuals.csv, report.json ...);
        None when nothing was written.
    """

    result: VariantResult
    folder: Path | None

    @property
    def sigma0(self) -> float:
        """sigma0 a posteriori of the adjustment.

        Returns
        -------
        float
            The standard deviation of unit weight (1: the observations fit as their sigmas say).
        """
        return float(self.result.adjustment.statistics.sigma0)

    def orientation(self) -> Orientation:
        """The adjusted orientation (what ``orientation.json`` holds).

        Returns
        -------
        Orientation
            Every strip's adjusted spline (project frame), mounting and GPS/IMU corrections.
        """
        return self.result.orientation()


def adjust(project: str | Path | Project, variant: str = "SE", *, variants_file: str | Path | None = None,
           write: bool = True, progress: ProgressCallback = no_progress) -> AdjustmentRun:
    """Adjust the project with one variant (docs/adjustment.md) and write its results.

    Parameters
    ----------
    project : str, Path or Project
        The project (project.toml, points.csv, ground.csv).
    variant : str
        The variant: a name of ``variants_file`` or a built-in one (DG, BE, SE).
    variants_file : str or Path, optional
        The variants file (default ``PROJECT/variants.toml``; without one only the built-in variants).
    write : bool
        Write the results to ``PROJECT/results/VARIANT/`` (False: only return them).
    progress : callable
        ``progress(done, total, message)``.

    Returns
    -------
    AdjustmentRun
        The result and the folder written.

    Raises
    ------
    ProjectFileError
        No such variant; a malformed project file or variants file (names the file and key).
    AdjustmentError
        The adjustment cannot be set up or solved.
    """
    result = run_variant(Project.from_user_input(project), variant, variants_file, progress)
    return AdjustmentRun(result, write_results(result) if write else None)


@dataclass
class ComparisonRun:
    """Every variant adjusted and compared by :func:`compare`, and the files written.

    Parameters
    ----------
    comparison : Comparison
        Per variant: sigma0, check-point rms per strip, accounting; the best and the recommended variant.
    files : list of Path
        The tables written: ``PROJECT/results/comparison.{md,csv,json}``.
    report : ReportFiles or None
        The report written (``report.html``, ``residuals.gpkg``); None with ``report=False``.
    """

    comparison: Comparison
    files: list[Path] = field(default_factory=list)
    report: ReportFiles | None = None


def compare(project: str | Path | Project, *, variants_file: str | Path | None = None, reference_variant: str = "SE",
            names: Sequence[str] | None = None, problem_strip: str | None = None,
            breaks_lines: Sequence[float] | None = None, folds: int = CompareSettings().folds,
            report: bool = True, progress: ProgressCallback = no_progress) -> ComparisonRun:
    """Adjust every variant, write each one's results, the comparison tables and the report
    (docs/reports.md).

    Without a variants file, the default variants are written to ``PROJECT/variants.toml`` for the
    problem strip and its breaks: those given, else those the diagnosis finds (:func:`diagnose`).
    On a platform with laser strips beside its image strips, the laser's patches are searched and every
    variant is adjusted jointly with them (:mod:`scangeo.strategy.platform`; BE and ME fail there).

    Parameters
    ----------
    project : str, Path or Project
        The project.
    variants_file : str or Path, optional
        The variants (default ``PROJECT/variants.toml``).
    reference_variant : str
        The variant whose figures are 100 %.
    names : sequence of str, optional
        Run only these variants (default: all, in the file's order).
    problem_strip : str, optional
        For the default variants: the strip with the GPS/IMU problem (default: diagnosed).
    breaks_lines : sequence of float, optional
        For the default variants: the problem strip's break lines (image lines).
    folds : int
        Folds of the cross-validation over the control points that, weighed with the check points,
        recommends a variant; 0: none.
    report : bool
        Also write ``report.html`` and ``residuals.gpkg`` (:func:`report`).
    progress : callable
        ``progress(done, total, message)``.

    Returns
    -------
    ComparisonRun
        The comparison, the tables' files and the report's.

    Raises
    ------
    ArgumentError
        ``folds`` is 1 or negative; ``breaks_lines`` without ``problem_strip``; either with a
        ``variants_file`` (they fill in the default variants only), or with a ``PROJECT/variants.toml``
        that holds other variants.
    ProjectFileError
        A malformed project or variants file.
    """
    if variants_file is not None and (problem_strip is not None or breaks_lines is not None):
        given = {k: v for k, v in (("problem_strip", problem_strip),
                                   ("breaks_lines", list(breaks_lines) if breaks_lines is not None else None))
                 if v is not None}
        raise ArgumentError(" and ".join(f"{{{k}}}" for k in given) + " fill in the default variants; "
                            "{variants_file} gives its own", **given, variants_file=str(variants_file))
    try:
        folds = CompareSettings(folds=folds).folds
    except OptionsError as exc:
        raise ArgumentError("{folds}: " + str(exc).split(": ", 1)[1].replace("{", "{{").replace("}", "}}"),
                            folds=folds) from None
    loaded = Project.from_user_input(project)
    # a platform's laser strips beside its images: every variant adjusted jointly (scangeo.strategy.platform)
    runner = joint_runner(loaded) if joins_a_laser(loaded) else run_variant
    comparison = compare_project(loaded, variants_file, reference=reference_variant,
                                 names=list(names) if names is not None else None, problem_strip=problem_strip,
                                 breaks_lines=tuple(breaks_lines) if breaks_lines else None, folds=folds,
                                 callback=progress, runner=runner)
    files = write_comparison(comparison)
    return ComparisonRun(comparison, files, write_report(loaded, callback=progress) if report else None)


@dataclass
class DiagnosisRun:
    """The drift diagnosis of :func:`diagnose` and the files written.

    Parameters
    ----------
    diagnosis : Diagnosis
        The problem strips, their breaks (image lines) and the fits that chose them.
    files : list of Path
        ``PROJECT/results/diagnosis.{json,md}`` and, when written, ``PROJECT/variants.toml``.
    """

    diagnosis: Diagnosis
    files: list[Path] = field(default_factory=list)


def diagnose(project: str | Path | Project, *, dtm_height_points: Sequence[str] = ("*",),
             max_breaks: int = SelectionOptions().max_breaks, refine: bool = True, write_variants: bool = True,
             overwrite: bool = False, progress: ProgressCallback = no_progress) -> DiagnosisRun:
    """Find the problem strips and their breaks from an SE adjustment (docs/adjustment.md, "Diagnosis").

    Writes ``PROJECT/results/diagnosis.{json,md}`` and, with ``write_variants``, ``PROJECT/variants.toml``
    with P and S variants for the problem strips found.

    Parameters
    ----------
    project : str, Path or Project
        The project.
    dtm_height_points : sequence of str
        Glob patterns of the tie points on open terrain (their DTM misclosures are used).
    max_breaks : int
        Most breaks per strip.
    refine : bool
        Place each break by adjusting the split model around it (False: keep the BIC's break lines).
    write_variants : bool
        Write ``PROJECT/variants.toml`` for the problem strips found.
    overwrite : bool
        Replace an existing ``PROJECT/variants.toml`` (with ``write_variants``).
    progress : callable
        ``progress(done, total, message)``.

    Returns
    -------
    DiagnosisRun
        The diagnosis and the files written.

    Raises
    ------
    ArgumentError
        ``max_breaks`` below 0; ``PROJECT/variants.toml`` exists and neither ``overwrite`` nor
        ``write_variants=False`` says what to do with it; ``overwrite`` without ``write_variants``.
    """
    if max_breaks < 0:
        raise ArgumentError("{max_breaks}: expected 0 or more", max_breaks=max_breaks)
    if overwrite and not write_variants:
        raise ArgumentError("{overwrite} with {write_variants}: nothing to overwrite", overwrite=True,
                            write_variants=False)
    loaded = Project.from_user_input(project)
    target = loaded.root / "variants.toml"
    if write_variants and target.exists() and not overwrite:
        where = str(target).replace("{", "{{").replace("}", "}}")
        raise ArgumentError(where + " exists: replace it ({overwrite}) or write no variants ({write_variants})",
                            overwrite=True, write_variants=False)
    d = _diagnose(loaded, dtm_height_points=tuple(dtm_height_points), options=SelectionOptions(max_breaks=max_breaks),
                  refine=DEFAULT_REFINE if refine else None, callback=progress)
    files = write_diagnosis(d)
    if write_variants:
        files.append(write_diagnosed_variants(loaded.root, d, "scangeo diagnose"))
    return DiagnosisRun(d, files)


def report(project: str | Path | Project, *, geopackage: bool = True,
           progress: ProgressCallback = no_progress) -> ReportFiles:
    """Write the HTML report of a compared project (docs/reports.md): ``PROJECT/results/report.html``.

    Parameters
    ----------
    project : str, Path or Project
        The project, compared before (:func:`compare`: it reads ``PROJECT/results/``).
    geopackage : bool
        Also write the residual vectors as ``PROJECT/results/residuals.gpkg``.
    progress : callable
        ``progress(done, total, message)``.

    Returns
    -------
    ReportFiles
        The files written and the number of figures.

    Raises
    ------
    ScangeoError
        The project was not compared (no ``PROJECT/results/comparison.json``), or a file is malformed.
    """
    return write_report(project, geopackage=geopackage, callback=progress)


def rectify_strips(project: str | Path | Project, variant: str, *, strips: Sequence[str] | None = None,
                   options: RectifyOptions | None = None, workers: int = 1, scheduler: str | None = None,
                   progress: ProgressCallback = no_progress) -> BatchResult:
    """Rectify strips onto the DTM with the orientation of ``variant`` (docs/rectify.md).

    The orthoimages (and the mosaic, layers, IGM and GLT the options ask for) go to
    ``PROJECT/results/VARIANT/ortho/``; a strip complete from an earlier run with the same inputs and
    options is skipped.

    Parameters
    ----------
    project : str, Path or Project
        The project.
    variant : str
        The orientation: an adjusted variant (``PROJECT/results/VARIANT/orientation.json``) or DG.
    strips : sequence of str, optional
        Strip ids (default: every strip with an image).
    options : RectifyOptions, optional
        Rectification settings (default ``RectifyOptions()``; a project's ``[rectify]`` table:
        ``read_settings(project).rectify``).
    workers : int
        Strips rectified at once in local processes.
    scheduler : str, optional
        Address of a Dask distributed scheduler that runs the strips instead (then ``workers`` stays 1).
    progress : callable
        ``progress(done, total, message)``, in strips.

    Returns
    -------
    BatchResult
        Per strip its file and figures (or ``skipped``), the mosaic, the folder.

    Raises
    ------
    ArgumentError
        ``workers`` below 1, or both ``workers`` and ``scheduler``.
    OrientationFileError
        The variant was not adjusted.
    ProjectFileError
        An unknown strip id, or no strip has an image.
    """
    _one_way_to_run(workers, scheduler)
    return rectify_project(project, variant, strips=list(strips) if strips is not None else None,
                           options=options or RectifyOptions(), workers=workers, scheduler=scheduler,
                           progress=progress)


def rectify_in_memory(project: str | Path | Project, variant: str, strip: str, options: RectifyOptions | None = None,
                      progress: ProgressCallback = no_progress) -> StripArray:
    """One strip rectified with the orientation of ``variant`` into an array; nothing is written.

    Parameters
    ----------
    project : str, Path or Project
        The project.
    variant : str
        The orientation: an adjusted variant or DG.
    strip : str
        The strip's id.
    options : RectifyOptions, optional
        Resolution, bounds, resampling, nodata, occlusion and memory budget; the settings of files
        (``mosaic``, ``geotiff``) do not apply, and the extra products (``layers``, ``igm``, ``glt``)
        cannot be asked for.
    progress : callable
        ``progress(done, total, message)``.

    Returns
    -------
    StripArray
        The orthoimage (bands x rows x columns of the image's dtype) and its grid (map CRS).

    Raises
    ------
    ArgumentError
        ``options`` asks for layers, an IGM or a GLT (files only a batch writes: :func:`rectify_strips`).
    ProjectFileError
        The strip has no image, or no such strip.
    """
    if options is not None:
        for name in ("layers", "igm", "glt"):
            if getattr(options, name):
                raise ArgumentError(f"{{{name}}}: rectify_in_memory returns the orthoimage only; "
                                    "rectify_strips writes the extra products", **{name: getattr(options, name)})
    p = Project.from_user_input(project)
    cfg = p.strip(strip)
    if cfg.image is None:
        raise ProjectFileError(f"{p.root / 'project.toml'} [strips id={cfg.id}]: no image to rectify")
    geometry = CoreStripGeometry(load_orientation(p, variant).geometry(cfg.id), p.dtm)
    return rectify_strip_array(geometry, cfg.image, options, progress=progress)


def read_orientation(project: str | Path | Project, variant: str) -> Orientation:
    """The orientation of ``variant``: its ``PROJECT/results/VARIANT/orientation.json`` as adjusted.

    Parameters
    ----------
    project : str, Path or Project
        The project.
    variant : str
        An adjusted variant, or DG (the GPS/IMU as measured, fitted by the spline; nothing is read).

    Returns
    -------
    Orientation
        Every strip's spline (project frame: x, y, z in metres, roll, pitch, heading in radians),
        mounting and GPS/IMU corrections, with the map reference of the project frame.

    Raises
    ------
    OrientationFileError
        The variant was not adjusted, or its file is of another project or schema version.
    """
    return load_orientation(Project.from_user_input(project), variant)


def lidar_adjust(project: str | Path | Project, variant: str = "strip", *,
                 corrected_strips: str | Path | None = None, progress: ProgressCallback = no_progress,
                 **options) -> LaserResult:
    """Adjust a laser project's strips with one variant (docs/lidar.md; ``scangeo run`` adjusts them all).

    Parameters
    ----------
    project : str, Path or Project
        The laser project (project.toml with ``[sensor] kind = "laser"``, strips with LAS files).
    variant : str
        A variant of ``PROJECT/variants.toml`` or, without it, of the paper's models (``strip``,
        ``mission``, ``block``). Ground control: ``PROJECT/ground.csv``.
    corrected_strips : str or Path, optional
        A folder to write the corrected strips to (``ID.laz``); None: none written.
    progress : callable
        ``progress(done, total, message)``.
    **options
        Keys of the project's ``[adjustment]`` table (the patch search) that replace its values.

    Returns
    -------
    LaserResult
        The adjustment: corrections per strip, calibration, statistics.

    Raises
    ------
    ProjectFileError
        A malformed laser project, an unknown variant or option.
    """
    loaded = Project.from_user_input(project)
    chosen = find_variant(loaded.root, variant, sensor="laser")
    return adjust_laser_variant(loaded, chosen, out=Path(corrected_strips) if corrected_strips is not None else None,
                                callback=progress, **options).result


__all__ = ["AdjustmentRun", "Cleaning", "CleaningOptions", "CompareSettings", "ComparisonRun", "DiagnosisRun",
           "LaserResult", "LaserSimulation", "Settings", "adjust", "clean", "compare", "diagnose", "lidar_adjust",
           "match_points", "read_orientation", "read_settings", "rectify_in_memory", "rectify_strips", "report",
           "simulate_project"]
