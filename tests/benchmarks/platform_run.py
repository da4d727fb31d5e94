"""Benchmark: ``scangeo run`` on a platform of a laser and a pushbroom, against the imager alone.

Simulates the preset (``platform_quick`` by default, with its images), runs ``scangeo run`` on it (the
variants of its diagnosis adjusted jointly with the laser's patches: ``scangeo.strategy.platform``) and
prints each stage's wall seconds, the run's CPU seconds in this process, and per variant the image strips'
true ground error (``scangeo.truth``, rms over the strips' sample grids) of the joint adjustment
(``comparison.json``) against the baseline, the imager alone (``compare_project`` with ``run_variant`` on
a copy of the project with the same variants.toml, its CPU seconds too), with their ratio; the laser's strip
differences on flat cells before and after for every jointly adjusted variant.

Run:  python tests/benchmarks/platform_run.py [--preset platform] [--out DIR] [--no-images]
      (the full ``platform`` preset simulates 7.2 M returns: ~300 s wall for the simulation alone)
"""
from __future__ import annotations

import argparse
import json
import resource
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np

from scangeo.pipeline.run import run
from scangeo.reports.tables import write_comparison
from scangeo.simulate.block import simulate
from scangeo.simulate.config import load_preset
from scangeo.strategy.comparison import compare_project


def _true(comparison: dict) -> dict[str, float | None]:
    """Per variant the rms over the strips of their true ground error (m), None for a failed variant."""
    out: dict[str, float | None] = {}
    for v in comparison["variants"]:
        errors = [s["true"]["rms_ground_m"] for s in v.get("strips", {}).values() if s.get("true")]
        out[v["name"]] = float(np.sqrt(np.mean(np.square(errors)))) if errors and v.get("error") is None else None
    return out


def _children() -> float:
    """CPU seconds (user + system) of this process's finished child processes."""
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--preset", default="platform_quick")
    ap.add_argument("--out", type=Path, help="folder of the simulation (default: a temporary one)")
    ap.add_argument("--no-images", action="store_true", help="simulate without images (no rectify stage)")
    args = ap.parse_args()
    base = args.out or Path(tempfile.mkdtemp(prefix="platform_run_"))
    print(subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip())
    sim = base / "sim"
    t = time.process_time()
    if not (sim / "project.toml").exists():
        over = {"output": {"images": False, "truth_ortho": False}} if args.no_images else {}
        simulate(sim, load_preset(args.preset, over))
        print(f"simulate {args.preset}: {time.process_time() - t:.1f} CPU s")
    joint_root, alone_root = base / "joint", base / "alone"
    for root in (joint_root, alone_root):
        shutil.rmtree(root, ignore_errors=True)
        shutil.copytree(sim, root)

    t, children = time.process_time(), _children()
    result = run(joint_root)
    cpu_run = time.process_time() - t
    print(f"scangeo run: {cpu_run:.1f} CPU s in this process, {_children() - children:.1f} in its child processes "
          f"({result.seconds:.1f} s wall)")
    for o in result.stages:
        print(f"  {o.name:9s} {o.status:10s} {o.seconds:7.1f} s wall")
    print(f"recommended: {result.recommended}")

    shutil.copy(joint_root / "variants.toml", alone_root / "variants.toml")
    t = time.process_time()
    alone = compare_project(alone_root, alone_root / "variants.toml", callback=lambda *a: None)
    write_comparison(alone)
    cpu_alone = time.process_time() - t
    compare_seconds = result.outcome("compare").seconds
    print(f"baseline, the imager alone (compare_project, run_variant): {cpu_alone:.1f} CPU s; the run's joint "
          f"compare stage {compare_seconds:.1f} s wall")
    print(f"  recommended alone: {(alone.crossvalidation or {}).get('recommended')}")

    joint = json.loads((joint_root / "results" / "comparison.json").read_text())
    e_joint, e_alone = _true(joint), _true(json.loads((alone_root / "results" / "comparison.json").read_text()))
    print("\nvariant  | images true ground error m: alone   joint   joint/alone | laser flat differences cm: "
          "before  after")
    for name in e_joint:
        a, j = e_alone.get(name), e_joint[name]
        laser_file = joint_root / "results" / name / "report.json"
        laser = json.loads(laser_file.read_text()).get("laser") if laser_file.exists() else None
        flat = laser["strip_differences_flat_rms_m"] if laser else None
        ratio = f"{j / a:6.2f}" if a and j else "     -"
        print(f"{name:8s} | {a if a is not None else float('nan'):37.3f} "
              f"{j if j is not None else float('nan'):7.3f} {ratio:>13s} | "
              + (f"{100 * flat['before']:31.2f} {100 * flat['after']:6.2f}" if flat else
                 f"{'failed: ' + str(next(v['error'] for v in joint['variants'] if v['name'] == name))[:60]:>38s}"))
    print(subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip())


if __name__ == "__main__":
    main()
