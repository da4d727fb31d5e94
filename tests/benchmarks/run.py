"""Benchmark: `scangeo run` against the separate commands it replaces, on vienna2000 with images.

Baseline: the commands a user chains by hand, each in its own process, on a fresh copy of the
simulated project: `scangeo info`, `clean`, `diagnose`, `compare --no-report`, `rectify --variant
RECOMMENDED --mosaic`, `report`. Against it: `scangeo run` in one process on another fresh copy (the
same stages; match is left out by both, the simulated project has tie points). The two alternate,
`--reps` times each, and the script prints every time and the ratio run / separate (target: at most
1.10), in wall seconds and in CPU seconds (user + system of the child processes: on a shared machine the
CPU ratio is the one other jobs disturb least). It also checks that both chose the same variant. Then a
second `scangeo run` on the run's copy: the time of a run with nothing to do.

Run:  python tests/benchmarks/run.py [--cache DIR] [--preset vienna2000] [--reps 1]
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import time
from pathlib import Path


def simulated(cache: Path, preset: str) -> Path:
    """The simulated project (made once, kept in ``cache``)."""
    root = cache / preset
    if not (root / "project.toml").exists():
        from scangeo.simulate.block import simulate
        from scangeo.simulate.config import load_preset

        simulate(root, load_preset(preset, {"output": {"truth_ortho": False}}), overwrite=True)
    return root


def fresh(source: Path, target: Path) -> Path:
    """A copy of the simulated project without results (nor truth: what a user has)."""
    shutil.rmtree(target, ignore_errors=True)
    shutil.copytree(source, target, ignore=shutil.ignore_patterns("results", "truth", "variants.toml", "run.toml"))
    return target


CPU: list[float] = []  # CPU seconds of every command run, in order


def _children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def scangeo(*args: str) -> float:
    """Run one scangeo command in its own process; its wall time in seconds (its CPU seconds go to ``CPU``)."""
    t, c = time.perf_counter(), _children_cpu()
    subprocess.run([sys.executable, "-m", "scangeo", *args, "--no-progress"], check=True, capture_output=True,
                   env={**os.environ, "PYTHONWARNINGS": "ignore"})
    CPU.append(_children_cpu() - c)
    return time.perf_counter() - t


def separate(root: Path) -> tuple[dict[str, float], str]:
    """The separate commands; their seconds and the variant rectified."""
    p = str(root)
    seconds = {"info": scangeo("info", p), "clean": scangeo("clean", p), "diagnose": scangeo("diagnose", p),
               "compare": scangeo("compare", p, "--no-report")}
    c = json.loads((root / "results" / "comparison.json").read_text(encoding="utf-8"))
    variant = c["recommended"] or c["best"] or c["reference"]
    seconds["rectify"] = scangeo("rectify", p, "--variant", variant, "--mosaic")
    seconds["report"] = scangeo("report", p)
    return seconds, variant


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cache", default="/tmp/scangeo-bench-run")
    parser.add_argument("--preset", default="vienna2000")
    parser.add_argument("--reps", type=int, default=1)
    args = parser.parse_args()
    cache = Path(args.cache)
    cache.mkdir(parents=True, exist_ok=True)
    source = simulated(cache, args.preset)
    print(f"load before: {os.getloadavg()[0]:.1f} (1 min average; 2 cores)", flush=True)
    ratios = []
    for rep in range(args.reps):
        a = fresh(source, cache / "separate")
        n = len(CPU)
        steps, chosen = separate(a)
        total, cpu_separate = sum(steps.values()), sum(CPU[n:])
        print(f"rep {rep + 1}: separate commands {total:7.1f} s, {cpu_separate:7.1f} CPU s  ("
              + ", ".join(f"{k} {v:.1f}" for k, v in steps.items()) + f"); rectified {chosen}", flush=True)
        b = fresh(source, cache / "run")
        t_run = scangeo("run", str(b))
        cpu_run = CPU[-1]
        m = json.loads((b / "results" / "run.json").read_text(encoding="utf-8"))
        stages = {k: r.get("seconds", 0.0) for k, r in m["stages"].items()}
        print(f"rep {rep + 1}: scangeo run       {t_run:7.1f} s, {cpu_run:7.1f} CPU s  ("
              + ", ".join(f"{k} {v:.1f}" for k, v in stages.items()) + f"); rectified {m['recommended']['variant']}",
              flush=True)
        if m["recommended"]["variant"] != chosen:
            print(f"  note: the two chose different variants ({chosen} / {m['recommended']['variant']})")
        ratios.append(t_run / total)
        print(f"rep {rep + 1}: run / separate = {ratios[-1]:.3f} wall, {cpu_run / cpu_separate:.3f} CPU "
              f"(load now {os.getloadavg()[0]:.1f})", flush=True)
        t_again = scangeo("run", str(b))
        print(f"rep {rep + 1}: second scangeo run (nothing to do) {t_again:.1f} s", flush=True)
    print(f"load after: {os.getloadavg()[0]:.1f}")
    print(f"run / separate: {', '.join(f'{r:.3f}' for r in ratios)} (target <= 1.10)")


if __name__ == "__main__":
    main()
