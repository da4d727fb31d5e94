"""Laser adjustment variants side by side (the paper's Montafon table, like the image comparison).

The patches are found once; every variant (a table of ``[adjustment]`` keys overriding the project's)
is set up on them, adjusted and evaluated (strips corrected in memory, not written). The variants
come from a TOML file, one table per variant::

    [mission]                     # GPS shift and IMU misalignment per mission
    models = "mission"
    position_degree = 0
    attitude_degree = 0

    [strip]                       # per strip, degree 1, under preventive regularisation
    models = "strip"

Without a file, :data:`PAPER_VARIANTS` (these two) are compared. Every key is checked as in
project.toml (:class:`~scangeo.lidar.adjust.LaserOptions`); an unknown key names the file and table.
"""

from __future__ import annotations

import html
import json
from dataclasses import dataclass
from pathlib import Path

from scangeo.atomic import write_text
from scangeo.errors import ProjectFileError
from scangeo.io.toml_config import load_toml
from scangeo.lidar.adjust import LaserOptions, build, run
from scangeo.lidar.evaluation import apply, evaluate
from scangeo.lidar.project import LaserProject
from scangeo.lidar.result import LaserResult
from scangeo.lidar.workflow import laser_result
from scangeo.progress import ProgressCallback, no_progress, scaled

PAPER_VARIANTS: dict[str, dict] = {
    "mission": {"models": "mission", "position_degree": 0, "attitude_degree": 0},
    "strip": {"models": "strip"},
}

#: the columns of the table: (heading, function of a LaserResult)
COLUMNS = (
    ("models", lambda r: r.options.get("models")),
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


def _cm(result: LaserResult, key: str) -> float | None:
    ev = (result.evaluation or {}).get(key)
    return None if ev is None or ev["after"] != ev["after"] else 100.0 * ev["after"]


@dataclass
class LaserComparison:
    """The variants' results in the order given."""

    results: dict[str, LaserResult]

    def table(self) -> list[dict]:
        return [{"variant": name, **{h: f(r) for h, f in COLUMNS}} for name, r in self.results.items()]


def read_variants(path: Path) -> dict[str, dict]:
    """The variant tables of a TOML file (each checked against :class:`LaserOptions`)."""
    data = load_toml(path)
    if not data:
        raise ProjectFileError(f"{path}: no variant table")
    for name, table in data.items():
        if not isinstance(table, dict):
            raise ProjectFileError(f"{path} [{name}]: expected a table of [adjustment] keys")
        LaserOptions.from_table(table, f"{path} [{name}]")
    return data


def compare_laser(
    project_path,
    variants: dict[str, dict] | None = None,
    ground: Path | None = None,
    callback: ProgressCallback = no_progress,
) -> LaserComparison:
    """Every variant on the same patches, evaluated alike."""
    project = LaserProject.load(project_path)
    variants = variants or PAPER_VARIANTS
    where = str(project.root / "project.toml")
    if ground is None and (project.root / "ground.csv").exists():
        ground = project.root / "ground.csv"
    found = None
    results = {}
    n = len(variants)
    for k, (name, table) in enumerate(variants.items()):
        options = LaserOptions.from_table({**project.adjustment, **table}, f"{where} + variant {name}")
        block = build(project, options, ground, scaled(callback, k / n, (k + 0.3) / n), found=found)
        found = block.found
        result = run(block, scaled(callback, (k + 0.3) / n, (k + 0.6) / n))
        values = result.parameters.values()
        evaluation = evaluate(block, result, apply(block, values, None, scaled(callback, (k + 0.6) / n, (k + 1) / n)))
        results[name] = laser_result(block, result, evaluation, name)
    callback(1.0, 1.0, "variants compared")
    return LaserComparison(results)


def write_comparison(out: Path, comparison: LaserComparison) -> None:
    """``comparison.json`` (every variant's results.json) and ``comparison.html`` (the table)."""
    out.mkdir(parents=True, exist_ok=True)
    write_text(out / "comparison.json",
               json.dumps({n: r.to_dict() for n, r in comparison.results.items()}, indent=1, default=float))
    rows = comparison.table()
    heads = ["variant"] + [h for h, _ in COLUMNS]

    def cell(v) -> str:
        return "" if v is None else (f"{v:.3f}" if isinstance(v, float) else html.escape(str(v)))

    body = "".join("<tr>" + "".join(f"<td>{cell(r[h])}</td>" for h in heads) + "</tr>" for r in rows)
    write_text(out / "comparison.html",
               "<!doctype html><html><head><meta charset='utf-8'><title>lidar variants</title></head><body>"
               "<h1>Laser adjustment variants side by side</h1><table border='1' cellpadding='3'><tr>"
               + "".join(f"<th>{html.escape(h)}</th>" for h in heads) + f"</tr>{body}</table></body></html>")
