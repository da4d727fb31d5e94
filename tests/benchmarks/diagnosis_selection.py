"""Benchmark: the diagnosis's break selection by BIC (``select_breaks`` and ``break_intervals``) with the
local update of ``scangeo/adjustment/diagnosis/local_fit.py`` against its baseline, every candidate refitted
with ``patterns.evaluate`` (the selection before the local update), side by side in one process.

For each size, block24 with that many strips (``--lines`` lines each, the preset scaled as in
``tests/benchmarks/block.py``) is simulated without images, adjusted SE as the diagnosis does, and its
pattern data taken (``diagnose.pattern_data``; set-up, not timed). Then the selection runs with the update
and, for the sizes of ``--baseline``, with every candidate refitted (the update switched off as in
``tests/adjustment/diagnosis/test_local_fit.py``). Printed per size: CPU seconds of each, the number of
exact refits, whether both chose the same breaks, criterion and intervals, and the ratios to the smallest
size (linear cost: the ratio of the sizes).

Run: python tests/benchmarks/diagnosis_selection.py [--sizes 24 48 96] [--lines 7000] [--baseline 24]
[--work DIR] (``--work`` keeps the simulated blocks and reuses them on the next run).
"""
from __future__ import annotations

import argparse
import pickle
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from tests.benchmarks.block import scaled_preset  # noqa: E402


def pattern_data(root: Path, lines: int, strips: int, work: Path):
    cache = work / f"pattern_{strips}x{lines}.pkl"
    if cache.exists():
        return pickle.loads(cache.read_bytes())
    if not (root / "project.toml").exists():
        preset = scaled_preset(lines, strips, work)
        subprocess.run([sys.executable, "-m", "scangeo", "simulate", str(root), "--preset", str(preset),
                        "--no-images", "--no-progress"], check=True, stdout=subprocess.DEVNULL)
    from scangeo.adjustment.diagnosis.diagnose import pattern_data, se_variant
    from scangeo.adjustment.results import run_variant

    data, _ = pattern_data(run_variant(root, se_variant()))
    cache.write_bytes(pickle.dumps(data))
    return data


def run(data, refit_all: bool):
    from scangeo.adjustment.diagnosis import patterns
    from scangeo.adjustment.diagnosis.local_fit import CurrentFit, StripProbe

    saved = (StripProbe.rss_rank, CurrentFit.bic, patterns.evaluate)
    calls = [0]

    def counted(*args, **kwargs):
        calls[0] += 1
        return saved[2](*args, **kwargs)

    patterns.evaluate = counted
    if refit_all:
        StripProbe.rss_rank = lambda self, breaks_s, constant_s: None  # type: ignore[method-assign]
        CurrentFit.bic = lambda self, rho, n_breaks: None  # type: ignore[method-assign]
    try:
        t = time.process_time()
        fit = patterns.select_breaks(data)
        intervals = patterns.break_intervals(data, fit)
        cpu = time.process_time() - t
    finally:
        StripProbe.rss_rank, CurrentFit.bic, patterns.evaluate = saved  # type: ignore[method-assign]
    return cpu, calls[0], fit, [(b.strip, b.line, b.low, b.high) for b in intervals]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[24, 48, 96])
    ap.add_argument("--lines", type=int, default=7000)
    ap.add_argument("--baseline", type=int, nargs="*", default=[24],
                    help="sizes also run with every candidate refitted")
    ap.add_argument("--work", type=Path)
    args = ap.parse_args()
    work = args.work or Path(tempfile.mkdtemp(prefix="selection_"))
    work.mkdir(parents=True, exist_ok=True)
    rows = []
    for n in args.sizes:
        data = pattern_data(work / f"block{n}", args.lines, n, work)
        cpu, refits, fit, intervals = run(data, False)
        line = dict(n=n, rows=data.n, cpu=cpu, refits=refits,
                    breaks={data.strips[s]: [round(v) for v in b] for s, b in enumerate(fit.breaks) if b})
        if n in args.baseline:
            base_cpu, base_refits, base_fit, base_intervals = run(data, True)
            same = (base_fit.breaks == fit.breaks and base_fit.constant == fit.constant and base_fit.bic == fit.bic
                    and base_intervals == intervals)
            line.update(base_cpu=base_cpu, base_refits=base_refits, same=same)
        rows.append(line)
        print(line, flush=True)
    first = rows[0]
    print(f"\n{'strips':>6} {'rows':>6} {'update CPU s':>12} {'refits':>6} {'ratio':>6} {'refit-all CPU s':>15} "
          f"{'refits':>6} {'speed-up':>8} {'same':>5}  breaks")
    for r in rows:
        base = (f"{r['base_cpu']:15.1f} {r['base_refits']:6d} {r['base_cpu'] / r['cpu']:7.1f}x {str(r['same']):>5}"
                if "base_cpu" in r else f"{'-':>15} {'-':>6} {'-':>8} {'-':>5}")
        print(f"{r['n']:6d} {r['rows']:6d} {r['cpu']:12.1f} {r['refits']:6d} {r['cpu'] / first['cpu']:5.1f}x {base}  "
              f"{r['breaks']}")
    print(f"(ratios to {first['n']} strips; linear cost: the ratio of the sizes)")


if __name__ == "__main__":
    main()
