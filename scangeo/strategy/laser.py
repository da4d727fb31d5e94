"""Laser variants side by side, and the cleaning that sets their blunders aside first.

The laser counterpart of :mod:`scangeo.strategy.comparison` and :mod:`scangeo.strategy.cleaning`,
with the same kind of variant (:class:`~scangeo.adjustment.variants.Variant`, from the project's
variants.toml or the paper's models) and the same places for the results (``PROJECT/results/``):

- :func:`clean_laser`: the most flexible model (a GPS/IMU model per strip, degree 1) adjusted with data
  snooping; the patch observations it removes (one strip's anchors of one patch, with w and MDB) go
  to ``results/cleaning/rejected.csv`` and are left out of every later adjustment;
- :func:`compare_laser`: every variant set up on the same patches (found once, by the ``patches``
  stage or here), adjusted and evaluated (strips corrected in memory); the recommended variant is
  the one with the smallest strip differences on flat cells after the adjustment (the block's relative
  accuracy, measured on thousands of planar cells; the check patches, a handful of surveyed planes,
  are reported beside it).
"""
from __future__ import annotations

import json
import logging
import math
from dataclasses import dataclass, field, replace
from pathlib import Path

from scangeo.adjustment.variants import Variant, laser_variant, laser_variants
from scangeo.atomic import write_csv, write_text
from scangeo.errors import InputFileError, ScangeoError
from scangeo.io.project import Project
from scangeo.lidar.adjust import LaserBlock, build, find_patches, run, tie_patches
from scangeo.lidar.differences import Differences
from scangeo.lidar.evaluation import Evaluation, apply, differences_before, evaluate
from scangeo.lidar.options import LaserOptions
from scangeo.lidar.patches import TiePatch
from scangeo.lidar.result import LaserResult, laser_result
from scangeo.lidar.search import StripFound
from scangeo.lsq.engine import Adjustment
from scangeo.progress import ProgressCallback, no_progress, scaled

log = logging.getLogger(__name__)

CLEANING_DIR = Path("results") / "cleaning"
#: The columns of the comparison table: (heading, function of a LaserResult)
COLUMNS = (
    ("strategy", lambda r: r.options.get("strategy")),
    ("degrees pos/att", lambda r: f"{r.options.get('position_degree')}/{r.options.get('attitude_degree')}"),
    ("unknowns", lambda r: r.accounting.get("unknowns")),
    ("redundancy", lambda r: r.accounting.get("redundancy")),
    ("sigma0", lambda r: r.sigma0),
    ("strip differences, flat, after (cm)", lambda r: _cm(r, "strip_differences_flat_rms_m")),
    ("check patches (cm)", lambda r: _cm(r, "check_patches_rms_m")),
    ("check points on control (cm)", lambda r: _cm(r, "control_check_points_rms_m")),
    ("coefficients not significant", lambda r: f"{sum(not e.significant for e in r.corrections)} of "
                                               f"{len(r.corrections)}"),
    ("tilted planes", lambda r: f"{r.tilts.significant} of {r.tilts.patches}"),
    ("rejected", lambda r: len(r.rejections)),
)


def after_m(result: LaserResult, key: str) -> float | None:
    """An evaluation figure of ``result`` after the adjustment (``key`` of its evaluation, e.g.
    ``strip_differences_flat_rms_m``), metres; None where there is none."""
    ev = (result.evaluation or {}).get(key)
    return None if ev is None or not math.isfinite(ev["after"]) else float(ev["after"])


def _cm(result: LaserResult, key: str) -> float | None:
    m = after_m(result, key)
    return None if m is None else 100.0 * m


def laser_options(project: Project, **overrides) -> LaserOptions:
    """The project's patch search settings (``[adjustment]``), then ``overrides`` (None: keep)."""
    return LaserOptions.from_table(project.adjustment, str(project.file), **overrides)


def ground_file(project: Project) -> Path | None:
    """The project's ``ground.csv`` (control and check patches), if it has one."""
    path = project.root / "ground.csv"
    return path if path.exists() else None


@dataclass
class AdjustedVariant:
    """One laser variant adjusted: the block, the engine's result, the evaluation and the typed result."""

    block: LaserBlock
    adjustment: Adjustment
    evaluation: Evaluation
    result: LaserResult
    #: the strip differences before any correction (``lidar.evaluation.differences_before``), for the next variant
    before: Differences | None = None


def adjust_laser_variant(project: Project, variant: Variant, found: dict[str, StripFound] | None = None,
                         exclude: frozenset[tuple[str, str]] = frozenset(), out: Path | None = None,
                         callback: ProgressCallback = no_progress, ties: list[TiePatch] | None = None,
                         before: Differences | None = None, **overrides) -> AdjustedVariant:
    """Set up, adjust and evaluate one variant; ``out``: the corrected strips written there as LAZ.

    ``found`` : the patches of an earlier search (None: search the strips now).
    ``exclude`` : ``(strip, patch)`` observations left out (:func:`clean_laser`).
    ``ties`` : the tie patches of ``found`` with these settings (``lidar.adjust.tie_patches``; None: found here).
    ``before`` : the strip differences of ``found`` before any correction, with these settings (an earlier
    variant's ``AdjustedVariant.before``; None: computed here).
    ``overrides`` : replace ``[adjustment]`` settings (None: keep).
    """
    options = laser_options(project, **overrides)
    block = build(project, options, variant, ground_file(project), scaled(callback, 0.0, 0.4), found=found,
                  exclude=exclude, ties=ties)
    adjustment = run(block, scaled(callback, 0.4, 0.7))
    after = apply(block, adjustment.parameters.values(), out, scaled(callback, 0.7, 1.0))
    before = before if before is not None else differences_before(block)
    evaluation = evaluate(block, adjustment, after, before)
    return AdjustedVariant(block, adjustment, evaluation, laser_result(block, adjustment, evaluation), before)


# --- cleaning ------------------------------------------------------------------------------------------------

def cleaning_variant() -> Variant:
    """The model of the laser cleaning: per strip, degree 1 in position and attitude, the laser's priors."""
    return laser_variant("cleaning", description="per strip, degree 1 (the cleaning)")


@dataclass
class LaserCleaning:
    """What :func:`clean_laser` set aside: ``rejected`` rows (strip, patch, w, MDB m, round)."""

    rejected: list[dict]
    sigma0_before: float
    sigma0_after: float

    @property
    def exclude(self) -> frozenset[tuple[str, str]]:
        return frozenset((r["strip"], r["patch"]) for r in self.rejected)

    def as_dict(self) -> dict:
        return {"model": cleaning_variant().description, "sigma0_before": self.sigma0_before,
                "sigma0_after": self.sigma0_after, "rejected": len(self.rejected),
                "observations_rejected": self.rejected}


def clean_laser(project: Project, found: dict[str, StripFound],
                callback: ProgressCallback = no_progress) -> LaserCleaning:
    """Adjust the cleaning model with data snooping; its rejections, to be left out of every variant."""
    block = build(project, laser_options(project), cleaning_variant(), ground_file(project),
                  scaled(callback, 0.0, 0.3), found=found)
    adjustment = run(block, scaled(callback, 0.3, 1.0))
    result = laser_result(block, adjustment, None)
    rows = [{"strip": r.group.removeprefix("anchors "), "patch": r.patch, "w": round(r.w, 3),
             "mdb_m": round(r.mdb, 5), "round": r.round} for r in result.rejections if r.group.startswith("anchors ")]
    return LaserCleaning(rows, float(adjustment.sigma0_first), float(result.sigma0))


def write_cleaning(root: Path, cleaning: LaserCleaning) -> list[Path]:
    """``results/cleaning/rejected.csv`` and ``cleaning.json``."""
    folder = root / CLEANING_DIR
    folder.mkdir(parents=True, exist_ok=True)
    csv = write_csv(folder / "rejected.csv", ["strip", "patch", "w", "mdb_m", "round"],
                    [[r["strip"], r["patch"], r["w"], r["mdb_m"], r["round"]] for r in cleaning.rejected])
    js = write_text(folder / "cleaning.json", json.dumps(cleaning.as_dict(), indent=1) + "\n")
    return [csv, js]


def read_cleaning(root: Path) -> frozenset[tuple[str, str]]:
    """The ``(strip, patch)`` observations set aside by the cleaning (none without results/cleaning/)."""
    path = root / CLEANING_DIR / "cleaning.json"
    if not path.exists():
        return frozenset()
    try:
        rows = json.loads(path.read_text(encoding="utf-8"))["observations_rejected"]
        return frozenset((str(r["strip"]), str(r["patch"])) for r in rows)
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise InputFileError(f"{path}: cannot read the cleaning ({exc}); run the clean stage again") from exc


# --- comparison ----------------------------------------------------------------------------------------------

@dataclass
class LaserComparison:
    """The variants' results in the order given, the failed ones' errors, and the recommendation."""

    project: str
    variants_file: str
    results: dict[str, LaserResult]
    errors: dict[str, str] = field(default_factory=dict)
    recommended: str | None = None
    why: str = ""

    def table(self) -> list[dict]:
        return [{"variant": name, **{h: f(r) for h, f in COLUMNS}} for name, r in self.results.items()]

    def as_dict(self) -> dict:
        """``results/comparison.json`` of a laser project."""
        return {"sensor": "laser", "project": self.project, "variants_file": self.variants_file,
                "recommended": self.recommended, "why": self.why, "table": self.table(), "errors": self.errors,
                "variants": {n: r.to_dict() for n, r in self.results.items()}}


def _recommend(results: dict[str, LaserResult]) -> tuple[str | None, str]:
    """The variant with the smallest strip differences on flat cells after the adjustment (the block's
    relative accuracy, measured on every planar cell of the overlaps; without any: the smallest
    check-patch rms)."""
    def figure(r: LaserResult, key: str) -> float:
        v = _cm(r, key)
        return math.inf if v is None else v

    if not results:
        return None, "no variant could be adjusted"
    for key, what in (("strip_differences_flat_rms_m", "the smallest strip differences on flat cells"),
                      ("check_patches_rms_m", "the smallest check-patch rms")):
        values = {n: figure(r, key) for n, r in results.items()}
        if any(math.isfinite(v) for v in values.values()):
            best = min(values, key=lambda n: values[n])
            return best, f"{what} after the adjustment ({values[best]:.2f} cm)"
    return next(iter(results)), "the first variant (no strip differences or check patches to compare)"


def _as_adjusted(variant: Variant, one_mission: bool) -> Variant:
    """What a variant adjusts, without its name and description (in a project of one mission, a model
    per mission is the model of the block)."""
    strategy = "BE" if one_mission and variant.strategy == "ME" else variant.strategy
    return replace(variant, name="", description="", strategy=strategy)


def compare_laser(project: Project | Path | str, variants: dict[str, Variant] | None = None,
                  found: dict[str, StripFound] | None = None, exclude: frozenset[tuple[str, str]] = frozenset(),
                  callback: ProgressCallback = no_progress) -> LaserComparison:
    """Every variant on the same patches, evaluated alike (module docstring).

    ``variants`` : by name (None: the project's variants.toml, else the paper's models).
    ``found`` : the patches of the ``patches`` stage (None: the strips are searched once here).
    ``exclude`` : observations set aside by :func:`clean_laser`.
    """
    project = project if isinstance(project, Project) else Project.load(project)
    path, file_variants = laser_variants(project.root)
    variants = variants if variants is not None else file_variants
    results: dict[str, LaserResult] = {}
    errors: dict[str, str] = {}
    done: dict[Variant, str] = {}
    one_mission = len({s.mission for s in project.strips}) == 1
    ties: list[TiePatch] | None = None
    before: Differences | None = None   # the strips' differences as found: the same for every variant
    n = len(variants)
    for k, (name, variant) in enumerate(variants.items()):
        sub = scaled(callback, k / n, (k + 1) / n)
        same = _as_adjusted(variant, one_mission)
        if same in done and done[same] in results:  # the same adjustment under another name: not repeated
            first = results[done[same]]
            results[name] = replace(first, variant=name, options={**first.options, "strategy": variant.strategy,
                                                                  "description": variant.description},
                                    notes=[*first.notes, f"the same adjustment as variant {done[same]} "
                                                         "(one mission: per mission is for the block)"])
            continue
        done.setdefault(same, name)
        try:
            if found is None:
                found = find_patches(project, laser_options(project), ground_file(project), scaled(sub, 0.0, 0.5))
            if ties is None:  # the same tie patches for every variant (33 CPU s on the montafon block)
                ties = tie_patches(project, laser_options(project), found)
            done_variant = adjust_laser_variant(project, variant, found, exclude, callback=sub, ties=ties,
                                                before=before)
            results[name], before = done_variant.result, done_variant.before
        except InputFileError:
            raise  # a defect of the project's files fails every variant alike
        except ScangeoError as exc:
            log.warning("variant %s failed: %s", name, exc)
            errors[name] = str(exc)
    best, why = _recommend(results)
    callback(1.0, 1.0, "variants compared")
    source = (str(path) if variants is file_variants and path.parent == project.root
              else "the paper's models (scangeo/data/laser_variants.toml)" if variants is file_variants
              else "given")
    return LaserComparison(str(project.root), source, results, errors, best, why)


def write_laser_comparison(root: Path, comparison: LaserComparison) -> list[Path]:
    """``results/comparison.json`` and every variant's ``results/NAME/results.json``."""
    (root / "results").mkdir(parents=True, exist_ok=True)
    out = [write_text(root / "results" / "comparison.json",
                      json.dumps(comparison.as_dict(), indent=1, default=float) + "\n")]
    for name, r in comparison.results.items():
        (root / "results" / name).mkdir(parents=True, exist_ok=True)
        out.append(write_text(root / "results" / name / "results.json",
                              json.dumps(r.to_dict(), indent=1, default=float) + "\n"))
    return out


__all__ = ["AdjustedVariant", "COLUMNS", "LaserCleaning", "LaserComparison", "adjust_laser_variant", "after_m",
           "clean_laser", "cleaning_variant", "compare_laser", "ground_file", "laser_options", "read_cleaning",
           "write_cleaning", "write_laser_comparison"]
