"""The demo: simulate the reference block, compare every strategy, rectify with the best, write the report.

:func:`run_demo` is what ``scangeo demo`` does (docs/reports.md): the ``vienna2000`` preset (three
strips of 7,000 lines, the middle one the problem strip; the reference case of docs/reports.md) simulated with images
into OUT, the default variants compared (``OUT/results/comparison.*``), the strips rectified with
the best variant's orientation (``OUT/results/BEST/ortho/``), and the HTML report with the
GeoPackage of residual vectors (``OUT/results/report.html``, ``residuals.gpkg``).
"""
from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from scangeo.progress import ProgressCallback, no_progress, scaled

if TYPE_CHECKING:
    from scangeo.adjustment.summary import Comparison

log = logging.getLogger(__name__)

#: Shares of the whole run per stage (measured on 2 cores, docs/reports.md), for one progress bar.
STAGES = {"simulate": (0.0, 0.45), "compare": (0.45, 0.75), "rectify": (0.75, 0.9), "report": (0.9, 1.0)}


@dataclass
class DemoResult:
    """What the demo made: the project, the comparison, the best variant and the output files."""

    root: Path
    comparison: Comparison
    best: str | None
    report: Path
    geopackage: Path | None
    ortho: Path | None = None
    seconds: dict[str, float] = field(default_factory=dict)
    matched: Comparison | None = None  # the comparison on matched points (``matched=True``)


def run_demo(out="demo", preset: str = "vienna2000", *, seed: int | None = None, rectify: bool = True,
             overwrite: bool = False, overrides: dict | None = None, matched: bool = False,
             callback: ProgressCallback = no_progress) -> DemoResult:
    """Simulate ``preset`` into ``out``, compare the default variants, rectify with the best, report.

    Parameters
    ----------
    out : the project folder to create (refused when it exists and is not empty, unless ``overwrite``).
    preset : a simulation preset (``scangeo simulate --list-presets``) or TOML file.
    seed : overrides the preset's seed.
    rectify : rectify the strips with the best variant (needs the images).
    overrides : nested preset overrides (``scangeo.simulate.config.load_preset``).
    matched : also measure ties and control with ``scangeo match`` (the truth orthoimage as the
        reference) and compare the same variants on a copy ``OUT/matched`` whose points are only the
        matched ones plus the simulator's check points (docs/match.md).
    callback : progress ``callback(done, total, message)`` over the whole run.
    """
    from scangeo.reports.report import write_report
    from scangeo.reports.tables import write_comparison
    from scangeo.simulate.block import simulate
    from scangeo.simulate.config import load_preset, merge
    from scangeo.strategy.comparison import compare_project

    root = Path(out)
    seconds: dict[str, float] = {}

    def stage(name: str):
        a, b = STAGES[name]
        return scaled(callback, a, b, 1.0)

    t = time.perf_counter()
    config = load_preset(preset, merge({"output": {"truth_ortho": matched}}, overrides or {}))
    simulate(root, config, seed=seed, overwrite=overwrite, progress=stage("simulate"))
    seconds["simulate"] = time.perf_counter() - t

    t = time.perf_counter()
    comparison = compare_project(root, callback=stage("compare"))
    write_comparison(comparison)
    seconds["compare"] = time.perf_counter() - t
    best = comparison.best
    on_matched = None
    if matched:
        t = time.perf_counter()
        from scangeo.match import match_project
        from scangeo.truth.matches import matched_points_project

        match_project(root, references=[root / "truth" / "ortho.tif"], workers=2)
        copy = matched_points_project(root, root / "matched")
        on_matched = compare_project(copy)
        write_comparison(on_matched)
        seconds["match"] = time.perf_counter() - t

    ortho = None
    if rectify and best is not None and config.output.images:
        t = time.perf_counter()
        from scangeo.rectify.batch import rectify_project

        batch = rectify_project(root, best, workers=1, progress=stage("rectify"))
        ortho = batch.folder
        seconds["rectify"] = time.perf_counter() - t

    t = time.perf_counter()
    files = write_report(root, callback=stage("report"))
    seconds["report"] = time.perf_counter() - t
    callback(1.0, 1.0, "demo: done")
    return DemoResult(root, comparison, best, files.html, files.geopackage, ortho, seconds, on_matched)


__all__ = ["DemoResult", "STAGES", "run_demo"]
