"""Benchmark: a whole block end to end: simulate, adjust (SE and an S variant), rectify
every strip and the mosaic; wall time per stage, peak memory, scaling with the number of strips.

Run: python tests/benchmarks/block.py [--lines 7000] [--strips 1 6 12 24] [--keep DIR]
[--scheduler local|ADDRESS] [--variant S2] [--skip-adjust] [--workers 2]

Set-up (timed, reported apart): the ``block24`` preset simulated with its images (24 strips of
716 px x ``--lines`` lines x 11 bands; ``--lines`` below 7,000 scales every line-valued key of the
preset: breaks, excursions, control bands). Then each stage runs as its own ``scangeo`` process,
as a user would run it:

* ``scangeo adjust ROOT --variant SE`` and ``--variant S2`` (the S variant splits the simulated
  problem strip at its breaks; a ``variants.toml`` with SE and S2 is written into the project);
* ``scangeo rectify ROOT --variant S2 --strips <first N> --mosaic`` for every N of ``--strips``
  (outputs removed between runs, so each N is rectified from scratch; overviews as the default);
  (``--workers 1``: in this process, pipelined), then the same with ``--workers 2`` (two local
  worker processes, one numba thread each);
  with ``--scheduler`` the same rectifications again on a Dask LocalCluster of 2 worker processes
  (1 thread each; ``local``) or the given scheduler, through ``--scheduler ADDRESS``.

``--sizes 24 48 96`` instead measures how every stage grows with the block: for each
number of strips a block24 project with that many strips (``--lines`` lines each; the preset's
line-valued keys scaled, :func:`scaled_preset`) is simulated by ``scangeo simulate --preset FILE``
(``--no-images`` unless ``--images``),
then ``adjust --variant SE`` (with the reliability), ``diagnose``, ``compare`` (every default
variant: the diagnosis, 8 variants, a 4-fold cross-validation of 7; ``--no-report``), ``compare DG SE
S4`` (the simulated problem strip and breaks given, three variants, 2 folds: the same stage at a
cost that fits; each compare starts without a variants.toml), ``report`` and, with images,
``match`` and ``rectify --variant SE --mosaic``, each as its own process (``--stages`` for a
subset); printed: wall and CPU seconds and peak memory per stage and size, and their ratios to the
smallest size (linear cost: the ratio of the sizes).
Run: python tests/benchmarks/block.py --sizes 24 48 96 --lines 7000 [--stages adjust diagnose]

Figures: wall seconds per stage, seconds per strip, and the peak resident memory of each stage's
process (``ru_maxrss`` of the process and its largest child; beside it the peak of the whole
process tree, worker processes summed, sampled from /proc every 0.25 s; for Dask the workers' peak as they report
it). Baseline for the scaling: the 1-strip run (time per strip should stay flat as N grows).
Big outputs go to a temporary folder (``--keep`` to keep them), removed at the end.
"""
from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
import tomllib
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

# the script that runs one `scangeo` command and records its peak memory, shared with the scale test
from tests.rectify.test_block_scale import STAGE  # noqa: E402

VARIANTS = """[defaults]
gps_sigma_m = [0.05, 0.05, 0.10]
imu_sigma_deg = [0.003, 0.003, 0.005]
snooping = false

[variants.SE]
strategy = "SE"
description = "one GPS/IMU model per strip, degree 0"

[variants.{name}]
strategy = "S"
description = "problem strip split at its breaks, position degree <= 2 per part; DTM heights"
dtm_heights = true
dtm_height_points = ["*"]
[[variants.{name}.strip]]
id = "{strip}"
breaks_lines = {breaks}
position_degree = 2
"""


def block_config(lines: int):
    """block24 with ``lines`` lines per strip (line-valued keys scaled) and no truth orthoimage."""
    from scangeo.resources import preset_file
    from scangeo.simulate.config import config_from_dict

    data = tomllib.loads(preset_file("block24").read_text(encoding="utf-8"))
    f = lines / float(data["flight"]["lines"])

    def scale(d):
        for key, value in d.items():
            if isinstance(value, dict):
                scale(value)
            elif isinstance(value, list) and value and isinstance(value[0], dict):
                for item in value:
                    scale(item)
            elif key.endswith("_lines") and key != "lines":
                d[key] = [v * f for v in value] if isinstance(value, list) else value * f

    if f != 1.0:
        scale(data["gpsimu_errors"])
        scale(data["points"])
    data["flight"]["lines"] = lines
    data["output"]["truth_ortho"] = False
    return config_from_dict(data, source="block24 (benchmark)"), data


def tree_rss_mib(root: int) -> float:
    """Resident memory of process ``root`` and all its descendants now (MiB), from /proc."""
    parent, rss = {}, {}
    page = os.sysconf("SC_PAGE_SIZE")
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            stat = Path(f"/proc/{entry}/stat").read_text()
            fields = stat[stat.rindex(")") + 2:].split()
            parent[int(entry)] = int(fields[1])
            rss[int(entry)] = int(fields[21]) * page
        except (OSError, ValueError, IndexError):
            continue
    tree, frontier = {root}, [root]
    while frontier:
        p = frontier.pop()
        for child in [c for c, pp in parent.items() if pp == p and c not in tree]:
            tree.add(child)
            frontier.append(child)
    return sum(rss.get(p, 0) for p in tree) / 2**20


def run_stage(label: str, args: list[str], log: list) -> tuple[float, float]:
    """Run ``scangeo ARGS`` in its own process; (wall seconds, peak RSS MiB of the largest single
    process), printing also the peak of the whole process tree (worker processes summed, sampled
    every 0.25 s) and its CPU seconds (user + system of the process and the children it waited for:
    the figure to compare on a loaded machine)."""
    import resource

    with tempfile.NamedTemporaryFile(suffix=".rss", delete=False) as f:
        rss_file = f.name
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.Popen([sys.executable, "-c", STAGE, rss_file, *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    tree_peak = 0.0
    while proc.poll() is None:
        tree_peak = max(tree_peak, tree_rss_mib(proc.pid))
        time.sleep(0.25)
    out, err = proc.communicate()
    dt = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = r1.ru_utime - r0.ru_utime + r1.ru_stime - r0.ru_stime
    rss = float(Path(rss_file).read_text() or "nan")
    os.unlink(rss_file)
    if proc.returncode:
        print(out[-2000:], err[-4000:])
        raise SystemExit(f"{label}: scangeo {' '.join(args)} failed ({proc.returncode})")
    log.append((label, dt, max(rss, tree_peak), os.getloadavg()[0], cpu))
    print(f"{label:<46}{dt:>9.1f} s{cpu:>8.1f} CPU s{rss:>9.0f} MiB (all processes {tree_peak:.0f} MiB)   "
          f"load {os.getloadavg()[0]:.1f}", flush=True)
    return dt, rss


def scaled_preset(lines: int, strips: int, folder: Path) -> Path:
    """block24's preset file with ``strips`` strips of ``lines`` lines: every line-valued key
    (breaks, excursions, control and break bands) scaled with the lines, and the problem strip
    moved to the middle when the block has fewer strips than its number."""
    import re

    from scangeo.resources import preset_file

    text = preset_file("block24").read_text(encoding="utf-8")
    f = lines / float(tomllib.loads(text)["flight"]["lines"])

    def scale(m: re.Match) -> str:
        value = tomllib.loads(f"v = {m.group(2)}")["v"]
        value = [v * f for v in value] if isinstance(value, list) else value * f
        return f"{m.group(1)} = {value!r}"

    text = re.sub(r"^(\w+_lines) = (.+)$", scale, text, flags=re.M)
    text = re.sub(r"^lines = .+$", f"lines = {lines}", text, flags=re.M)
    text = re.sub(r"^strips = .+$", f"strips = {strips}", text, flags=re.M)
    problem = int(tomllib.loads(text)["gpsimu_errors"]["problem_strip"])
    if problem > strips:
        middle = strips // 2 + 1
        text = re.sub(rf"^(problem_strip|strip) = {problem}$", rf"\1 = {middle}", text, flags=re.M)
    path = folder / f"block24_{strips}x{lines}.toml"
    path.write_text(text, encoding="utf-8")
    return path


def stage_scaling(sizes: list[int], lines: int, images: bool, work: Path, only: list[str] | None = None,
                  keep: bool = False) -> None:
    """Every stage (or those whose name starts with one of ``only``; the simulation always runs) at
    each block size (strips): seconds and peak MiB, ratios to the smallest. A stage that fails is
    reported and the next one runs. ``keep``: leave each size's project in ``work`` (to profile a
    stage on it afterwards)."""
    table: dict[tuple[str, int], tuple[float, float, float]] = {}
    stages: list[str] = []
    work.mkdir(parents=True, exist_ok=True)
    for n in sizes:
        root = work / f"block{n}"
        shutil.rmtree(root, ignore_errors=True)
        preset = scaled_preset(lines, n, work)
        sim = ["simulate", str(root), "--preset", str(preset), "--no-progress"] + ([] if images else ["--no-images"])
        plan = [("simulate", sim)]
        if images:
            plan.append(("match", ["match", str(root), "--no-progress"]))
        r = str(root)
        errors = tomllib.loads(preset.read_text(encoding="utf-8"))["gpsimu_errors"]
        given = ["--problem-strip", f"{int(errors['problem_strip']):02d}",
                 "--breaks-lines", *(f"{b:g}" for b in errors["breaks_lines"])]
        plan += [("adjust SE (with reliability)", ["adjust", r, "--variant", "SE", "--no-progress"]),
                 ("diagnose", ["diagnose", r, "--no-progress"]),
                 ("compare (every variant)", ["compare", r, "--no-report", "--no-progress"]),
                 # the same stage with the diagnosis's findings given (diagnose is measured above),
                 # three variants and 2 folds: compare's own work at a cost that fits a session
                 ("compare DG SE S4, 2 folds", ["compare", r, *given, "--only", "DG", "SE", "S4", "--folds", "2",
                                                "--no-report", "--no-progress"]),
                 ("report", ["report", r, "--no-progress"])]
        if images:
            plan.append(("rectify SE + mosaic", ["rectify", r, "--variant", "SE", "--mosaic", "--no-progress"]))
        log: list = []
        for name, args in plan:
            if only and name != "simulate" and not any(name.startswith(o) for o in only):
                continue
            if name not in stages:
                stages.append(name)
            if name.startswith("compare"):  # each compare fills in its own variants (diagnose writes some)
                (root / "variants.toml").unlink(missing_ok=True)
            try:
                dt, rss = run_stage(f"{n} strips: {name}", args, log)
                table[name, n] = (dt, log[-1][4], rss)
            except SystemExit as exc:  # a failed stage: say so, measure the others
                print(f"  FAILED: {exc}", flush=True)
        if not keep:
            shutil.rmtree(root, ignore_errors=True)
    base = sizes[0]
    print(f"\nstage scaling ({lines} lines per strip; ratios to {base} strips; linear = "
          + ", ".join(f"{n / base:.0f}x" for n in sizes[1:]) + "):")
    for name in stages:
        cells = []
        for n in sizes:
            if (name, n) not in table or (name, base) not in table:
                continue
            dt, cpu, rss = table[name, n]
            b_dt, b_cpu, b_rss = table[name, base]
            cells.append(f"{n}: {dt:.1f} s, {cpu:.1f} CPU s, {rss:.0f} MiB" + (
                "" if n == base else f" ({dt / b_dt:.2f}x, CPU {cpu / b_cpu:.2f}x, {rss / b_rss:.2f}x)"))
        print(f"  {name:<30} " + "; ".join(cells))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lines", type=int, default=7000)
    ap.add_argument("--strips", type=int, nargs="+", default=[1, 6, 12, 24])
    ap.add_argument("--variant", default="S2", help="name of the S variant")
    ap.add_argument("--scheduler", default=None, help="'local' (a LocalCluster of 2 workers) or an address")
    ap.add_argument("--keep", default=None, help="keep (and reuse) the simulated project in this folder")
    ap.add_argument("--skip-adjust", action="store_true", help="reuse the adjustments of a kept project")
    ap.add_argument("--workers", type=int, default=2,
                    help="also rectify with this many local worker processes (--workers; 1: not)")
    ap.add_argument("--sizes", type=int, nargs="+", default=None,
                    help="stage scaling: block sizes in strips (e.g. 24 48 96); see the docstring")
    ap.add_argument("--images", action="store_true", help="with --sizes: render images, then match and rectify")
    ap.add_argument("--stages", nargs="+", default=None,
                    help="with --sizes: only the stages whose names start with these (e.g. adjust diagnose)")
    args = ap.parse_args()
    if args.sizes:
        print(f"cores {os.cpu_count()}, load average {os.getloadavg()[0]:.1f}")
        work = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="scangeo-bench-sizes-"))
        try:
            stage_scaling(args.sizes, args.lines, args.images, work, args.stages, keep=bool(args.keep))
        finally:
            if not args.keep:
                shutil.rmtree(work, ignore_errors=True)
        return
    import numba

    from scangeo.threading_layer import choose_threading_layer

    choose_threading_layer()  # what scangeo's kernels do before their first run, so the line below is true
    print(f"cores {os.cpu_count()}, numba threading layer {numba.config.THREADING_LAYER}, "
          f"load average {os.getloadavg()[0]:.1f}")
    tmp = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="scangeo-bench-block-"))
    root = tmp / "block24"
    cfg, data = block_config(args.lines)
    if not (root / "project.toml").exists():
        from scangeo.simulate.block import simulate

        t0 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            simulate(root, cfg)
        print(f"set-up: block24 simulated with images, {data['flight']['strips']} strips x {args.lines} lines, "
              f"in {time.perf_counter() - t0:.0f} s ({root})", flush=True)
    errs = data["gpsimu_errors"]
    strip_id = f"{int(errs['problem_strip']):02d}"
    (root / "variants.toml").write_text(VARIANTS.format(name=args.variant, strip=strip_id,
                                                        breaks=[float(b) for b in errs["breaks_lines"]]))
    log: list = []
    r = str(root)
    for variant in () if args.skip_adjust else ("SE", args.variant):
        run_stage(f"adjust {variant}", ["adjust", r, "--variant", variant, "--no-progress"], log)
    ortho = root / "results" / args.variant / "ortho"
    ids = [f"{i + 1:02d}" for i in range(int(data["flight"]["strips"]))]
    routes = [("in process (pipelined)", ["--workers", "1"])]
    if args.workers > 1:
        routes.append((f"{args.workers} local worker processes", ["--workers", str(args.workers)]))
    cluster = None
    if args.scheduler:
        address = args.scheduler
        if address == "local":
            from dask.distributed import LocalCluster

            cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None)
            address = cluster.scheduler_address
        routes.append((f"Dask, 2 workers ({args.scheduler})", ["--scheduler", address]))
    per_strip = {}
    try:
        for route, extra in routes:
            for n in args.strips:
                shutil.rmtree(ortho, ignore_errors=True)
                dt, rss = run_stage(f"rectify {n:>2} strips + mosaic, {route}",
                                    ["rectify", r, "--variant", args.variant, "--strips", *ids[:n], "--mosaic",
                                     "--no-progress", *extra], log)
                if cluster is not None and extra and extra[0] == "--scheduler":
                    mem = cluster.scheduler_info["workers"]
                    rss = max(w.get("metrics", w).get("memory", 0) for w in mem.values()) / 2**20
                    print(f"{'':<46}{'':>11}{rss:>9.0f} MiB (largest Dask worker now)" if rss > 0 else
                          f"{'':<46}the Dask workers' memory is not reported by this scheduler")
                per_strip[route, n] = dt / n
    finally:
        if cluster is not None:
            cluster.close()
    print("\nscaling (seconds per strip; the 1-strip run is the baseline):")
    for route, _ in routes:
        base = per_strip.get((route, args.strips[0]))
        row = ", ".join(f"{n}: {per_strip[route, n]:.1f} s ({per_strip[route, n] / base:.2f}x)" for n in args.strips)
        print(f"  {route}: {row}")
    print(f"peak memory of any stage: {max(x[2] for x in log):.0f} MiB")
    if not args.keep:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
