"""The command line's conventions (docs/formats.md, "Command-line conventions"): defaults and choices in
``--help`` come from the library's own options, one meaning per flag name, the same settings in ``scangeo run``
and the stage commands, errors in the command line's words, outputs under PROJECT/results/."""
from __future__ import annotations

import argparse
import dataclasses
import importlib
import inspect
import shutil
from pathlib import Path

import pytest

from scangeo.cli import build_parser, main
from scangeo.pipeline.settings import Settings, read_settings
from scangeo.rectify.options import LAYERS, RectifyOptions
from scangeo.rectify.resample import RESAMPLING
from tests.session_projects import copy_project


def commands() -> dict[str, argparse.ArgumentParser]:
    """Every command's parser (sub-commands as ``lidar budget``)."""
    out = {}

    def walk(parser: argparse.ArgumentParser, prefix: str) -> None:
        for a in parser._actions:
            if isinstance(a, argparse._SubParsersAction):
                for name, sub in a.choices.items():
                    out[f"{prefix} {name}".strip()] = sub
                    walk(sub, f"{prefix} {name}")

    walk(build_parser(), "")
    return out


def library_default(target: str, scale: float = 1.0) -> tuple[object, str]:
    """The default of ``module:Owner.name`` read from the dataclass field, the field of a dataclass instance (an
    example a command starts from) or the call's signature, in the flag's unit (the library's value over
    ``scale``), and how a dataclass field's docs word a default its value does not say (``default_doc``)."""
    module, _, rest = target.partition(":")
    owner_name, _, name = rest.rpartition(".")
    owner = getattr(importlib.import_module(module), owner_name)
    if dataclasses.is_dataclass(owner):
        field = {f.name: f for f in dataclasses.fields(owner)}[name]
        value = field.default if isinstance(owner, type) else getattr(owner, name)
        worded = field.metadata["setting"].default_doc if "setting" in field.metadata else ""
    else:
        value, worded = inspect.signature(owner).parameters[name].default, ""
    if scale != 1.0:
        value = tuple(v / scale for v in value) if isinstance(value, tuple) else value / scale
    return value, worded


def words(value: object) -> str:
    if isinstance(value, bool):
        return "on" if value else "off"
    if isinstance(value, tuple):
        return " ".join(words(v) for v in value) if value else "none"
    return f"{value:g}" if isinstance(value, float) else str(value)


def bound_actions():
    for command, parser in commands().items():
        for a in parser._actions:
            if getattr(a, "option", None):
                yield command, parser, a


def test_help_states_each_default_and_choice_as_the_library_defines_it():
    seen = set()
    for command, parser, action in bound_actions():
        help_text = " ".join(parser.format_help().split())
        value, worded = library_default(action.option, getattr(action, "scale", 1.0))
        assert "default" not in (action.help or ""), f"{command} {action.option_strings}: a default written by hand"
        expected = worded or words(value)
        assert f"(default: {expected}" in help_text, (command, action.option_strings, expected)
        seen.add(command)
    assert {"match", "rectify", "clean", "compare", "diagnose", "adjust", "plan", "report", "simulate", "lidar errors",
            "lidar budget", "lidar network", "lidar forward-reverse", "lidar check-returns"} <= seen
    rectify = " ".join(commands()["rectify"].format_help().split())
    assert "one of: " + ", ".join(LAYERS) in rectify  # all six layers, from the options
    assert "one of: " + ", ".join(RESAMPLING) in rectify
    match = " ".join(commands()["match"].format_help().split())
    assert "tie points per overlap (default: 60)" in match and "(60)" not in match


def test_help_follows_a_changed_default(monkeypatch):
    """The text is read from the options when the help is shown, not copied into the parser."""
    from scangeo.io import schema
    from scangeo.match.options import MatchOptions

    fields = {f.name: f for f in dataclasses.fields(MatchOptions)}
    monkeypatch.setattr(fields["per_overlap"], "default", 75)
    schema._keys.cache_clear()  # the keys of a settings class are read once
    try:
        assert "tie points per overlap (default: 75)" in " ".join(commands()["match"].format_help().split())
    finally:
        monkeypatch.undo()
        schema._keys.cache_clear()


def test_one_meaning_per_flag_name():
    """A flag used by several commands takes the same kind of value into the same argument everywhere."""
    meaning: dict[str, tuple] = {}
    for command, parser in commands().items():
        for a in parser._actions:
            for flag in a.option_strings:
                if flag in ("-h", "--help"):
                    continue
                kind = (a.dest, a.nargs, getattr(a.type, "__name__", a.type), a.metavar, type(a).__name__)
                first = meaning.setdefault(flag, (command, kind))
                assert first[1] == kind, f"{flag}: {first[0]} {first[1]} but {command} {kind}"
    assert meaning["--variants"][1][0] == "variants_file" and meaning["--reference"][1][2] is None
    assert meaning["--strips"][1][1] == "+" and meaning["--strip-count"][1][0] == "n_strips"  # ids; a count
    assert meaning["--config"][1][0] == "config" and meaning["--system"][0] == "lidar check-returns"
    assert "--out" not in meaning  # outputs go under PROJECT/results/


def test_no_flag_takes_centimetres():
    """Lengths and their sigmas in metres on every command line (docs/formats.md, "Units")."""
    import re

    cm = re.compile(r"\bcm\b", re.I)
    found = [(command, a.option_strings) for command, parser in commands().items() for a in parser._actions
             if cm.search(str(a.metavar or "")) or cm.search(a.help or "")]
    assert found == []
    budget = " ".join(commands()["lidar budget"].format_help().split())
    assert "--sigma-noise M sigma of the noise component (default: 0.03 m)" in budget


def test_run_and_the_stage_commands_read_the_same_settings(tmp_path):
    parser = build_parser()

    def options(*argv):
        args = parser.parse_args(list(argv))
        module = importlib.import_module(f"scangeo.cli.{args.command}")
        return module.options_of(args)

    root = tmp_path / "p"
    root.mkdir()
    assert options("rectify", str(root), "--variant", "SE") == Settings().rectify == RectifyOptions()
    assert Settings().rectify.mosaic  # the mosaic is on in a run and in scangeo rectify alike
    assert options("match", str(root)) == Settings().match
    (root / "run.toml").write_text('[rectify]\nmosaic = false\nresampling = "cubic"\n[match]\nper_overlap = 80\n'
                                   "[clean]\npiece_lines = 500\n[compare]\nfolds = 0\n", encoding="utf-8")
    run = read_settings(root)  # what scangeo run reads
    assert options("rectify", str(root), "--variant", "SE") == run.rectify and not run.rectify.mosaic
    assert options("match", str(root)) == run.match and run.match.per_overlap == 80
    assert options("rectify", str(root), "--variant", "SE", "--mosaic", "--resampling", "nearest") == \
        run.rectify.replace(mosaic=True, resampling="nearest")
    other = tmp_path / "other.toml"
    other.write_text("[rectify]\nigm = true\n", encoding="utf-8")
    assert options("rectify", str(root), "--variant", "SE", "--config", str(other)) == RectifyOptions(igm=True)


def test_errors_name_the_flag_not_the_python_argument(small_block, tmp_path, capsys):
    root = tmp_path / "p"
    root.mkdir()
    assert main(["rectify", str(root), "--variant", "DG", "--max-error", "0", "--no-progress"]) == 1
    assert "--max-error 0: expected a number > 0 (px), found 0.0" in capsys.readouterr().err
    assert main(["rectify", str(root), "--variant", "DG", "--layers", "slope", "--no-progress"]) == 1
    assert "--layers slope: expected a list of strings (one of scan_angle" in capsys.readouterr().err
    (root / "run.toml").write_text("[rectify]\nmax_error_px = -1\n", encoding="utf-8")
    assert main(["rectify", str(root), "--variant", "DG", "--no-progress"]) == 1
    assert "run.toml [rectify.max_error_px]: expected a number > 0 (px), found -1" in capsys.readouterr().err
    project = copy_project(small_block, tmp_path / "small")
    assert main(["run", str(project), "--from", "report", "--until", "check", "--no-progress"]) == 1
    assert "--from report comes after --until check" in capsys.readouterr().err
    assert main(["rectify", str(project), "--variant", "DG", "--workers", "0", "--no-progress"]) == 1
    assert "--workers 0: expected 1 or more" in capsys.readouterr().err


def test_library_errors_name_the_python_argument(small_block):
    import scangeo
    from scangeo.errors import ArgumentError

    with pytest.raises(ArgumentError, match=r"^workers=0: expected 1 or more$"):
        scangeo.rectify_strips(small_block, "DG", workers=0)
    with pytest.raises(ArgumentError, match=r"^workers=2 and scheduler='tcp://x:8786': give one"):
        scangeo.match_points(small_block, workers=2, scheduler="tcp://x:8786")
    with pytest.raises(ArgumentError, match=r"^folds=1: expected 0 \(none\) or 2 or more, found 1$"):
        scangeo.compare(small_block, folds=1)
    with pytest.raises(ArgumentError, match=r"^from_stage='report' comes after until='check'"):
        scangeo.run(small_block, from_stage="report", until="check")
    with pytest.raises(ArgumentError, match=r"^igm=True: rectify_in_memory returns the orthoimage only"):
        scangeo.rectify_in_memory(small_block, "DG", "01", RectifyOptions(igm=True))


def test_no_library_error_names_a_flag():
    """Library code words its errors for Python; the command line (scangeo/cli/) says which flag."""
    import ast
    import re

    package = Path(importlib.import_module("scangeo").__file__).parent
    flag = re.compile(r"(?<![\w-])--[a-z][a-z-]+")
    found = []
    for path in package.rglob("*.py"):
        rel = path.relative_to(package).as_posix()
        if rel.startswith("cli/"):
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Raise) and node.exc is not None:
                text = " ".join(c.value for c in ast.walk(node.exc) if isinstance(c, ast.Constant)
                                and isinstance(c.value, str))
                if flag.search(text):
                    found.append(f"{rel}:{node.lineno}: {flag.search(text).group()}")
    assert found == []


def test_every_output_goes_under_results(textured_block, tmp_path):
    """Each command that works on a project writes under PROJECT/results/; outside it only the inputs it is
    documented to rewrite (match: points.csv, ground.csv; diagnose and compare: variants.toml)."""
    root = copy_project(textured_block, tmp_path / "p", truth=False)
    shutil.rmtree(root / "results", ignore_errors=True)
    allowed = {"points.csv", "ground.csv", "variants.toml", ".scangeo.lock"}

    def outside() -> dict[str, float]:
        return {p.relative_to(root).as_posix(): p.stat().st_mtime_ns for p in root.rglob("*")
                if p.is_file() and "results" not in p.relative_to(root).parts}

    steps = [["match"], ["clean"], ["diagnose", "--no-refine"], ["adjust", "--variant", "SE"],
             ["compare", "--only", "DG", "SE", "--folds", "0"], ["report", "--no-geopackage"],
             ["rectify", "--variant", "SE", "--strips", "01", "--resolution", "8"],
             ["plan", "--variant", "SE", "--tie-spacing", "400"]]
    for step in steps:
        before = outside()
        assert main([step[0], str(root), *step[1:], "--no-progress"]) == 0, step
        after = outside()
        changed = {k for k in after if before.get(k) != after[k]}
        assert changed <= allowed, (step[0], changed - allowed)
    results = root / "results"
    for path in ("match_report.json", "match_cells.csv", "cleaning/rejected.csv", "diagnosis.json",
                 "SE/orientation.json", "comparison.json", "report.html", "SE/ortho/01.tif", "SE/ortho/mosaic.tif",
                 "plan_SE/plan.html"):
        assert (results / path).exists(), path


def test_a_match_report_where_an_older_scangeo_wrote_it_is_still_read(tmp_path):
    """Users' projects matched before the report went under results/ keep their control part on a rerun."""
    from scangeo.match.run import report_path

    new = tmp_path / "results" / "match_report.json"
    assert report_path(tmp_path) == new and report_path(tmp_path, existing=True) == new
    (tmp_path / "match_report.json").write_text("{}", encoding="utf-8")
    assert report_path(tmp_path, existing=True) == tmp_path / "match_report.json" and report_path(tmp_path) == new
    new.parent.mkdir()
    new.write_text("{}", encoding="utf-8")
    assert report_path(tmp_path, existing=True) == new


def test_an_argument_that_cannot_apply_is_an_error(small_block, tmp_path, capsys):
    import scangeo
    from scangeo.errors import ArgumentError

    with pytest.raises(ArgumentError, match=r"^reference_dtm='d.tif': the heights of control points, which come "
                                            r"only with reference orthoimages \(references=\[\]\)$"):
        scangeo.match_points(small_block, reference_dtm="d.tif")
    with pytest.raises(ArgumentError, match=r"^problem_strip='02' fill in the default variants; "
                                            r"variants_file='v.toml' gives its own$"):
        scangeo.compare(small_block, variants_file="v.toml", problem_strip="02")
    with pytest.raises(ArgumentError, match=r"^overwrite=True with write_variants=False: nothing to overwrite$"):
        scangeo.diagnose(small_block, overwrite=True, write_variants=False)
    project = copy_project(small_block, tmp_path / "p")
    assert main(["run", str(project), "--reference-dtm", "d.tif", "--no-progress"]) == 1
    assert ("--reference-dtm d.tif: the heights of control points, which come only with reference orthoimages "
            "(--reference)") in capsys.readouterr().err
    assert main(["diagnose", str(project), "--overwrite", "--no-write-variants", "--no-progress"]) == 1
    assert "--overwrite with --no-write-variants: nothing to overwrite" in capsys.readouterr().err
