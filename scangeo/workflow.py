"""The workflow in one place: what ``import scangeo`` offers (``scangeo.adjust``, ``scangeo.compare`` ...).

Every function is what one ``scangeo`` command does, without the printing: the command line
(``scangeo/cli/``) parses its arguments, calls one of these and prints the result. Each returns a
dataclass. Paths may be strings or :class:`~pathlib.Path`; ``project`` is a project folder (with
``project.toml``). ``progress`` is a ``callback(done, total, message)`` (``scangeo.progress``).
docs/api.md has a worked example.

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
from scangeo.errors import ProjectFileError
from scangeo.io.project import Project
from scangeo.lidar.result import LaserResult
from scangeo.match.options import MatchOptions
from scangeo.match.run import MatchResult, match_project
from scangeo.orientation.file import Orientation, load_orientation
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
from scangeo.strategy.comparison import compare_project
from scangeo.strategy.default_variants import ProblemStrip, write_variants_file
from scangeo.strategy.laser import adjust_laser_variant


@dataclass
class LaserSimulation:
    """A simulated laser block (:func:`simulate_project` with a laser preset): ``summary`` is truth.json."""

    root: Path
    seed: int
    summary: dict


def simulate_project(out: str | Path, preset: str | Path = "small", *, seed: int | None = None,
             overrides: dict | None = None, images: bool = True, dtm: str | None = None,
             texture: str | None = None, overwrite: bool = False,
             progress: ProgressCallback = no_progress) -> SimulatedBlock | LaserSimulation:
    """Simulate a project with known truth from a preset (``quick``, ``small``, ``vienna2000``,
    ``block24``, ``laser`` or a TOML file) into the folder ``out``.

    ``overrides`` : nested preset keys, e.g. ``{"flight": {"lines": 1200}}``; ``images=False`` skips
    the images and the truth orthoimage. A laser preset (one with a ``[laser]`` table) takes only
    ``{"laser": {...}}`` overrides, ``seed`` and ``overwrite`` (the image arguments ``images``, ``dtm`` and
    ``texture`` are errors naming them) and gives a :class:`LaserSimulation`.
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
    return _simulate_block(out, load_preset(preset, overrides), seed=seed, dtm_file=dtm, texture=texture,
                           overwrite=overwrite, progress=progress)


def match_points(project: str | Path, variant: str = "DG", *, references: Sequence[str | Path] = (),
          reference_dtm: str | Path | None = None, reference_dtm_sigma: float | None = None,
          options: MatchOptions | None = None, workers: int = 1, scheduler: str | None = None,
          progress: ProgressCallback = no_progress) -> MatchResult:
    """Measure tie points between overlapping strips (and control and check points against reference
    orthoimages) with the orientation of ``variant``; rewrites the matched rows of points.csv and
    ground.csv (docs/match.md)."""
    if workers < 1:
        raise ProjectFileError(f"match: workers (--workers) must be at least 1, got {workers}")
    return match_project(project, variant, references=references, reference_dtm=reference_dtm,
                         reference_dtm_sigma=reference_dtm_sigma, options=options, workers=workers,
                         scheduler=scheduler, progress=progress)


@dataclass
class Adjustment:
    """One adjusted variant (:func:`adjust`): the full result and the folder its files went to."""

    result: VariantResult
    folder: Path | None

    @property
    def sigma0(self) -> float:
        return float(self.result.adjustment.statistics.sigma0)

    def orientation(self) -> Orientation:
        """The adjusted orientation (what ``orientation.json`` holds)."""
        return self.result.orientation()


def adjust(project: str | Path, variant: str = "SE", *, variants: str | Path | None = None,
           out: str | Path | None = None, write: bool = True,
           progress: ProgressCallback = no_progress) -> Adjustment:
    """Adjust one variant (a name from ``variants`` (default PROJECT/variants.toml) or built in: DG,
    BE, SE) and, with ``write``, write its results to ``out`` (default PROJECT/results/NAME)."""
    result = run_variant(project, variant, variants, progress)
    return Adjustment(result, write_results(result, out) if write else None)


@dataclass
class ComparisonRun:
    """All variants adjusted and compared (:func:`compare`): the tables' files and the report's."""

    comparison: Comparison
    files: list[Path] = field(default_factory=list)
    report: ReportFiles | None = None


def compare(project: str | Path, variants: str | Path | None = None, *, reference: str = "SE",
            names: list[str] | None = None, problem_strip: str | None = None,
            breaks_lines: Sequence[float] | None = None, folds: int = 4, report: bool = False,
            progress: ProgressCallback = no_progress) -> ComparisonRun:
    """Adjust every variant, write each one's results and PROJECT/results/comparison.{md,csv,json};
    with ``report`` also report.html (docs/reports.md)."""
    comparison = compare_project(project, variants, reference=reference, names=names, problem_strip=problem_strip,
                                 breaks_lines=tuple(breaks_lines) if breaks_lines else None, folds=folds,
                                 callback=progress)
    files = write_comparison(comparison)
    return ComparisonRun(comparison, files, write_report(project, callback=progress) if report else None)


@dataclass
class DiagnosisRun:
    """The drift diagnosis (:func:`diagnose`) and the files written (diagnosis.json, .md, variants.toml)."""

    diagnosis: Diagnosis
    files: list[Path] = field(default_factory=list)


def diagnose(project: str | Path, *, dtm_height_points: Sequence[str] = ("*",), max_breaks: int = 4,
             refine: bool = True, variants: bool = True, overwrite: bool = False,
             progress: ProgressCallback = no_progress) -> DiagnosisRun:
    """Find the problem strips and their breaks from an SE adjustment; write PROJECT/results/diagnosis.*
    and, with ``variants``, PROJECT/variants.toml with P and S variants for them (an existing one only
    with ``overwrite``)."""
    if max_breaks < 0:
        raise ProjectFileError(f"diagnose: max_breaks (--max-breaks): expected 0 or more, found {max_breaks}")
    target = Path(project) / "variants.toml"
    if variants and target.exists() and not overwrite:
        raise ProjectFileError(f"{target} exists: replace it (overwrite=True, --overwrite) or write no variants "
                               "(variants=False, --no-variants)")
    d = _diagnose(project, dtm_height_points=tuple(dtm_height_points), options=SelectionOptions(max_breaks=max_breaks),
                  refine=DEFAULT_REFINE if refine else None, callback=progress)
    files = write_diagnosis(d)
    if variants:
        problems = [ProblemStrip(s, d.breaks_of(s), "scangeo diagnose") for s in d.problem_strips]
        files.append(write_variants_file(project, problems))
    return DiagnosisRun(d, files)


def rectify_strips(project: str | Path, variant: str, *, strips: list[str] | None = None,
            options: RectifyOptions | None = None, workers: int = 1, scheduler: str | None = None,
            progress: ProgressCallback = no_progress) -> BatchResult:
    """Rectify the strips (default: all with an image) with the orientation of ``variant`` into
    PROJECT/results/VARIANT/ortho/ (docs/rectify.md); strips complete from an earlier run are skipped."""
    if workers < 1:
        raise ProjectFileError(f"rectify: workers (--workers) must be at least 1, got {workers}")
    return rectify_project(project, variant, strips=strips, options=options or RectifyOptions(), workers=workers,
                           scheduler=scheduler, progress=progress)


def rectify_in_memory(project: str | Path, variant: str, strip: str, options: RectifyOptions | None = None,
                      progress: ProgressCallback = no_progress) -> StripArray:
    """One strip rectified with the orientation of ``variant`` into an array (nothing written)."""
    p = Project.load(project)
    cfg = p.strip(strip)
    if cfg.image is None:
        raise ProjectFileError(f"{p.root / 'project.toml'} [strips id={cfg.id}]: no image to rectify")
    geometry = CoreStripGeometry(load_orientation(p, variant).geometry(cfg.id), p.dtm)
    return rectify_strip_array(geometry, cfg.image, options, progress=progress)


def read_orientation(project: str | Path, variant: str) -> Orientation:
    """The orientation of ``variant`` as adjusted (its ``orientation.json``; DG: the GPS/IMU as measured)."""
    return load_orientation(Project.load(project), variant)


def lidar_adjust(project: str | Path, variant: str = "strip", *, strips: str | Path | None = None,
                 progress: ProgressCallback = no_progress, **options) -> LaserResult:
    """Adjust a laser project's strips with one variant (docs/lidar.md; ``scangeo run`` adjusts them all).

    ``variant`` : a variant of PROJECT/variants.toml or, without it, of the paper's models (``strip``,
    ``mission``, ``block``). ``strips`` : a folder to write the corrected strips to (``ID.laz``).
    ``options`` : replace ``[adjustment]`` (patch search) settings. Ground control: PROJECT/ground.csv.
    """
    loaded = Project.load(project)
    chosen = find_variant(loaded.root, variant, sensor="laser")
    return adjust_laser_variant(loaded, chosen, out=Path(strips) if strips is not None else None,
                                callback=progress, **options).result


__all__ = ["Adjustment", "ComparisonRun", "DiagnosisRun", "LaserResult", "LaserSimulation", "adjust", "compare",
           "diagnose", "lidar_adjust", "match_points", "read_orientation", "rectify_in_memory", "rectify_strips",
           "simulate_project"]
