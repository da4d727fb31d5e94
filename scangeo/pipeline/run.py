"""``scangeo run``: one call from a project's raw files to the outputs and report of the recommended variant.

:func:`run` takes the stages of :mod:`scangeo.pipeline.stages` in order (a laser project's:
:mod:`scangeo.pipeline.laser`, up to the corrected strips). Each stage's inputs are
fingerprinted (:mod:`scangeo.pipeline.fingerprints`); a stage runs when its fingerprint differs from
the one recorded in ``PROJECT/results/run.json`` (:mod:`scangeo.pipeline.manifest`), when it never
finished, when an output it recorded is gone, when a stage whose results it reads ran in this call,
or from ``from_stage`` on. Otherwise it is up to date and only its record is carried over. So a
second run does nothing, an edited ground.csv reruns from clean on, a changed ``[rectify]`` setting
reruns rectify and the report, and a killed run resumes at the stage it was in (docs/run.md). The habits
follow OpenDroneMap's staged pipeline: ``--rerun-from`` is ``from_stage``, ``--end-with`` ``until``.
"""
from __future__ import annotations

import datetime
import logging
import time
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from scangeo.errors import ArgumentError, ScangeoError
from scangeo.io.project import Project
from scangeo.io.toml_config import load_toml
from scangeo.pipeline.fingerprints import changes, file_stamps, relative_name, stage_fingerprint
from scangeo.pipeline.laser import LASER_NAMES, LASER_STAGES
from scangeo.pipeline.manifest import Manifest
from scangeo.pipeline.platform import PLATFORM_NAMES, PLATFORM_STAGES
from scangeo.pipeline.settings import SETTINGS_FILE, read_settings
from scangeo.pipeline.settings import settings_file as settings_file_of
from scangeo.pipeline.stages import NAMES, STAGES, Context, RunSettings, Stage, tie_points
from scangeo.progress import ProgressCallback, no_progress, scaled
from scangeo.reports.unchecked import UNCHECKED
from scangeo.strategy.platform import joins_a_laser
from scangeo.version import __version__

log = logging.getLogger(__name__)



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
    """What :func:`run` did: the stages' outcomes, the recommended variant and where the outputs are.

    Parameters
    ----------
    root : Path
        The project folder.
    stages : list of StageOutcome
        Every stage in order: ``ran``, ``up to date`` or ``not run``, why, its figures.
    manifest : Path
        ``PROJECT/results/run.json``.
    seconds : float
        Wall-clock time of the call.
    """

    root: Path
    stages: list[StageOutcome]
    manifest: Path
    seconds: float = 0.0

    def outcome(self, name: str) -> StageOutcome:
        """One stage's outcome.

        Parameters
        ----------
        name : str
            The stage (check, match, clean, diagnose, compare, rectify, report).

        Returns
        -------
        StageOutcome
            Its status, seconds, reason and figures.

        Raises
        ------
        KeyError
            Not a stage.
        """
        for s in self.stages:
            if s.name == name:
                return s
        raise KeyError(name)

    @property
    def ran(self) -> list[str]:
        """The stages that did their work in this call.

        Returns
        -------
        list of str
            Their names, in order.
        """
        return [s.name for s in self.stages if s.status == "ran"]

    def summary_of(self, name: str) -> dict[str, Any]:
        """The figures of a stage, from this call or the earlier run it is up to date with.

        Parameters
        ----------
        name : str
            The stage.

        Returns
        -------
        dict
            Its summary (empty when it has none).
        """
        try:
            return self.outcome(name).summary
        except KeyError:
            return {}

    @property
    def recommended(self) -> str | None:
        """The variant the compare stage recommended.

        Returns
        -------
        str or None
            Its name; None when compare did not run.
        """
        return self.summary_of("compare").get("recommended")


def _log_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """A library's warning during a run goes to the log (``-v`` shows it), not to the terminal."""
    log.info("%s (%s:%d): %s", category.__name__, Path(filename).name, lineno, message)


def _look_angles(root: Path) -> str | None:
    """The ``[sensor] look_angles`` table of project.toml (a file the sensor model reads), if any."""
    sensor = load_toml(root / "project.toml").get("sensor", {})
    table = sensor.get("look_angles") if isinstance(sensor, dict) else None
    return str(table) if table else None


def stages_of(project: Project) -> tuple[tuple[Stage, ...], tuple[str, ...]]:
    """The stages of a project and their names: an image project's, a laser project's, or a platform's of
    line scanners and a laser (:mod:`scangeo.pipeline.platform`)."""
    if project.is_laser:
        return LASER_STAGES, LASER_NAMES
    return (PLATFORM_STAGES, PLATFORM_NAMES) if joins_a_laser(project) else (STAGES, NAMES)


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
    if "match" not in {s.name for s in stages}:
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
    plan = [s for s in stages if s.name != "match" or why]
    if until is not None:
        plan = plan[: [s.name for s in plan].index(until) + 1]
    return plan, why


def _check_names(from_stage: str | None, until: str | None, names: tuple[str, ...] = NAMES, kind: str = "") -> None:
    what = f" of a {kind} project" if kind else ""
    for argument, name in (("from_stage", from_stage), ("until", until)):
        if name is not None and name not in names:
            raise ArgumentError(f"{{{argument}}}: not a stage{what} (stages: {', '.join(names)})", **{argument: name})
    if from_stage and until and names.index(from_stage) > names.index(until):
        raise ArgumentError(f"{{from_stage}} comes after {{until}} (stages: {', '.join(names)})",
                            from_stage=from_stage, until=until)



def run(project: str | Path | Project, *, references: Sequence[str | Path] = (),
        reference_dtm: str | Path | None = None, from_stage: str | None = None, until: str | None = None,
        match: bool = False, settings_file: str | Path | None = None,
        progress: ProgressCallback = no_progress) -> RunResult:
    """Run the stages on a project in order; only what changed since the last run is done (docs/run.md).

    The stages: check, match (when points.csv has no tie points, or with ``match``), clean, diagnose,
    compare, rectify (the recommended variant, with the mosaic) and report; the record of each goes to
    ``PROJECT/results/run.json``, the outputs under ``PROJECT/results/``.

    Parameters
    ----------
    project : str, Path or Project
        The project folder (or its project.toml), or a loaded project.
    references : sequence of str or Path
        Reference orthoimages for control points (the match stage; any raster with a CRS).
    reference_dtm : str or Path, optional
        Heights of those control points (default: the project's DTM).
    from_stage : str, optional
        Run this stage and every later one again, whatever their fingerprints.
    until : str, optional
        Stop after this stage.
    match : bool
        Run the match stage even though points.csv has tie points.
    settings_file : str or Path, optional
        The settings file (tables ``[match]``, ``[clean]``, ``[compare]``, ``[rectify]``; default
        ``PROJECT/run.toml`` when it exists; :mod:`scangeo.pipeline.settings`).
    progress : callable
        ``progress(done, total, message)`` over the whole run (stages weighted by their usual cost).

    Returns
    -------
    RunResult
        Each stage's outcome (ran, up to date, not run) and figures, the recommended variant, the manifest.

    Raises
    ------
    ArgumentError
        ``from_stage`` or ``until`` is not a stage, or ``from_stage`` comes after ``until``;
        ``reference_dtm`` without ``references``; a match argument on a laser project.
    StageFailed
        A stage stopped with an error (chained; the manifest records the stage as failed).
    """
    started = time.perf_counter()
    loaded = Project.from_user_input(project)
    root = loaded.root
    stages, names = stages_of(loaded)
    _check_names(from_stage, until, names, loaded.kind if loaded.is_laser else "")
    images_only = {k: v for k, v in (("references", list(references)), ("reference_dtm", reference_dtm),
                                     ("match", match)) if v}
    if loaded.is_laser and images_only:
        raise ArgumentError(" and ".join(f"{{{k}}}" for k in images_only) + ": for images; a laser project has no "
                            "match stage", **images_only)
    if reference_dtm is not None and not references:
        raise ArgumentError("{reference_dtm}: the heights of control points, which come only with reference "
                            "orthoimages ({references})", reference_dtm=reference_dtm, references=[])
    settings_file = settings_file_of(root, settings_file)
    settings = RunSettings(tuple(Path(r) for r in references), Path(reference_dtm) if reference_dtm else None,
                           match, read_settings(root, settings_file))
    manifest = Manifest.load(root)
    previous = dict(manifest.stages)
    plan, match_why = _plan(root, settings, manifest, until, stages)
    if from_stage == "match" and not match_why:
        where = str(root / "points.csv").replace("{", "{{").replace("}", "}}")
        raise ArgumentError("{from_stage}: " + where + " has tie points; match them again with {match}",
                            from_stage="match", match=True)
    manifest.started = datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds")
    manifest.options = {"from": from_stage, "until": until, "settings_file": str(settings_file or ""),
                        **settings.as_dict()}
    manifest.recommended = None
    ctx = Context(root, loaded, settings, {}, previous, _look_angles(root))
    cannot = {s.name: why for s in plan if (why := s.cannot_run(ctx))}
    for argument, asked in (("from_stage", from_stage), ("until", until)):
        if asked in cannot:
            why = f" stage {asked} cannot run on {root}: {cannot[asked]}".replace("{", "{{").replace("}", "}}")
            raise ArgumentError(f"{{{argument}}}:" + why, **{argument: asked})
    plan = [s for s in plan if s.name not in cannot]
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
            why = (f"cannot run: {cannot[name]}" if name in cannot
                   else "tie points in points.csv (--match matches anyway)" if name == "match" and not match_why
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
    rectify = ctx.records.get("rectify", {}).get("summary")
    if not compare and rectify and "compare" not in ctx.records:  # no points: direct georeferencing, unchecked
        return {"variant": rectify["variant"], "why": UNCHECKED, "checked": False,
                "orthoimages": rectify["orthoimages"]}
    if not compare:
        return None
    name = compare["recommended"]
    out = {"variant": name, "why": compare["why"], **compare["variants"].get(name, {})}
    for key in ("margin", "cv_choice", "check_choice", "disagreement", "contradicts_checks", "independent_check"):
        if compare.get(key):
            out[key] = compare[key]
    if rectify and rectify.get("variant") == name:
        out["orthoimages"] = rectify["orthoimages"]
        out["stac_items"] = rectify["stac_items"]
    applied = ctx.records.get("apply", {}).get("summary")
    if applied and applied.get("variant") == name:  # a laser's strips (a platform's beside its orthoimages)
        out["corrected_strips"] = applied["strips"]
        out["stac_items"] = [*out.get("stac_items", []), *applied["stac_items"]]
    return out


__all__ = ["RunResult", "SETTINGS_FILE", "StageFailed", "StageOutcome", "run"]
