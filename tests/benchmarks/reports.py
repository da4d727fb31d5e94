"""Benchmark: `scangeo compare`, `scangeo report` and `scangeo demo` on vienna2000.

Baseline for compare: the same 8 default variants adjusted one by one with `scangeo adjust` in their
own processes (what a user would run without compare), side by side with `compare_project` in this
process (one import, numba kernels compiled once, the truth read once; it also computes the true
error of every variant). Then `write_report` on the result. With `--demo`, the whole `scangeo demo`
(vienna2000 with images: simulate, compare, rectify, report) and the seconds of its stages.

Run:  python tests/benchmarks/reports.py [--cache DIR] [--demo]
"""
from __future__ import annotations

import argparse
import resource
import shutil
import subprocess
import sys
import time
from pathlib import Path


def prepared(cache: Path) -> Path:
    root = cache / "vienna2000"
    if not (root / "project.toml").exists():
        from scangeo.simulate.block import simulate
        from scangeo.simulate.config import load_preset

        simulate(root, load_preset("vienna2000", {"output": {"images": False, "truth_ortho": False}}), overwrite=True)
    shutil.rmtree(root / "results", ignore_errors=True)
    (root / "variants.toml").unlink(missing_ok=True)
    return root


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cache", default="/tmp/scangeo-bench-reports")
    parser.add_argument("--demo", action="store_true", help="also time the whole demo (minutes)")
    args = parser.parse_args()
    cache = Path(args.cache)
    cache.mkdir(parents=True, exist_ok=True)
    root = prepared(cache)

    from scangeo.reports.report import write_report
    from scangeo.reports.tables import write_comparison
    from scangeo.strategy.comparison import compare_project
    from scangeo.strategy.default_variants import ensure_variants_file

    t = time.perf_counter()
    variants_file = ensure_variants_file(root)  # no variants.toml yet: scangeo diagnose (an SE adjustment + the fit)
    print(f"diagnosis (SE adjustment, break selection)    {time.perf_counter() - t:6.1f} s", flush=True)
    names = list(__import__("scangeo.adjustment.variants", fromlist=["x"]).read_variants(variants_file))
    t = time.perf_counter()
    for v in names:
        subprocess.run([sys.executable, "-m", "scangeo", "adjust", str(root), "--variant", v, "--no-progress"],
                       check=True, capture_output=True)
    base = time.perf_counter() - t
    print(f"baseline: {len(names)} x 'scangeo adjust' processes     {base:6.1f} s", flush=True)
    t = time.perf_counter()
    c = compare_project(root, folds=0)
    write_comparison(c)
    cmp_s = time.perf_counter() - t
    print(f"compare_project (+ true error, tables)        {cmp_s:6.1f} s  x{base / cmp_s:.2f} vs baseline", flush=True)
    from scangeo.adjustment.variants import read_variants
    from scangeo.strategy.crossvalidation import cross_validate

    t = time.perf_counter()
    cv = cross_validate(root, read_variants(variants_file), c.variants, 4, variants_file)
    print(f"cross-validation, 4 folds ({cv.recommended} recommended)  {time.perf_counter() - t:6.1f} s", flush=True)
    t = time.perf_counter()
    files = write_report(root)
    print(f"write_report ({files.figures} figures, GeoPackage)        {time.perf_counter() - t:6.1f} s", flush=True)
    print(
        "peak resident memory of this process           "
        f"{resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:6.0f} MiB"
    )
    if args.demo:
        from scangeo.pipeline.demo import run_demo

        t = time.perf_counter()
        r = run_demo(cache / "demo", overwrite=True)
        print(
            f"demo total {time.perf_counter() - t:.0f} s: " + ", ".join(f"{k} {v:.0f} s" for k, v in r.seconds.items())
        )


if __name__ == "__main__":
    main()
