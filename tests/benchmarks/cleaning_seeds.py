"""Acceptance figures per seed: cleaning, diagnosis and break intervals on vienna2000 with blunders.

Not collected by pytest. For every seed: simulate vienna2000 (``--factor`` of its length, every line-based key
scaled as in tests/strategy/test_physics.py) without images and with ``--blunders N`` blunders of 10-40 px among
the measurements (``points.blunders``), clean it (``scangeo clean``; ``--no-clean``: not), then diagnose it
(or, with ``--compare``, run ``compare`` without a variants file: diagnosis, default variants, 2-fold
cross-validation) and print one row: sigma0 before/after the cleaning, the blunders with a finite MDB removed
(separable or with their point, not separable) and missed, good measurements rejected on their own (false
alarms), the diagnosis's SE sigma0 and its warning, the problem strips found, every injected break with the
nearest found one and whether the 95 % interval contains it, and with ``--compare`` the recommended variant's
pooled true error against the best variant's. The last lines sum up over the seeds: blunders removed, breaks
inside their intervals, seeds with the problem strip found alone.

    python tests/benchmarks/cleaning_seeds.py OUT [--factor 0.5] [--seeds 1 2 3] [--blunders 20] [--compare]

Projects already simulated in OUT are reused (delete OUT to start again). Truth is read here only to score.
"""
from __future__ import annotations

import argparse
import csv
import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "strategy"))
from test_physics import pooled_true, reduced_overrides  # noqa: E402

from scangeo.adjustment.diagnosis.diagnose import diagnose  # noqa: E402
from scangeo.io.rejected import rejected_path  # noqa: E402
from scangeo.simulate.block import simulate  # noqa: E402
from scangeo.simulate.config import load_preset  # noqa: E402
from scangeo.strategy.cleaning import clean, restore  # noqa: E402
from scangeo.strategy.comparison import compare_project  # noqa: E402


def simulate_vienna(root: Path, seed: int, factor: float, blunders: int) -> None:
    if not (root / "project.toml").exists():
        over: dict = {"output": {"images": False, "truth_ortho": False}, "seed": seed}
        if factor != 1.0:
            over.update(reduced_overrides("vienna2000", factor))
        over.setdefault("points", {})["blunders"] = blunders
        simulate(root, load_preset("vienna2000", over))


def _blunders(root: Path) -> list[tuple[str, str]]:
    with open(root / "truth" / "measurements.csv", newline="", encoding="utf-8") as f:
        return [(r["point"], r["strip"]) for r in csv.DictReader(f) if r["blunder"] == "1"]


def seed_row(root: Path, seed: int, factor: float, blunders: int, cleaning: bool, compare: bool, totals: dict) -> str:
    simulate_vienna(root, seed, factor, blunders)
    for stale in ("variants.toml",):
        (root / stale).unlink(missing_ok=True)
    t0 = time.perf_counter()
    bad = _blunders(root)
    if cleaning:
        c = clean(root)
        rejected = {r.key: r for r in c.rejected if r.kind == "image"}
        finite = [k for k in bad if c.mdb.get(k, float("inf")) < float("inf")]
        removed = [k for k in finite if k in rejected]
        not_sep = [k for k in removed if not rejected[k].separable]
        false = [k for k, r in rejected.items() if r.separable and k not in set(bad)]
        clean_text = (f"{c.sigma0_before:.2f} -> {c.sigma0_after:.2f} | {len(removed)}/{len(finite)} "
                      f"({len(not_sep)} n.s.; {len(bad) - len(finite)} MDB inf) | {len(false)} |")
        totals["finite"] += len(finite)
        totals["removed"] += len(removed)
        totals["false"] += len(false)
    else:
        restore(root)
        clean_text = "– | – | – |"
    assert cleaning == rejected_path(root).exists()
    t1 = time.perf_counter()
    truth = json.loads((root / "truth" / "errors.json").read_text())
    problem = str(truth["problem_strip"])
    rec_text = ""
    if compare:
        comp = compare_project(root, folds=2)
        d = json.loads((root / "results" / "diagnosis.json").read_text())
        problems, breaks, sigma0 = d["problem_strips"], d["breaks"], d["se_sigma0"]
        warned = any("far above 1" in n for n in d["notes"])
        adjusted = [v for v in comp.variants if v.strategy != "DG" and v.error is None]
        best = min(adjusted, key=pooled_true)
        rec = comp.variant(comp.recommended) if comp.recommended else None
        ratio = None if rec is None else pooled_true(rec) / pooled_true(best)
        rec_text = "– |" if rec is None else f"{rec.name} {100 * ratio:.0f} % of {best.name} |"
        totals["within15"] += ratio is not None and ratio <= 1.15
    else:
        diag = diagnose(root)
        problems, sigma0 = diag.problem_strips, diag.sigma0
        breaks = [{"strip": b.strip, "line": b.line, "low": b.low, "high": b.high} for b in diag.breaks]
        warned = any("far above 1" in n for n in diag.notes)
    seconds = time.perf_counter() - t1
    found = [b for b in breaks if b["strip"] == problem]
    parts = []
    for line in truth["breaks_lines"]:
        b = min(found, key=lambda b: abs(b["line"] - line)) if found else None
        inside = b is not None and b["low"] <= line <= b["high"]
        totals["breaks"] += 1
        totals["covered"] += inside
        parts.append("–" if b is None else f"{line:.0f}: {b['line']:.0f} ({b['line'] - line:+.0f}; "
                     f"{b['low']:.0f}-{b['high']:.0f} {'in' if inside else 'OUT'})")
    totals["seeds"] += 1
    totals["alone"] += problems == [problem]
    return (f"| {seed} | {clean_text} {sigma0:.2f}{' (warning)' if warned else ''} | {', '.join(problems) or '–'} "
            f"({problem}) | {' / '.join(parts)} | {rec_text} {t1 - t0:.0f} + {seconds:.0f} s |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("--factor", type=float, default=0.5)
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4, 5])
    ap.add_argument("--blunders", type=int, default=20)
    ap.add_argument("--no-clean", dest="clean", action="store_false", help="diagnose without cleaning first")
    ap.add_argument("--compare", action="store_true", help="compare (with the recommendation), not only diagnose")
    a = ap.parse_args()
    print(f"vienna2000 at {a.factor:g} of its length, {a.blunders} blunders, {'cleaned' if a.clean else 'not cleaned'}"
          f", {'compare' if a.compare else 'diagnosis'}:\n")
    print("| seed | cleaning sigma0 | blunders (finite MDB) removed | false alarms | diagnosis SE sigma0 | "
          "problem strips (injected) | injected break: found (offset; 95 %) | "
          + ("recommended: true error | " if a.compare else "") + "clean + rest |")
    print("|---|---|---|---|---|---|---|" + ("---|" if a.compare else "") + "---|")
    totals = dict.fromkeys(("finite", "removed", "false", "breaks", "covered", "seeds", "alone", "within15"), 0)
    for seed in a.seeds:
        root = a.out / f"vienna_{a.factor:g}_b{a.blunders}_s{seed}"
        try:
            print(seed_row(root, seed, a.factor, a.blunders, a.clean, a.compare, totals), flush=True)
        except Exception as exc:  # noqa: BLE001 (a benchmark row, not a library: say so and go on)
            print(f"| {seed} | failed: {type(exc).__name__}: {exc} |", flush=True)
    t = totals
    print(f"\nblunders with a finite MDB removed: {t['removed']} of {t['finite']}; false alarms {t['false']}; "
          f"breaks inside their 95 % interval: {t['covered']} of {t['breaks']}; problem strip found alone: "
          f"{t['alone']} of {t['seeds']} seeds" + (f"; recommended within 15 % of the best: {t['within15']} of "
                                                   f"{t['seeds']}" if a.compare else ""))


if __name__ == "__main__":
    main()
