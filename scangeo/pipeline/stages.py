"""The stages of ``scangeo run``, in order: check, match, clean, diagnose, compare, rectify, report.

A :class:`Stage` names the files it reads and the options it depends on (its fingerprint,
:mod:`scangeo.pipeline.fingerprints`), the stages whose results it reads (``after``), and a function
that does the work through the library and returns a summary (JSON-able figures) and its outputs.
What each stage does and what makes it run again: docs/run.md.
"""
from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from scangeo.adjustment.diagnosis.diagnose import diagnose
from scangeo.adjustment.diagnosis.output import write_diagnosis
from scangeo.adjustment.results import run_variant
from scangeo.errors import InputFileError, ProjectFileError
from scangeo.io.points import GroundPoints, ImagePoints
from scangeo.io.project import Project
from scangeo.io.rejected import CLEANING_DIR
from scangeo.io.summary import summarise_project
from scangeo.match import match_project
from scangeo.match.options import MatchOptions
from scangeo.match.run import report_path
from scangeo.pipeline.fingerprints import file_stamps, relative_name
from scangeo.pipeline.settings import Settings
from scangeo.progress import ProgressCallback
from scangeo.rectify.batch import rectify_project
from scangeo.rectify.options import RectifyOptions
from scangeo.reports.report import write_report
from scangeo.reports.stac import write_stac_items
from scangeo.reports.tables import write_comparison
from scangeo.strategy.cleaning import CleaningOptions, clean
from scangeo.strategy.comparison import compare_project
from scangeo.strategy.crossvalidation import VariantRunner
from scangeo.strategy.default_variants import write_diagnosed_variants
from scangeo.textfile import read_text

log = logging.getLogger(__name__)

#: The first line of a ``variants.toml`` the diagnose stage writes: such a file is the run's to
#: rewrite (while nobody edited it); any other variants.toml is the user's and is kept.
VARIANTS_MARKER = "# Written by scangeo run from its diagnosis (results/diagnosis.md); edited, it is kept\n"


@dataclass(frozen=True)
class RunSettings:
    """The settings of a run: ``references``, ``reference_dtm``, ``force_match`` and the project's settings
    file (:class:`~scangeo.pipeline.settings.Settings`: ``[match]``, ``[clean]``, ``[compare]``,
    ``[rectify]``, the same a stage command run alone uses)."""

    references: tuple[Path, ...] = ()
    reference_dtm: Path | None = None
    force_match: bool = False
    stages: Settings = field(default_factory=Settings)

    @property
    def match(self) -> MatchOptions:
        return self.stages.match

    @property
    def clean(self) -> CleaningOptions:
        return self.stages.clean

    @property
    def rectify(self) -> RectifyOptions:
        return self.stages.rectify

    @property
    def folds(self) -> int:
        return self.stages.compare.folds

    def as_dict(self) -> dict[str, Any]:
        return {"references": [str(p) for p in self.references],
                "reference_dtm": str(self.reference_dtm) if self.reference_dtm else None,
                "match": self.force_match, "match_options": asdict(self.match), "clean_options": asdict(self.clean),
                "rectify_options": asdict(self.rectify), "folds": self.folds}


@dataclass
class Context:
    """What the stages of one run share: the project, the settings, the records so far."""

    root: Path
    project: Project
    settings: RunSettings
    records: dict[str, dict[str, Any]]  # the record of every stage done (this run or earlier)
    previous: dict[str, dict[str, Any]] = field(default_factory=dict)  # records found at the start
    look_angles: str | None = None  # a pushbroom's look-angle table ([sensor] look_angles), relative

    def base_files(self) -> list[Path]:
        """What every adjustment reads: project.toml, the DTM (and geoid grid), a pushbroom's look-angle
        table, the trajectories and line-time tables."""
        p = self.project
        files = [self.root / "project.toml", p.dtm_path]
        files += [Path(p.geoid.path)] if p.geoid.path else []
        files += [self.root / self.look_angles] if self.look_angles else []
        for s in p.strips:
            files += [s.trajectory] + ([s.line_times] if s.line_times else [])
        return [Path(f) for f in files]

    def images(self) -> list[Path]:
        return [Path(s.image) for s in self.project.strips if s.image is not None]

    def points_files(self) -> list[Path]:
        return [self.root / "points.csv", self.root / "ground.csv"]


@dataclass(frozen=True)
class Stage:
    """One stage: its inputs (files, options), the stages it reads, and the work."""

    name: str
    weight: float  # its share of the progress bar (measured on vienna2000)
    after: tuple[str, ...]
    files: Callable[[Context], list[Path]]
    options: Callable[[Context], dict[str, Any]]
    work: Callable[[Context, ProgressCallback], tuple[dict[str, Any], list[Path]]]
    doc: str = ""
    #: why the stage cannot run on this project (None: it can), e.g. rectify without an image
    cannot_run: Callable[[Context], str | None] = lambda ctx: None


def no_images(ctx: Context) -> str | None:
    """Why a stage that reads the images cannot run: no strip of the project has one."""
    if ctx.images():
        return None
    return "no strip has an image (project.toml [[strips]] image)"


def no_points(ctx: Context) -> str | None:
    """Why the stages that adjust cannot run: no points.csv (a line imported without GCPs), and no matching
    that would write one."""
    if (ctx.root / "points.csv").exists() or nothing_to_match(ctx) is None:
        return None
    return "no points.csv: no GCPs and no tie points; the orthoimage is a direct georeferencing (DG), unchecked"


def nothing_to_match(ctx: Context) -> str | None:
    """Why matching cannot run: no images, or a single strip and no reference to match it with."""
    if ctx.images() and len(ctx.project.strips) == 1 and not ctx.settings.references:
        return "a single strip and no --reference: no tie points to match, no control to find"
    return no_images(ctx)


# -- check -------------------------------------------------------------------------------------------------

def _check(ctx: Context, progress: ProgressCallback) -> tuple[dict[str, Any], list[Path]]:
    """Every input file read as ``scangeo info`` reads it; any that cannot be read stops the run."""
    progress(0, 1, "check: reading the inputs")
    dtm = ctx.project.dtm_file
    if dtm is not None and not dtm.exists() and ctx.project.sensor.kind != "laser":
        raise InputFileError(f"{ctx.root}: the project has no DTM: project.toml [project] dtm names "
                             f"{relative_name(dtm, ctx.root)}, which does not exist. The line's rays need a DTM "
                             "(over water a plane at the sea surface): put one there, or import the line again "
                             "with its DTM")
    summary = summarise_project(ctx.root)
    problems = [f"DTM: {summary['dtm']['error']}"] if "error" in summary.get("dtm", {}) else []
    problems += [f"strip {s['id']}: {s['error']}" for s in summary["strips"] if "error" in s]
    problems += [f"strip {s['id']}: the trajectory does not cover the strip's lines"
                 for s in summary["strips"] if s.get("covered") is False]
    problems += [summary[k]["error"] for k in ("points", "ground") if "error" in summary.get(k, {})]
    if problems:
        raise InputFileError(f"{ctx.root}: the inputs do not check out: " + "; ".join(problems))
    progress(1, 1, "check: done")
    keep: dict[str, Any] = {k: summary[k] for k in ("crs", "points", "ground") if k in summary}
    keep["strips"] = {s["id"]: s.get("lines") for s in summary["strips"]}
    keep["tie_points"] = tie_points(ctx.root)
    return keep, []


def tie_points(root: Path) -> int:
    """Points of points.csv measured in 2+ strips and absent from ground.csv (0 without points.csv)."""

    if not (root / "points.csv").exists():
        return 0
    pts = ImagePoints.read(root / "points.csv")
    ground = set(GroundPoints.read(root / "ground.csv").point) if (root / "ground.csv").exists() else set()
    strips: dict[str, set] = {}
    for p, s in zip(pts.point, pts.strip):
        strips.setdefault(str(p), set()).add(str(s))
    return sum(1 for p, s in strips.items() if len(s) >= 2 and p not in ground)


# -- match -------------------------------------------------------------------------------------------------

def _match_files(ctx: Context) -> list[Path]:
    s = ctx.settings
    return ctx.base_files() + ctx.images() + list(s.references) + ([s.reference_dtm] if s.reference_dtm else [])


def _match(ctx: Context, progress: ProgressCallback) -> tuple[dict[str, Any], list[Path]]:
    s = ctx.settings
    result = match_project(ctx.root, "DG", references=list(s.references), reference_dtm=s.reference_dtm,
                           options=s.match, workers=1, progress=progress)
    summary = dict(result.report.get("summary", {}))
    return summary, [result.points_file, result.report_file] + ([result.ground_file] if result.ground_rows else [])


# -- clean -------------------------------------------------------------------------------------------------

def _clean(ctx: Context, progress: ProgressCallback) -> tuple[dict[str, Any], list[Path]]:
    cleaning = clean(ctx.root, ctx.settings.clean, progress=progress)
    summary = {k: v for k, v in cleaning.as_dict().items() if k not in ("project", "options")}
    return summary, [ctx.root / CLEANING_DIR / "rejected.csv", ctx.root / CLEANING_DIR / "cleaning.json"]


# -- diagnose ----------------------------------------------------------------------------------------------

def _variants_are_ours(path: Path, previous: dict[str, Any] | None) -> bool:
    """variants.toml may be (re)written: absent, or written by an earlier run and not edited since."""
    if not path.exists():
        return True
    text = read_text(path, "a TOML file", ProjectFileError)
    if not text.startswith(VARIANTS_MARKER):
        return False
    before = (previous or {}).get("summary", {}).get("variants_sha256")
    return before is None or before == file_stamps([path], path.parent)[path.name]["sha256"]


def _diagnose(ctx: Context, progress: ProgressCallback) -> tuple[dict[str, Any], list[Path]]:
    d = diagnose(ctx.root, callback=progress)
    outputs = write_diagnosis(d)
    target = ctx.root / "variants.toml"
    problems = {s: list(d.breaks_of(s)) for s in d.problem_strips}
    if _variants_are_ours(target, ctx.previous.get("diagnose")):
        write_diagnosed_variants(ctx.root, d, "scangeo run: diagnose", header=VARIANTS_MARKER)
        variants = "written from the diagnosis"
    else:
        variants = "kept (not written by scangeo run, or edited since)"
        log.info("%s: kept as it is (yours); the diagnosis is in results/diagnosis.md", target)
    summary = {"problem_strips": problems, "se_sigma0": d.sigma0,
               # the search's own problem strips when an attribution's model replaced its model (else absent)
               **({"search_problem_strips": d.search_problem_strips} if d.search is not None else {}),
               "attribution": [{"strip": c.strip, "ambiguous": c.ambiguous, "text": c.sentence(),
                                "runner_up": None if c.runner_up is None else c.runner_up.as_dict()}
                               for c in d.attribution],
               "other_attributions": {a.label: {s: list(b) for s, b in a.breaks.items()} for a in d.plausible()},
               "notes": list(d.notes), "variants": variants,
               "variants_sha256": file_stamps([target], ctx.root)["variants.toml"]["sha256"]}
    return summary, [*outputs, target]


# -- compare -----------------------------------------------------------------------------------------------

def _compare(ctx: Context, progress: ProgressCallback) -> tuple[dict[str, Any], list[Path]]:
    return compare_variants(ctx, progress, run_variant)


def compare_variants(ctx: Context, progress: ProgressCallback,
                     runner: VariantRunner) -> tuple[dict[str, Any], list[Path]]:
    """The compare stage with ``runner`` adjusting each variant (a platform with a laser: the joint one)."""
    c = compare_project(ctx.root, ctx.root / "variants.toml", folds=ctx.settings.folds, callback=progress,
                        runner=runner)
    outputs = write_comparison(c)
    evidence = (c.crossvalidation or {}).get("evidence") or {}
    if c.recommended:
        chosen, why = c.recommended, ("recommended weighing the cross-validation and the check points: "
                                      f"{(c.crossvalidation or {}).get('reason')}")
    elif c.best:
        chosen, why = c.best, "the lowest check-point rms (the cross-validation recommended none)"
    elif c.reference_summary() is not None:
        chosen, why = c.reference, "the reference (no other variant succeeded)"
    else:
        raise InputFileError(f"{ctx.root}: no variant of {c.variants_file} could be adjusted: "
                             + "; ".join(f"{v.name}: {v.error}" for v in c.variants if v.error))
    variants = {}
    for v in c.variants:
        variants[v.name] = {"error": v.error, "sigma0": v.sigma0, "check_rms_px": v.check_pooled_rms(),
                            "rejected": v.rejected,
                            "strips": {sid: e.get("check", {}) for sid, e in v.strips.items()}}
    summary = {"recommended": chosen, "why": why, "best": c.best, "reference": c.reference, "variants": variants,
               "margin": evidence.get("margin"), "cv_choice": evidence.get("cv_choice"),
               "check_choice": evidence.get("check_choice"), "disagreement": evidence.get("disagreement"),
               "contradicts_checks": evidence.get("contradicts_checks") or {},
               "independent_check": (evidence.get("independent_check") or {}).get("text")}
    return summary, [*outputs, *(ctx.root / "results" / v.name for v in c.variants if v.error is None)]


# -- rectify -----------------------------------------------------------------------------------------------

def _rectify(ctx: Context, progress: ProgressCallback) -> tuple[dict[str, Any], list[Path]]:
    # without points compare cannot run: the GPS/IMU as measured, unchecked
    variant = ctx.records["compare"]["summary"]["recommended"] if "compare" in ctx.records else "DG"
    result = rectify_project(ctx.root, variant, options=ctx.settings.rectify, workers=1, progress=progress)
    rasters = [Path(s["path"]) for s in result.strips.values()] + list(result.mosaics.values())
    spans = {}
    for sid in result.strips:
        first_last = ctx.project.timing(sid).time_of_line(np.array([0.0, ctx.project.n_lines(sid) - 1.0]))
        spans[sid] = [round(float(t), 6) for t in first_last]
    items = write_stac_items(ctx.root, variant, rasters, spans, result.coregistration)
    summary = {"variant": variant, "folder": relative_name(result.folder, ctx.root),
               "orthoimages": [relative_name(p, ctx.root) for p in rasters],
               "stac_items": [relative_name(p, ctx.root) for p in items],
               "strips": {sid: s["status"] for sid, s in result.strips.items()}}
    # a platform's (several sensors): the VRT of each flight line and the co-registration layers
    extra = [*result.stacks.values(), *(Path(c["path"]) for c in result.coregistration.values())]
    if extra:
        summary["stacks"] = {fid: relative_name(p, ctx.root) for fid, p in result.stacks.items()}
        summary["coregistration"] = {sid: relative_name(Path(c["path"]), ctx.root)
                                     for sid, c in result.coregistration.items()}
    return summary, [*rasters, *items, *extra]


# -- report ------------------------------------------------------------------------------------------------

def _report(ctx: Context, progress: ProgressCallback) -> tuple[dict[str, Any], list[Path]]:
    files = write_report(ctx.root, callback=progress)
    outputs = [files.html] + ([files.geopackage] if files.geopackage else [])
    return {"html": relative_name(files.html, ctx.root), "figures": files.figures}, outputs


def _no_options(ctx: Context) -> dict[str, Any]:
    return {}


STAGES: tuple[Stage, ...] = (
    # points.csv and ground.csv are checked but not fingerprinted here: match writes points.csv, and clean,
    # which reads both, reruns when they change
    Stage("check", 0.02, (), lambda c: c.base_files() + c.images(), _no_options, _check,
          "every input file read and checked, as scangeo info"),
    Stage("match", 0.20, (), _match_files,
          lambda c: {"options": asdict(c.settings.match),
                     "references": [relative_name(p, c.root) for p in c.settings.references]},
          _match, "tie points (and control against --reference) from the images", nothing_to_match),
    Stage("clean", 0.15, (), lambda c: c.base_files() + c.points_files(), lambda c: asdict(c.settings.clean), _clean,
          "blunders found by a robust adjustment and set aside for every later adjustment", no_points),
    Stage("diagnose", 0.13, ("clean",), lambda c: c.base_files() + c.points_files(), _no_options, _diagnose,
          "problem strips and breaks from an SE adjustment of the cleaned measurements; variants.toml", no_points),
    Stage("compare", 0.35, ("clean", "diagnose"),
          lambda c: c.base_files() + c.points_files() + [c.root / "variants.toml"],
          lambda c: {"folds": c.settings.folds}, _compare,
          "every variant adjusted, compared, cross-validated; the recommended variant", no_points),
    Stage("rectify", 0.12, ("compare",), lambda c: c.base_files() + c.images(),
          lambda c: asdict(c.settings.rectify), _rectify,
          "orthoimages and mosaic of the recommended variant, with STAC items", no_images),
    Stage("report", 0.03, ("clean", "diagnose", "compare", "rectify"),
          lambda c: c.base_files() + c.points_files() + [report_path(c.root, existing=True)],
          _no_options, _report, "the HTML report (a quicklook of the mosaic) and the residual vectors (GeoPackage)"),
)

NAMES = tuple(s.name for s in STAGES)


def stage(name: str) -> Stage:
    for s in STAGES:
        if s.name == name:
            return s
    raise KeyError(name)


__all__ = ["Context", "NAMES", "RunSettings", "STAGES", "Stage", "VARIANTS_MARKER", "compare_variants", "stage",
           "tie_points"]
