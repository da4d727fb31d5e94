"""``scangeo run``: one call from a project's raw files to the outputs and report of the recommended variant.

:func:`run` takes the stages of :mod:`scangeo.pipeline.stages` in order (a laser project's:
:mod:`scangeo.pipeline.laser`, up to the corrected strips). Each stage's inputs are
fingerprinted (:mod:`scangeo.pipeline.fingerprints`); a stage runs when its fingerprint differs from
the one recorded in ``PROJECT/results/run.json`` (:mod:`scangeo.pipeline.manifest`), when it never
finished, when an output it recorded is gone, when a stage whose results it reads ran in this call,
or from ``from_stage`` on. Otherwise it is up to date and only its record is carried over. So a
second run does nothing, an edited ground.csv reruns from clean on, a changed ``[rectify]`` setting
reruns rectify alone, and a killed run resumes at the stage it was in (docs/run.md). The habits
follow OpenDroneMap's staged pipeline: ``--rerun-from`` is ``from_stage``, ``--end-with`` ``until``.
"""
from __future__ import annotations

import datetime
import logging
import time
import tomllib
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from scangeo.errors import ProjectFileError, ScangeoError
from scangeo.io.project import Project
from scangeo.match.options import MatchOptions
from scangeo.pipeline.fingerprints import changes, file_stamps, relative_name, stage_fingerprint
from scangeo.pipeline.laser import LASER_NAMES, LASER_STAGES
from scangeo.pipeline.manifest import Manifest
from scangeo.pipeline.stages import NAMES, STAGES, Context, RunSettings, Stage, tie_points
from scangeo.progress import ProgressCallback, no_progress, scaled
from scangeo.rectify.options import RectifyOptions
from scangeo.version import __version__

log = logging.getLogger(__name__)

#: The settings file a run reads when no other is given (tables [match], [rectify], [compare]).
SETTINGS_FILE = "run.toml"


class StageFailed(ScangeoError):
    """A stage of ``scangeo run`` stopped with an error (``stage`` names it; the cause is chained)."""

    def __init__(self, stage: str, cause: BaseException) -> None:
        super().__init__(f"stage {stage} failed: {cause}")
        self.stage = stage


@dataclass
class StageOutcome:
    """What one stage did in this call: ``ran``, ``up to date`` or ``not run`` (after ``until``, or not needed)."""

    name: str
    status: str
    seconds: float = 0.0
    reason: str = ""
    summary: dict[str, Any] = field(default_factory=dict)


@dataclass
class RunResult:
    """The stages' outcomes, the recommended variant and where the outputs are."""

    root: Path
    stages: list[StageOutcome]
    manifest: Path
    seconds: float = 0.0

    def outcome(self, name: str) -> StageOutcome:
        for s in self.stages:
            if s.name == name:
                return s
        raise KeyError(name)

    @property
    def ran(self) -> list[str]:
        """The stages that did their work in this call, in order."""
        return [s.name for s in self.stages if s.status == "ran"]

    def summary_of(self, name: str) -> dict[str, Any]:
        """The figures of a stage (from this call or the earlier run it is up to date with)."""
        try:
            return self.outcome(name).summary
        except KeyError:
            return {}

    @property
    def recommended(self) -> str | None:
        return self.summary_of("compare").get("recommended")


def read_settings(path: Path | None, references=(), reference_dtm=None, force_match: bool = False) -> RunSettings:
    """The run's settings: the tables ``[match]``, ``[rectify]``, ``[compare]`` of a TOML file (all optional)."""
    tables: dict[str, Any] = {}
    if path is not None:
        try:
            with open(path, "rb") as fh:
                tables = tomllib.load(fh)
        except (OSError, tomllib.TOMLDecodeError) as exc:
            raise ProjectFileError(f"{path}: cannot read the run's settings ({exc})") from exc
        unknown = [k for k in tables if k not in ("match", "rectify", "compare")]
        if unknown:
            raise ProjectFileError(f"{path}: unknown table [{unknown[0]}] (expected [match], [rectify], [compare])")
    rectify = {"mosaic": True, **tables.get("rectify", {})}
    compare = dict(tables.get("compare", {}))
    folds = compare.pop("folds", 4)
    if compare:
        raise ProjectFileError(f"{path} [compare]: unknown key {next(iter(compare))!r} (expected folds)")
    if not isinstance(folds, int) or isinstance(folds, bool) or folds < 0 or folds == 1:
        raise ProjectFileError(f"{path} [compare] folds: expected 0 (none) or an integer of 2 or more, found {folds!r}")
    return RunSettings(
        references=tuple(Path(r) for r in references),
        reference_dtm=Path(reference_dtm) if reference_dtm else None,
        force_match=force_match,
        match=MatchOptions.from_dict(tables.get("match", {}), source=f"{path} [match]" if path else "match options"),
        rectify=RectifyOptions.from_dict(rectify, source=f"{path}" if path else "rectify options"),
        folds=folds,
    )


def _log_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """A library's warning during a run goes to the log (``-v`` shows it), not to the terminal."""
    log.info("%s (%s:%d): %s", category.__name__, Path(filename).name, lineno, message)


def _look_angles(root: Path) -> str | None:
    """The ``[sensor] look_angles`` table of project.toml (a file the sensor model reads), if any."""
    with open(root / "project.toml", "rb") as fh:
        sensor = tomllib.load(fh).get("sensor", {})
    table = sensor.get("look_angles") if isinstance(sensor, dict) else None
    return str(table) if table else None


def stages_of(project: Project) -> tuple[tuple[Stage, ...], tuple[str, ...]]:
    """The stages of a project and their names: an image project's or a laser project's."""
    return (LASER_STAGES, LASER_NAMES) if project.is_laser else (STAGES, NAMES)


def _forward_only(progress: ProgressCallback) -> ProgressCallback:
    """The run's one bar never moves back (a stage's library calls may restart their own counts)."""
    high = 0.0

    def inner(done: float, total: float, message: str = "") -> None:
        nonlocal high
        high = max(high, done / total if total else 0.0)
        progress(high, 1.0, message)

    return inner


def _plan(root: Path, settings: RunSettings, manifest: Manifest, until: str | None,
          stages: tuple[Stage, ...] = STAGES) -> tuple[list[Stage], str]:
    """The stages of this call, and why match is in or out."""
    if stages is not STAGES:
        plan = list(stages)
        return (plan[: [s.name for s in plan].index(until) + 1] if until is not None else plan), ""
    if settings.force_match:
        why = "--match"
    elif manifest.stages.get("match"):
        why = "matched by an earlier run"
    else:
        try:
            why = "points.csv has no tie points" if tie_points(root) == 0 else ""
        except ScangeoError:  # points.csv or ground.csv cannot be read: the check stage says why
            why = ""
    plan = [s for s in STAGES if s.name != "match" or why]
    if until is not None:
        plan = plan[: [s.name for s in plan].index(until) + 1]
    return plan, why


def _check_names(from_stage: str | None, until: str | None, names: tuple[str, ...] = NAMES, kind: str = "") -> None:
    what = f" of a {kind} project" if kind else ""
    for flag, name in (("--from", from_stage), ("--until", until)):
        if name is not None and name not in names:
            raise ProjectFileError(f"{flag} {name}: not a stage{what} (stages: {', '.join(names)})")
    if from_stage and until and names.index(from_stage) > names.index(until):
        raise ProjectFileError(f"--from {from_stage} comes after --until {until} (stages: {', '.join(names)})")


def run(project, *, references=(), reference_dtm=None, from_stage: str | None = None, until: str | None = None,
        match: bool = False, settings_file=None, progress: ProgressCallback = no_progress) -> RunResult:
    """Run the stages on a project; only what changed since the last run is done (module docstring).

    Parameters
    ----------
    project : the project folder (or its project.toml).
    references : reference orthoimages for control points (the match stage; any raster with a CRS).
    reference_dtm : heights of those control points (default: the project's DTM).
    from_stage : rerun this stage and every later one, whatever their fingerprints.
    until : stop after this stage.
    match : run the match stage even though points.csv has tie points.
    settings_file : TOML file with ``[match]``, ``[rectify]``, ``[compare]`` tables (default
        ``PROJECT/run.toml`` when it exists).
    progress : ``callback(done, total, message)`` over the whole run (stages weighted by their usual cost).
    """
    started = time.perf_counter()
    root = Path(project)
    root = root.parent if root.name == "project.toml" else root
    loaded = Project.load(root)
    stages, names = stages_of(loaded)
    _check_names(from_stage, until, names, loaded.kind if loaded.is_laser else "")
    if loaded.is_laser and (references or reference_dtm or match):
        raise ProjectFileError(f"{root / 'project.toml'}: a laser project has no match stage (--reference, "
                               "--reference-dtm and --match are for images)")
    if settings_file is None and (root / SETTINGS_FILE).exists():
        settings_file = root / SETTINGS_FILE
    settings = read_settings(Path(settings_file) if settings_file else None, references, reference_dtm, match)
    manifest = Manifest.load(root)
    previous = dict(manifest.stages)
    plan, match_why = _plan(root, settings, manifest, until, stages)
    if from_stage == "match" and not match_why:
        raise ProjectFileError(f"--from match: {root / 'points.csv'} has tie points; add --match to match again")
    manifest.started = datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds")
    manifest.options = {"from": from_stage, "until": until, "settings_file": str(settings_file or ""),
                        **settings.as_dict()}
    manifest.recommended = None
    ctx = Context(root, loaded, settings, {}, previous, _look_angles(root))
    forced = set(names[names.index(from_stage):]) if from_stage else set()
    progress = _forward_only(progress)
    total, edge = sum(s.weight for s in plan), 0.0
    outcomes: list[StageOutcome] = []
    ran: set[str] = set()
    with warnings.catch_warnings():
        warnings.showwarning = _log_warning
        for stage in plan:
            a, edge = edge, edge + stage.weight / total
            sub = scaled(progress, a, edge, 1.0)
            outcome = _one_stage(stage, ctx, manifest, forced, ran, sub)
            if outcome.status == "ran":
                ran.add(stage.name)
            outcomes.append(outcome)
    for name in names:
        if name not in {o.name for o in outcomes}:
            why = ("tie points in points.csv (--match matches anyway)" if name == "match" and not match_why
                   else f"after --until {until}")
            outcomes.append(StageOutcome(name, "not run", reason=why))
    outcomes.sort(key=lambda o: names.index(o.name))
    manifest.recommended = _recommended(ctx)
    manifest.finished = datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds")
    path = manifest.save()
    progress(1.0, 1.0, "run: done")
    return RunResult(root, outcomes, path, time.perf_counter() - started)


def _one_stage(stage: Stage, ctx: Context, manifest: Manifest, forced: set[str], ran: set[str],
               progress: ProgressCallback) -> StageOutcome:
    """Run one stage if it must (module docstring), recording it in the manifest; else carry its record over."""
    files = file_stamps(stage.files(ctx), ctx.root)
    options = stage.options(ctx)
    after = {n: ctx.records[n]["fingerprint"] for n in stage.after if n in ctx.records}
    fingerprint = stage_fingerprint(stage.name, options, files, after)
    old = manifest.completed(stage.name)
    if stage.name in forced:
        reasons = ["--from"]
    elif ran & set(stage.after):
        reasons = [f"stage {n} ran" for n in stage.after if n in ran]
    elif old is None:
        status = (manifest.stages.get(stage.name) or {}).get("status")
        reasons = [f"the last run stopped in it ({status})" if status else "no earlier run"]
    elif old.get("fingerprint") != fingerprint:
        reasons = changes(old, options, files, after)
    else:
        reasons = [f"{name} is gone" for name in old.get("outputs", []) if not (ctx.root / name).exists()]
    manifest.inputs.update(files)
    if not reasons and old is not None:
        ctx.records[stage.name] = {**old, "status": "up to date"}
        manifest.stages[stage.name] = ctx.records[stage.name]
        progress(1, 1, f"{stage.name}: up to date")
        return StageOutcome(stage.name, "up to date", 0.0, "", old.get("summary", {}))
    reason = "; ".join(reasons)
    log.info("stage %s runs: %s", stage.name, reason)
    record: dict[str, Any] = {"status": "running", "fingerprint": fingerprint, "version": __version__,
                              "files": files, "options": options,
                              "after": after, "reason": reason,
                              "started": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds")}
    manifest.stages[stage.name] = record
    manifest.save()  # the old record is gone before any output changes: a kill from here on reruns the stage
    t = time.perf_counter()
    try:
        summary, outputs = stage.work(ctx, lambda d, n, m="": progress(d, n, m if m.startswith(stage.name)
                                                                        else f"{stage.name}: {m}"))
    except KeyboardInterrupt:
        record["status"] = "interrupted"
        manifest.save()
        raise
    except ScangeoError as exc:
        record.update(status="failed", error=str(exc), seconds=round(time.perf_counter() - t, 2))
        manifest.save()
        raise StageFailed(stage.name, exc) from exc
    record.update(status="ran", seconds=round(time.perf_counter() - t, 2), summary=summary,
                  outputs=sorted({relative_name(p, ctx.root) for p in outputs}))
    ctx.records[stage.name] = record
    manifest.save()  # written last: the stage's outputs are all complete now
    return StageOutcome(stage.name, "ran", record["seconds"], reason, summary)


def _recommended(ctx: Context) -> dict[str, Any] | None:
    """The recommended variant, why, and its figures (the manifest's ``recommended``)."""
    compare = ctx.records.get("compare", {}).get("summary")
    if not compare:
        return None
    name = compare["recommended"]
    out = {"variant": name, "why": compare["why"], **compare["variants"].get(name, {})}
    rectify = ctx.records.get("rectify", {}).get("summary")
    if rectify and rectify.get("variant") == name:
        out["orthoimages"] = rectify["orthoimages"]
        out["stac_items"] = rectify["stac_items"]
    applied = ctx.records.get("apply", {}).get("summary")
    if applied and applied.get("variant") == name:
        out["corrected_strips"] = applied["strips"]
        out["stac_items"] = applied["stac_items"]
    return out


__all__ = ["RunResult", "SETTINGS_FILE", "StageFailed", "StageOutcome", "read_settings", "run"]
