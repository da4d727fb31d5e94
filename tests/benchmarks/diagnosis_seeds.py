"""Acceptance figures per seed: the diagnosis and the recommendation on vienna2000 (docs/adjustment.md).

Not collected by pytest. For every seed: simulate vienna2000 (``--factor`` of its length, every line-based
key scaled as in tests/strategy/test_physics.py; 1 = the preset as it is) without images, run ``compare``
without a variants file (the diagnosis finds the problem strips and breaks; 2-fold cross-validation
recommends a variant; results/comparison.* written as ``scangeo compare`` does), and print one row: the
problem strips found, every injected break with the nearest
found one (and the BIC's line before the S model placed it), the recommended variant's pooled true error
against the best variant's, and the good strips' worst P/S change against SE. Then, with ``--quiet N``,
N seeds of a block without a problem strip (the ``small`` preset with three strips): breaks proposed.

    python tests/benchmarks/diagnosis_seeds.py OUT [--factor 0.5] [--seeds 1 2 3 4 5] [--quiet 5] [--table]
    python tests/benchmarks/diagnosis_seeds.py OUT --factor 1 --ties 240 --diagnose-only

``--ties N`` simulates N tie points per overlap instead of the preset's 60; ``--diagnose-only`` runs the
diagnosis alone (no compare, no recommendation) and prints every break found with its offset and F test.

and the figures of the paper's Table 2 over the seeds (``--table``: only those, from the comparisons in OUT).

With blunders among the measurements and the cleaning stage first, and the 95 % intervals'
coverage summed over the seeds: tests/benchmarks/cleaning_seeds.py.

Projects already simulated in OUT are reused (delete OUT to start again). Truth is read here only to
score what ``compare`` found.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "strategy"))
from test_physics import CORRECTED, pooled_true, reduced_overrides  # noqa: E402

from scangeo.adjustment.diagnosis.diagnose import diagnose  # noqa: E402
from scangeo.adjustment.summary import Comparison  # noqa: E402
from scangeo.reports.tables import write_comparison  # noqa: E402
from scangeo.simulate.block import simulate  # noqa: E402
from scangeo.simulate.config import load_preset  # noqa: E402
from scangeo.strategy.comparison import compare_project  # noqa: E402


def simulate_vienna(root: Path, seed: int, factor: float, ties: int | None) -> None:
    if not (root / "project.toml").exists():
        over: dict = {"output": {"images": False, "truth_ortho": False}, "seed": seed}
        if factor != 1.0:
            over.update(reduced_overrides("vienna2000", factor))
        if ties is not None:
            over.setdefault("points", {})["tie_per_overlap"] = ties
        simulate(root, load_preset("vienna2000", over))


def diagnosis_row(root: Path, seed: int, factor: float, ties: int | None) -> str:
    simulate_vienna(root, seed, factor, ties)
    t0 = time.perf_counter()
    d = diagnose(root)
    seconds = time.perf_counter() - t0
    truth = json.loads((root / "truth" / "errors.json").read_text())
    injected = truth["breaks_lines"]
    found = ", ".join(f"{b.strip}@{b.line:.0f} ({b.line - min(injected, key=lambda x: abs(x - b.line)):+.0f}; "
                      f"95 % {b.low:.0f}-{b.high:.0f}; BIC {b.bic_line if b.bic_line is not None else b.line:.0f}; "
                      f"F {b.f_statistic if b.f_statistic is not None else float('nan'):.2f})" for b in d.breaks)
    strips = ", ".join(d.problem_strips) or "–"
    return f"| {seed} | {strips} ({truth['problem_strip']}) | {found or '–'} | {seconds:.0f} s |"


def vienna_row(root: Path, seed: int, factor: float, ties: int | None = None) -> str:
    simulate_vienna(root, seed, factor, ties)
    t0 = time.perf_counter()
    c = compare_project(root, folds=2)
    seconds = time.perf_counter() - t0
    write_comparison(c)  # results/comparison.{md,csv,json}, as `scangeo compare` writes them
    truth = json.loads((root / "truth" / "errors.json").read_text())
    d = json.loads((root / "results" / "diagnosis.json").read_text())
    problem = str(truth["problem_strip"])
    found = [b for b in d["breaks"] if b["strip"] == problem]
    breaks = []
    for line in truth["breaks_lines"]:
        b = min(found, key=lambda b: abs(b["line"] - line)) if found else None
        breaks.append("–" if b is None else f"{line:.0f}: {b['line']:.0f} ({b['line'] - line:+.0f}; "
                      f"95 % {b['low']:.0f}-{b['high']:.0f}; BIC {b['bic_line'] or b['line']:.0f})")
    adjusted = [v for v in c.variants if v.strategy != "DG" and v.error is None]
    best = min(adjusted, key=pooled_true)
    rec = c.variant(c.recommended) if c.recommended else None
    good = [s for s in c.strips if s != problem]
    worst = max(((v.name, s, k, v.strips[s][w][f"rms_{k}_px"] - c.variant("SE").strips[s][w][f"rms_{k}_px"], w)
                 for v in adjusted if v.name in CORRECTED for s in good for k in ("along", "across")
                 for w in ("check", "true")), key=lambda x: x[3])
    rec_text = "–" if rec is None else (f"{rec.name} {pooled_true(rec):.3f} px = "
                                        f"{100 * pooled_true(rec) / pooled_true(best):.0f} % of {best.name}'s")
    return (f"| {seed} | {', '.join(d['problem_strips']) or '–'} ({problem}) | {len(found)} | {' / '.join(breaks)} | "
            f"{rec_text} | {worst[0]} {worst[1]} {worst[2]} {worst[4]} {worst[3]:+.3f} px | {seconds:.0f} s |")


def _span(values, fmt="{:.0f}") -> str:
    values = [v for v in values if v is not None]
    return "–" if not values else (fmt.format(min(values)) + "-" + fmt.format(max(values)))


def table2(roots: list[Path]) -> str:
    """The figures of the paper's Table 2 over the seeds' results/comparison.json (ranges over the seeds)."""
    cs = [Comparison.from_dict(json.loads((r / "results" / "comparison.json").read_text())) for r in roots]
    problems = [str(json.loads((r / "truth" / "errors.json").read_text())["problem_strip"]) for r in roots]
    rows = []
    rows.append(("problem strip across, P2/P4/S2/S4 % of SE", " / ".join(
        _span([c.check_percent(c.variant(n), p, "across") for c, p in zip(cs, problems)]) for n in CORRECTED) + " %"))
    good = [(c.check_percent(c.variant(n), s, k), n, s, k, r.name) for r, c, p in zip(roots, cs, problems)
            for n in CORRECTED for s in c.strips if s != p for k in ("along", "across")]
    worst = max(good)
    rows.append(("good strips, P/S % of SE (along and across)",
                 f"{_span([g[0] for g in good])} % (worst: {worst[1]} strip {worst[2]} {worst[3]}, {worst[4]})"))
    for label, names in (("P", ("P2", "P4")), ("S", ("S2", "S4"))):
        rows.append((f"sigma0 {label} % SE (paper: other observations)",
                     _span([c.sigma0_percent(c.variant(n)) for c in cs for n in names]) + " %"))
        rows.append((f"sigma0 {label} % SE_DTM (same observations)",
                     _span([c.sigma0_identical_percent(c.variant(n)) for c in cs for n in names]) + " %"))
    for label, names in (("SE", ("SE",)), ("P", ("P2", "P4")), ("S", ("S2", "S4"))):
        rows.append((f"true error across, problem strip, {label} (px)", _span(
            [c.variant(n).strips[p]["true"]["rms_across_px"] for c, p in zip(cs, problems) for n in names], "{:.2f}")))
        rows.append((f"true error pooled over strips, {label} (px)",
                     _span([pooled_true(c.variant(n)) for c in cs for n in names], "{:.2f}")))
    return "| figure | scangeo |\n|---|---|\n" + "\n".join(f"| {a} | {b} |" for a, b in rows)


def quiet_row(root: Path, seed: int) -> str:
    if not (root / "project.toml").exists():
        simulate(root, load_preset("small", {"output": {"images": False, "truth_ortho": False}, "seed": seed,
                                             "flight": {"strips": 3}, "points": {"tie_per_overlap": 40}}))
    d = diagnose(root)
    return f"| {seed} | {', '.join(d.problem_strips) or 'none'} | {len(d.breaks)} |"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("--factor", type=float, default=0.5)
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4, 5])
    ap.add_argument("--quiet", type=int, default=5, help="seeds of the block without a problem strip")
    ap.add_argument("--table", action="store_true",
                    help="only print the paper's Table 2 figures over the seeds already compared in OUT")
    ap.add_argument("--ties", type=int, default=None, help="tie points per overlap (default: the preset's)")
    ap.add_argument("--diagnose-only", action="store_true", help="the diagnosis alone, no compare")
    a = ap.parse_args()
    tag = f"vienna_{a.factor:g}" + (f"_t{a.ties}" if a.ties is not None else "")
    roots = [a.out / f"{tag}_s{seed}" for seed in a.seeds]
    if a.table:
        print(table2(roots))
        return
    if a.diagnose_only:
        ties = a.ties if a.ties is not None else "the preset's"
        print(f"vienna2000 at {a.factor:g} of its length, {ties} tie points per overlap:\n")
        print("| seed | problem strips found (injected) | breaks: line (offset; 95 %; BIC; F) | diagnosis |")
        print("|---|---|---|---|")
        for seed, root in zip(a.seeds, roots):
            print(diagnosis_row(root, seed, a.factor, a.ties), flush=True)
        return
    print(f"vienna2000 at {a.factor:g} of its length:\n")
    print("| seed | problem strips found (injected) | breaks found | injected: found (offset; 95 %; BIC) | "
          "recommended: pooled true error | worst good-strip change P/S vs SE | compare |")
    print("|---|---|---|---|---|---|---|")
    for seed, root in zip(a.seeds, roots):
        print(vienna_row(root, seed, a.factor, a.ties), flush=True)
    print("\n" + table2(roots))
    if a.quiet:
        print("\nsmall, 3 strips, no problem strip:\n\n| seed | problem strips | breaks |\n|---|---|---|")
        for seed in range(1, a.quiet + 1):
            print(quiet_row(a.out / f"quiet_s{seed}", seed), flush=True)


if __name__ == "__main__":
    main()
