"""Benchmark: `scangeo run` with the code of a baseline revision and with this checkout's, side by side,
and every output of the two compared.

A simulated project (``--project``, or the ``--preset`` simulated once into ``--cache``) is copied
fresh (no results, no truth) for every run; the baseline's code is ``git archive REV`` unpacked into
``--cache``, this checkout's is the repository root; each run is ``python -m scangeo run COPY`` in its
own process with PYTHONPATH set to one of them, the two alternating ``--reps`` times, optionally with
``--load N`` busy-loop processes beside them the whole time (the load average is printed: the
machine's own load counts as well). Printed per run: CPU seconds of the process (user + system, every
thread), wall seconds, the load average at its start; then the least CPU of each and their ratio.

Then the outputs of the first run of each: every file under ``results/`` but the run's own records
(``run.json``, logs) compared, JSON and CSV value by value (numbers to the bit), rasters cell by cell,
the HTML report after its timings are taken out; printed: the files that differ and how much.

Run: python tests/benchmarks/run_revisions.py --baseline REV [--preset vienna2000 | --project DIR]
[--reps 2] [--load 0] [--cache DIR] [--with-results] [--warm SMALL_PROJECT]
[-- EXTRA RUN ARGUMENTS, e.g. --from compare --until compare]
"""
from __future__ import annotations

import argparse
import csv
import io
import json
import math
import multiprocessing as mp
import os
import re
import resource
import shutil
import subprocess
import sys
import tarfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
#: the run's own records, which hold times and paths
SKIP = {"run.json"}
#: keys whose values are times, paths or versions, not figures
VOLATILE = re.compile(r"(seconds|time|elapsed|started|finished|created|datetime|path|file|folder|root|project"
                      r"|version|commit|host|fingerprint|digest|hash)", re.I)


def busy(stop) -> None:
    x = 0
    while not stop.is_set():
        for _ in range(100_000):
            x += 1


def code_at(revision: str, cache: Path) -> Path:
    """The package as it was at ``revision`` (git archive), unpacked once into ``cache``."""
    sha = subprocess.run(["git", "-C", str(ROOT), "rev-parse", revision], check=True, capture_output=True,
                         text=True).stdout.strip()
    target = cache / f"code-{sha[:12]}"
    if not (target / "scangeo").exists():
        data = subprocess.run(["git", "-C", str(ROOT), "archive", sha, "scangeo"], check=True,
                              capture_output=True).stdout
        target.mkdir(parents=True, exist_ok=True)
        with tarfile.open(fileobj=io.BytesIO(data)) as tar:
            tar.extractall(target, filter="data")
    return target


def simulated(cache: Path, preset: str, code: Path) -> Path:
    root = cache / preset
    if not (root / "project.toml").exists():
        subprocess.run([sys.executable, "-m", "scangeo", "simulate", str(root), "--preset", preset, "--no-progress"],
                       check=True, env={**os.environ, "PYTHONPATH": str(code)}, cwd=cache)
    return root


def fresh(source: Path, target: Path, with_results: bool = False) -> Path:
    shutil.rmtree(target, ignore_errors=True)
    skip = ("truth",) if with_results else ("results", "truth")
    shutil.copytree(source, target, ignore=shutil.ignore_patterns(*skip))
    return target


def children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def run(code: Path, project: Path, extra: list[str]) -> tuple[float, float]:
    t, c = time.perf_counter(), children_cpu()
    subprocess.run([sys.executable, "-m", "scangeo", "run", str(project), "--no-progress", *extra], check=True,
                   capture_output=True, env={**os.environ, "PYTHONPATH": str(code), "PYTHONWARNINGS": "ignore"},
                   cwd=project.parent)
    return children_cpu() - c, time.perf_counter() - t


def _differences(a, b, where: str, out: list[str], limit: int = 12) -> None:
    if len(out) >= limit:
        return
    if isinstance(a, dict) and isinstance(b, dict):
        for k in sorted(set(a) | set(b), key=str):
            if VOLATILE.search(str(k)):
                continue
            if k not in a or k not in b:
                out.append(f"{where}.{k}: only in one")
            else:
                _differences(a[k], b[k], f"{where}.{k}", out, limit)
    elif isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            out.append(f"{where}: {len(a)} against {len(b)} items")
            return
        for i, (x, y) in enumerate(zip(a, b)):
            _differences(x, y, f"{where}[{i}]", out, limit)
    elif isinstance(a, float) and isinstance(b, float):
        if not (a == b or (math.isnan(a) and math.isnan(b))):
            out.append(f"{where}: {a!r} against {b!r} (relative {abs(a - b) / max(abs(a), abs(b), 1e-300):.1e})")
    elif a != b:
        out.append(f"{where}: {a!r} against {b!r}")


def _as_values(text: str):
    rows = list(csv.reader(io.StringIO(text)))
    return [[_number(v) for v in r] for r in rows]


def _number(v: str):
    try:
        return float(v)
    except ValueError:
        return v


def compare_outputs(a: Path, b: Path) -> list[str]:
    """What differs between the results/ folders of two runs (empty: nothing)."""
    report = []
    files_a = {p.relative_to(a) for p in a.rglob("*") if p.is_file() and p.name not in SKIP}
    files_b = {p.relative_to(b) for p in b.rglob("*") if p.is_file() and p.name not in SKIP}
    for rel in sorted(files_a ^ files_b):
        report.append(f"{rel}: only in {'the baseline' if rel in files_a else 'this checkout'}'s run")
    for rel in sorted(files_a & files_b):
        pa, pb = a / rel, b / rel
        diff: list[str] = []
        if pa.suffix == ".json":
            _differences(json.loads(pa.read_text(encoding="utf-8")), json.loads(pb.read_text(encoding="utf-8")),
                         "", diff)
        elif pa.suffix == ".csv":
            _differences(_as_values(pa.read_text(encoding="utf-8")), _as_values(pb.read_text(encoding="utf-8")),
                         "", diff)
        elif pa.suffix in (".tif", ".tiff"):
            import numpy as np
            import rasterio

            with rasterio.open(pa) as x, rasterio.open(pb) as y:
                va, vb = x.read(), y.read()
            if va.shape != vb.shape or not np.array_equal(va, vb, equal_nan=va.dtype.kind == "f"):
                diff.append("cells differ")
        elif pa.suffix in (".html", ".svg", ".txt", ".toml", ".geojson"):
            strip = re.compile(r"\d+(\.\d+)? ?(s|seconds|ms)\b|\d{4}-\d\d-\d\d[T ][\d:.]+|/[\w./-]+")
            if strip.sub("", pa.read_text(encoding="utf-8", errors="replace")) != strip.sub(
                    "", pb.read_text(encoding="utf-8", errors="replace")):
                diff.append("text differs")
        elif pa.read_bytes() != pb.read_bytes():
            diff.append("bytes differ")
        report += [f"{rel}{d}" if d.startswith((".", "[")) else f"{rel}: {d}" for d in diff]
    return report


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--baseline", required=True, help="git revision of the baseline code")
    ap.add_argument("--preset", default="vienna2000")
    ap.add_argument("--project", type=Path, help="a project folder instead of --preset (copied, never changed)")
    ap.add_argument("--reps", type=int, default=2)
    ap.add_argument("--load", type=int, default=0, help="busy-loop processes beside the runs")
    ap.add_argument("--with-results", action="store_true", help="copy the project's results/ too (to run from a "
                    "later stage: -- --from compare --until compare)")
    ap.add_argument("--cache", type=Path, default=Path("/tmp/scangeo-bench-revisions"))
    ap.add_argument("--warm", type=Path, help="a small project each code runs once first, untimed (with the same "
                    "arguments and --with-results): numba's cache of a freshly unpacked baseline is empty, and "
                    "compiling would be counted against it")
    ap.add_argument("extra", nargs="*", help="more arguments of `scangeo run` (after --)")
    args = ap.parse_args()
    args.cache.mkdir(parents=True, exist_ok=True)
    base = code_at(args.baseline, args.cache)
    source = args.project or simulated(args.cache, args.preset, ROOT)
    routes = {f"baseline {args.baseline}": base, "this checkout": ROOT}
    stop = mp.get_context("fork").Event()
    procs = [mp.get_context("fork").Process(target=busy, args=(stop,), daemon=True) for _ in range(args.load)]
    for p in procs:
        p.start()
    if procs:
        time.sleep(3.0)
    print(f"{source}: `scangeo run {' '.join(args.extra)}`; {args.load} busy-loop processes beside it; "
          f"OPENBLAS_CORETYPE={os.environ.get('OPENBLAS_CORETYPE')}", flush=True)
    if args.warm is not None:
        for k, (name, code) in enumerate(routes.items()):
            c, w = run(code, fresh(args.warm, args.cache / "runs" / f"warm-{k}", args.with_results), args.extra)
            print(f"warm {name:25s} CPU {c:8.1f} s  wall {w:8.1f} s  ({args.warm}, not counted)", flush=True)
    cpu: dict[str, list[float]] = {n: [] for n in routes}
    first: dict[str, Path] = {}
    try:
        for rep in range(args.reps):
            for k, (name, code) in enumerate(routes.items()):
                copy = fresh(source, args.cache / "runs" / f"{k}-{rep}", args.with_results)
                load = os.getloadavg()[0]
                c, w = run(code, copy, args.extra)
                cpu[name].append(c)
                first.setdefault(name, copy)
                print(f"{rep} {name:28s} CPU {c:8.1f} s  wall {w:8.1f} s  load at start {load:5.1f}", flush=True)
    finally:
        stop.set()
        for p in procs:
            p.join()
    (nb, cb), (nn, cn) = ((n, min(v)) for n, v in cpu.items())
    print(f"\nleast CPU: {nb} {cb:.1f} s, {nn} {cn:.1f} s: {cn / cb:.3f}x", flush=True)
    diffs = compare_outputs(first[nb] / "results", first[nn] / "results")
    if diffs:
        print(f"outputs: {len(diffs)} differences")
        for d in diffs[:60]:
            print("  " + d)
    else:
        print("outputs: every file of results/ the same (figures to the bit; run.json and times aside)")


if __name__ == "__main__":
    main()
