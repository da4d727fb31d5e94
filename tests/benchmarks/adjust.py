"""Benchmark: `scangeo adjust` on simulated blocks -- time per iteration, to convergence, peak memory.

Cases: vienna2000 (SE, P4, S2), block24 (SE), and the scaling of SE with the number of strips
(the first 1, 3, 12, 24 strips of the block24 project). Every case runs in its own process (peak memory is the
process's maximum resident set). Blocks are simulated without images into a cache folder first.

Run:  python tests/benchmarks/adjust.py [--cache DIR] [--only vienna|block24|scaling]
Baselines, run side by side: for the solver, the same adjustment with the scipy fallback
(``backend = "superlu"``) on vienna2000 SE; for data snooping, a full solution and selected
inversion after every removal (``snooping_method = "resolve"``) on vienna2000 SE and block24 SE.
Targets: any vienna2000 variant < 10 s; block24 SE < 60 s and < 4 GB.
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import time
import tomllib
from pathlib import Path

VARIANTS = """
[variants.P4]
strategy = "P"
roles = { "B*" = "control" }
dtm_heights = true
[[variants.P4.strip]]
id = "02"
position_degree = 4

[variants.S2]
strategy = "S"
roles = { "B*" = "control" }
dtm_heights = true
[[variants.S2.strip]]
id = "02"
breaks_lines = [2400, 4900]
position_degree = 2

[variants.SE_superlu]
strategy = "SE"
backend = "superlu"

[variants.SE_resolve]
strategy = "SE"
snooping_method = "resolve"
"""

CASE = """
import json, resource, sys, time
from scangeo.adjustment.results import run_variant
t0 = time.perf_counter()
r = run_variant(sys.argv[1], sys.argv[2], sys.argv[3] if len(sys.argv) > 3 else None)
sol, st = r.adjustment.solution, r.adjustment.statistics
print(json.dumps({"seconds": time.perf_counter() - t0, "iterations": len(sol.iterations),
    "solves": getattr(r.adjustment, "full_solutions", r.adjustment.snooping_rounds + 1),
    "rounds": r.adjustment.snooping_rounds, "per_iteration": [round(i.seconds, 3) for i in sol.iterations],
    "unknowns": st.accounting.unknowns, "observations": st.accounting.observations, "backend": sol.factor.backend,
    "sigma0": st.sigma0, "rejected": len(r.adjustment.rejections),
    "cpu_s": sum(resource.getrusage(resource.RUSAGE_SELF)[:2]),
    "peak_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))
"""


def prepared(cache: Path, preset: str) -> Path:
    """A simulated project (no images) in the cache, made once."""
    root = cache / preset
    if not (root / "project.toml").exists():
        from scangeo.simulate.block import simulate
        from scangeo.simulate.config import load_preset

        t0 = time.perf_counter()
        simulate(root, load_preset(preset, {"output": {"images": False, "truth_ortho": False}}), overwrite=True)
        ground = root / "ground.csv"  # simulate writes sigma_xy 0 for height points; the reader wants > 0
        ground.write_text(ground.read_text().replace(",0,0.1,height", ",1,0.1,height"))
        print(f"  simulated {preset} in {time.perf_counter() - t0:.0f} s", flush=True)
    (root / "variants.toml").write_text(VARIANTS)
    return root


def first_strips(block: Path, n: int) -> Path:
    """A copy of a project keeping its first n strips (and their measurements)."""
    root = block.with_name(f"{block.name}_{n}")
    if not root.exists():
        shutil.copytree(block, root, ignore=shutil.ignore_patterns("results", "truth"))
        text = (root / "project.toml").read_text()
        head, *strips = text.split("[[strips]]")
        (root / "project.toml").write_text("[[strips]]".join([head] + strips[:n]))
        keep = {tomllib.loads("[[strips]]" + s)["strips"][0]["id"] for s in strips[:n]}
        lines = (root / "points.csv").read_text().splitlines()
        rows = [lines[0]] + [ln for ln in lines[1:] if ln.split(",")[1] in keep]
        (root / "points.csv").write_text("\n".join(rows) + "\n")
    return root


def run_case(root: Path, variant: str, source: str | None = None) -> dict:
    """One adjustment in its own process; ``source``: run an older scangeo tree instead (PYTHONPATH),
    with a variants file of the variant alone (older trees may not know newer keys)."""
    args = [sys.executable, "-c", CASE, str(root.resolve()), variant]
    if source:
        alone = root.parent / f"{root.name}_{variant}_alone.toml"
        alone.write_text(f'[variants.{variant}]\nstrategy = "{variant}"\n')
        args.append(str(alone))
    env = dict(os.environ, PYTHONPATH=source) if source else None
    out = subprocess.run(args, capture_output=True, text=True, env=env, cwd=source)
    if out.returncode:
        raise RuntimeError(out.stderr[-2000:])
    return json.loads(out.stdout.strip().splitlines()[-1])


def show(label: str, r: dict, **bases: dict) -> None:
    ratio = "".join(f"  x{b['seconds'] / r['seconds']:.1f} vs {name}" for name, b in bases.items())
    it = sum(r["per_iteration"]) / max(len(r["per_iteration"]), 1)
    print(
        f"{label:32s} {r['unknowns']:7d} unknowns {r['observations']:8d} obs  {r['seconds']:6.1f} s total "
        f"({r['cpu_s']:6.1f} s cpu)  "
        f"{it:5.2f} s/iteration ({r['iterations']} it, {r['solves']} full solutions, {r['rounds']} snooping rounds, "
        f"{r['rejected']} rejected, sigma0 {r['sigma0']:.6f})  peak {r['peak_mib']:6.0f} MiB  [{r['backend']}]{ratio}",
        flush=True,
    )


def load() -> str:
    return "load average " + " ".join(f"{x:.1f}" for x in os.getloadavg())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cache", default="/tmp/scangeo-bench-adjust", help="folder for the simulated blocks")
    parser.add_argument("--only", choices=["vienna", "block24", "scaling"], default=None)
    parser.add_argument("--repeat", type=int, default=1, help="runs of each block24 SE case, interleaved")
    parser.add_argument(
        "--before",
        default=None,
        metavar="SRC",
        help="also run block24 SE with an older source tree, e.g. made by `git archive COMMIT scangeo | tar -x -C SRC`",
    )
    args = parser.parse_args()
    cache = Path(args.cache)
    cache.mkdir(parents=True, exist_ok=True)
    if args.only in (None, "vienna"):
        root = prepared(cache, "vienna2000")
        print(load(), flush=True)
        base = run_case(root, "SE_superlu")
        show("vienna2000 SE (superlu)", base)
        resolve = run_case(root, "SE_resolve")
        show("vienna2000 SE (resolve)", resolve)
        show("vienna2000 SE", run_case(root, "SE"), superlu=base, resolve=resolve)
        for v in ("P4", "S2"):
            show(f"vienna2000 {v}", run_case(root, v))
        print(load(), flush=True)
    if args.only in (None, "block24"):
        root = prepared(cache, "block24")
        print(load(), flush=True)
        for _ in range(args.repeat):
            base = run_case(root, "SE_resolve")
            show("block24 SE (resolve)", base)
            before = run_case(root, "SE", args.before) if args.before else None
            if before:
                show("block24 SE (before)", before)
            show("block24 SE", run_case(root, "SE"), resolve=base, **({"before": before} if before else {}))
            print(load(), flush=True)
    if args.only in (None, "scaling"):
        block = prepared(cache, "block24")
        for n in (1, 3, 12, 24):
            show(f"block24 SE, first {n} strips", run_case(block if n == 24 else first_strips(block, n), "SE"))


if __name__ == "__main__":
    main()
