"""``scangeo run PROJECT``: from a project's raw files to the orthoimages and report of the recommended variant.

A thin shell over :func:`scangeo.pipeline.run.run`: one progress bar across the stages, one summary at
the end. Exit codes (docs/run.md): 0 done, 1 a stage failed or an input is wrong (the message names
the stage, the file and what was expected), 2 a wrong command line, 3 another run is writing the
project, 130 interrupted (the next run resumes).
"""
from __future__ import annotations

import argparse
import sys

from scangeo.cli import settings_argument

#: Exit codes of ``scangeo run`` (docs/run.md).
EXIT_DONE, EXIT_FAILED, EXIT_USAGE, EXIT_LOCKED, EXIT_INTERRUPTED = 0, 1, 2, 3, 130
#: The stages, for --from and --until (scangeo.pipeline.stages.NAMES and, of a laser project,
#: scangeo.pipeline.laser.LASER_NAMES; listed here so that --help does not import the pipeline).
STAGE_NAMES = ("check", "match", "clean", "diagnose", "compare", "rectify", "report")
LASER_STAGE_NAMES = ("check", "patches", "clean", "compare", "apply", "report")


def add_parser(subparsers, common) -> None:
    p = subparsers.add_parser(
        "run", parents=[common], help="all stages: check, match, clean, diagnose, compare, rectify, report",
        description="Run the stages on a project in order: check the inputs (as scangeo info), match tie points "
                    "(when points.csv has none, or with --match), clean blunders, diagnose problem strips and breaks, "
                    "compare the strategies, rectify the recommended one (with the mosaic) and write the report. "
                    "A laser project's stages: check, patches, clean, compare, apply (the corrected strips as LAZ) "
                    "and report. A platform of line scanners and a laser: the image stages with patches (the "
                    "laser's) after match, every variant adjusted jointly with the laser's patches, and apply "
                    "(the laser strips corrected) after rectify. "
                    "A rerun does only what changed since the last run; a killed run resumes where it stopped "
                    "(PROJECT/results/run.json, docs/run.md). Settings: PROJECT/run.toml or --config with "
                    "[match], [clean], [compare] and [rectify] tables, as the stage commands read them. Exit codes: "
                    "0 done, 1 a stage failed, 2 usage, 3 the project is locked by another run, 130 interrupted.",
    )
    p.add_argument("project", help="the project folder")
    p.add_argument("--reference", dest="references", nargs="+", default=[], metavar="ORTHO",
                   help="reference orthoimage(s) for control points (the match stage)")
    p.add_argument("--reference-dtm", default=None, metavar="DTM",
                   help="heights of the matched control points (default: the project's DTM)")
    names = tuple(dict.fromkeys(STAGE_NAMES + LASER_STAGE_NAMES))
    p.add_argument("--from", dest="from_stage", choices=names, default=None, metavar="STAGE",
                   help="rerun this stage and every later one (OpenDroneMap's --rerun-from)")
    p.add_argument("--until", choices=names, default=None, metavar="STAGE",
                   help="stop after this stage (OpenDroneMap's --end-with)")
    p.add_argument("--match", action="store_true", help="match tie points even though points.csv has some")
    settings_argument(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    # here, not at the top: start-up cost (see scangeo.cli)
    from scangeo.atomic import OutputLock
    from scangeo.cli import progress_of
    from scangeo.errors import OutputLockedError
    from scangeo.pipeline.run import run as run_pipeline

    try:
        with OutputLock(args.project, "scangeo run"):
            result = run_pipeline(args.project, references=args.references, reference_dtm=args.reference_dtm,
                                  from_stage=args.from_stage, until=args.until, match=args.match,
                                  settings_file=args.config, progress=progress_of(args))
    except OutputLockedError as exc:
        print(f"scangeo run: {exc}", file=sys.stderr)
        return EXIT_LOCKED
    print("\n".join(summary_lines(result)))
    return EXIT_DONE


def _number(x) -> str:
    """A figure of the manifest (a number, or a string such as ``inf``) with two decimals."""
    return f"{x:.2f}" if isinstance(x, int | float) else str(x)


def summary_lines(result) -> list[str]:
    """The end-of-run summary: stages, recommended variant and why, figures, outputs."""
    lines = []
    for o in result.stages:
        detail = f" ({o.seconds:.0f} s; {o.reason})" if o.status == "ran" else (f" ({o.reason})" if o.reason else "")
        lines.append(f"{o.name:9s} {o.status}{detail}")
    names = {o.name for o in result.stages}
    laser = "patches" in names and "diagnose" not in names  # a laser project (a platform's has both)
    lines += laser_summary_lines(result) if laser else []
    clean = result.summary_of("clean") if not laser else {}
    if clean:
        r = clean["rejected"]
        lines.append(f"blunders removed: {r['image']} image measurements, {r['ground']} ground coordinates"
                     + (f" ({len(r['not_separable_points'])} points not separable, removed whole)"
                        if r["not_separable_points"] else "")
                     + f"; sigma0 {_number(clean['sigma0_before'])} -> {_number(clean['sigma0_after'])} "
                     "(results/cleaning/)")
    diagnose = result.summary_of("diagnose")
    if diagnose:
        problems = diagnose.get("problem_strips", {})
        search = diagnose.get("search_problem_strips")
        lines.append("problem strips: " + ("; ".join(
            f"{s} (breaks at lines {', '.join(f'{b:g}' for b in breaks) or 'none'})" for s, breaks in problems.items())
            or "none") + ("" if search is None else
                          f" (the attribution's: the search's own model had {', '.join(search) or 'none'})"))
        lines += [f"  {a['text']}" for a in diagnose.get("attribution", [])]
    compare = result.summary_of("compare") if not laser else {}
    if compare:
        name = compare["recommended"]
        v = compare["variants"].get(name, {})
        rms = v.get("check_rms_px")
        lines.append(f"recommended variant: {name} ({compare['why']})")
        if compare.get("margin"):
            lines.append(f"  margin: {compare['margin']}")
        if compare.get("disagreement"):
            lines.append(f"  THE EVIDENCE DISAGREES: {compare['disagreement']}")
        for other, why in (compare.get("contradicts_checks") or {}).items():
            lines.append(f"  NOTE: {name} is significantly worse at the check points than {other}: {why}")
        if compare.get("independent_check"):
            lines.append(f"  {compare['independent_check']}")
        lines.append(f"  sigma0 {v.get('sigma0') or float('nan'):.3f}; check-point rms "
                     + (f"{rms:.3f} px" if rms is not None else "- (no check points)")
                     + "".join(f"; strip {sid} along {c.get('rms_along_px') or float('nan'):.2f} / across "
                               f"{c.get('rms_across_px') or float('nan'):.2f} px"
                               for sid, c in v.get("strips", {}).items() if c.get("n")))
    if "patches" in names and not laser:  # a platform's laser strips, adjusted with the images
        lines += [f"laser {line}" for line in corrected_lines(result)]
    rectify = result.summary_of("rectify")
    if rectify:
        lines.append(f"orthoimages: {result.root / rectify['folder']} ({len(rectify['orthoimages'])} GeoTIFFs, "
                     "STAC items beside them)")
    report = result.summary_of("report")
    if report:
        lines.append(f"report: {result.root / report['html']}")
    lines.append(f"manifest: {result.manifest} ({result.seconds:.0f} s)")
    return lines


def _cm(figure) -> str:
    """``before -> after`` of an evaluation figure (metres) in cm."""
    if not figure or not all(isinstance(figure.get(k), int | float) and figure[k] == figure[k]  # NaN: none
                             for k in ("before", "after")):
        return "-"
    return f"{100 * figure['before']:.2f} -> {100 * figure['after']:.2f} cm"


def laser_summary_lines(result) -> list[str]:
    """A laser project's figures: cleaning, recommended variant, strip differences, corrected strips."""
    lines = []
    clean = result.summary_of("clean")
    if clean:
        lines.append(f"blunders set aside: {clean['rejected']} patch observations (results/cleaning/)")
    compare = result.summary_of("compare")
    if compare:
        lines.append(f"recommended variant: {compare['recommended']} ({compare['why']})")
    return lines + corrected_lines(result)


def corrected_lines(result) -> list[str]:
    """The apply stage's figures: the laser strip differences before and after, the corrected strips."""
    applied = result.summary_of("apply")
    if not applied:
        return []
    return [f"strip differences {_cm(applied.get('strip_differences_rms_m'))}; on flat cells "
            f"{_cm(applied.get('strip_differences_flat_rms_m'))}; check patches "
            f"{_cm(applied.get('check_patches_rms_m'))}",
            f"corrected strips: {result.root / applied['folder']} ({len(applied['strips'])} LAZ, "
            "STAC items beside them)"]
