"""The demo: simulate the reference block, then ``scangeo run`` on it.

:func:`run_demo` is what ``scangeo demo`` does (docs/reports.md, docs/run.md): the ``vienna2000`` preset
(three strips of 7,000 lines, the middle one the problem strip; the reference case of docs/reports.md)
simulated with images into OUT, then :func:`scangeo.pipeline.run.run` on it: the inputs checked, the
blunders cleaned, the problem strips diagnosed, the default variants compared
(``OUT/results/comparison.*``), the strips rectified with the recommended variant's orientation
(``OUT/results/NAME/ortho/``, with the mosaic and STAC items) and the HTML report with the GeoPackage
of residual vectors (``OUT/results/report.html``, ``residuals.gpkg``). The simulated project has tie
points, so the run's match stage is left out.
"""
from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field
from pathlib import Path

from scangeo.adjustment.summary import Comparison
from scangeo.match import match_project
from scangeo.pipeline.run import RunResult, run
from scangeo.progress import ProgressCallback, no_progress, scaled
from scangeo.reports.report import write_report
from scangeo.reports.tables import read_comparison, write_comparison
from scangeo.simulate.block import simulate
from scangeo.simulate.config import load_preset, merge
from scangeo.strategy.comparison import compare_project
from scangeo.truth.matches import matched_points_project

log = logging.getLogger(__name__)

#: Shares of the whole demo per step (measured on 2 cores, docs/reports.md), for one progress bar.
STAGES = {"simulate": (0.0, 0.45), "run": (0.45, 1.0)}


@dataclass
class DemoResult:
    """What the demo made: the project, the run, the comparison and the output files.

    ``best`` is the variant with the lowest check-point rms (the simulation has check points);
    ``recommended`` the one the run chose without them and rectified.
    """

    root: Path
    comparison: Comparison
    best: str | None
    report: Path
    geopackage: Path | None
    ortho: Path | None = None
    seconds: dict[str, float] = field(default_factory=dict)
    matched: Comparison | None = None  # the comparison on matched points (``matched=True``)
    run: RunResult | None = None
    recommended: str | None = None


def run_demo(out="demo", preset: str = "vienna2000", *, seed: int | None = None, rectify: bool = True,
             overwrite: bool = False, overrides: dict | None = None, matched: bool = False,
             callback: ProgressCallback = no_progress) -> DemoResult:
    """Simulate ``preset`` into ``out`` and run every stage on it (module docstring).

    Parameters
    ----------
    out : the project folder to create (refused when it exists and is not empty, unless ``overwrite``).
    preset : a simulation preset (``scangeo simulate --list-presets``) or TOML file.
    seed : overrides the preset's seed.
    rectify : rectify the strips with the recommended variant (needs the images); without, the run
        stops after compare and the report is written on its own.
    overrides : nested preset overrides (``scangeo.simulate.config.load_preset``).
    matched : also measure ties and control with ``scangeo match`` (the truth orthoimage as the
        reference) and compare the same variants on a copy ``OUT/matched`` whose points are only the
        matched ones plus the simulator's check points (docs/match.md).
    callback : progress ``callback(done, total, message)`` over the whole demo.
    """
    root = Path(out)
    seconds: dict[str, float] = {}

    def step(name: str) -> ProgressCallback:
        a, b = STAGES[name]
        return scaled(callback, a, b, 1.0)

    t = time.perf_counter()
    config = load_preset(preset, merge({"output": {"truth_ortho": matched}}, overrides or {}))
    simulate(root, config, seed=seed, overwrite=overwrite, progress=step("simulate"))
    seconds["simulate"] = time.perf_counter() - t

    rectify = rectify and config.output.images
    result = run(root, until=None if rectify else "compare", progress=step("run"))
    seconds.update({o.name: o.seconds for o in result.stages if o.status == "ran"})
    if not rectify:
        t = time.perf_counter()
        write_report(root)
        seconds["report"] = time.perf_counter() - t
    comparison = read_comparison(root / "results")
    on_matched = None
    if matched:
        t = time.perf_counter()
        match_project(root, references=[root / "truth" / "ortho.tif"], workers=2)
        copy = matched_points_project(root, root / "matched")
        on_matched = compare_project(copy)
        write_comparison(on_matched)
        seconds["match"] = time.perf_counter() - t

    ortho = None
    rectified = result.summary_of("rectify")
    if rectified:
        ortho = root / rectified["folder"]
    gpkg = root / "results" / "residuals.gpkg"
    callback(1.0, 1.0, "demo: done")
    return DemoResult(root, comparison, comparison.best, root / "results" / "report.html",
                      gpkg if gpkg.exists() else None, ortho, seconds, on_matched, result, result.recommended)


__all__ = ["DemoResult", "STAGES", "run_demo"]
