"""Benchmark: reliability (MDB, external reliability) and honest blunder attribution on simulated blocks.

1. Cost: the reliability of every observation row (one solve per row, in chunks, and the strips'
   probe grids) against the adjustment itself, on the small preset and a larger block (``--strips``,
   ``--lines``).
2. Blunders: ``--seeds`` copies of a 2-strip and a 3-strip block (60 % sidelap: tie points in three
   strips) with 6 blunders of 10-30 px each in image measurements of distinct control, height and
   tie points; counted: blunders whose measurement has a finite MDB, of those caught (rejected itself
   or its point removed as not separable), separable rejections of a good measurement (blamed), and
   rejections on the clean block (false alarms).

3. ``--vienna``: false alarms on the simulated vienna2000 block (3 strips x 7,000 lines, no
   blunders) with S (the middle strip split at lines 2400 and 4900, DTM heights) and BE.

4. ``--scaling 12 24 48``: the external reliability of block24 cut to that many strips
   (``--lines`` lines each, SE), over every row (a solve with the whole factor and a product with
   every row, per strip) against the near rows (the windows of
   :mod:`scangeo.adjustment.neighbourhoods`, partial solves), side by side in this process: CPU
   seconds of each (``time.process_time``: less sensitive to a shared machine than wall time) and
   the largest relative difference of the strips' largest shifts, of the shifts at every probe
   position and of the per-observation figures (``ext_orientation_m``).

Run:  python tests/benchmarks/reliability.py [--seeds 3] [--strips 4 --lines 1500] [--vienna]
      python tests/benchmarks/reliability.py --scaling 12 24 48 --lines 1500
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from scangeo.adjustment.reliability_summary import variant_reliability  # noqa: E402
from scangeo.adjustment.results import run_variant  # noqa: E402
from tests.adjustment.test_block import SHIFT_ONLY, _simulate  # noqa: E402
from tests.adjustment.test_reliability import VARIANT, _detectable, inject  # noqa: E402


def adjusted_with_reliability(root: Path, variant):
    """(result, reliability, seconds of the adjustment, seconds of the reliability figures)."""
    t = time.perf_counter()
    result = run_variant(root, variant)
    t_adj = time.perf_counter() - t
    t = time.perf_counter()
    vr = variant_reliability(result)
    return result, vr, t_adj, time.perf_counter() - t


def cost(root: Path, label: str) -> None:
    result, vr, t_adj, t_rel = adjusted_with_reliability(root, VARIANT)
    acc = result.adjustment.statistics.accounting
    rows = sum(int((r == r).sum()) for r in vr.reliability.mdb)
    print(f"{label}: {acc.observations} observations, {acc.unknowns} unknowns; adjustment {t_adj:.2f} s, "
          f"reliability of {rows} rows {t_rel:.2f} s ({t_rel / t_adj:.2f}x the adjustment)")


def blunders(root: Path, seeds: int, label: str, work: Path) -> None:
    clean = run_variant(root, VARIANT)
    n_points = len({str(p) for g in clean.adjustment.solution.groups if g.kind == "observation" for p in g.ids})
    caught = detectable = blamed = non_sep = sep = 0
    for seed in range(seeds):
        truth = inject(root, work / f"{label}{seed}", seed)
        result = run_variant(work / f"{label}{seed}", VARIANT)
        rej = result.adjustment.rejections
        for p, s in _detectable(clean, truth):
            detectable += 1
            caught += any(r.id == p and (not r.separable or r.group == f"image {s}") for r in rej)
        for r in rej:
            non_sep += not r.separable
            sep += r.separable
            blamed += r.separable and not (r.group.startswith("image ") and (r.id, r.group[6:]) in truth)
    print(f"{label}: {seeds} seeds x 6 blunders: {detectable} with a finite MDB, {caught} caught "
          f"({100 * caught / max(detectable, 1):.0f} %), {sep} rejected as separable, {non_sep} points removed as "
          f"not separable, {blamed} good measurements blamed; clean block: {len(clean.adjustment.rejections)} "
          f"rejections of {n_points} points")


def false_alarms(root: Path) -> None:
    from scangeo.adjustment.variants import StripModels, Variant
    from scangeo.simulate.block import simulate
    from scangeo.simulate.config import load_preset

    simulate(root, load_preset("vienna2000", {"output": {"images": False, "truth_ortho": False}}))
    ground = root / "ground.csv"
    ground.write_text(ground.read_text().replace(",0,0.1,height", ",1,0.1,height"))
    split = StripModels("02", position_degree=2, breaks_lines=(2400.0, 4900.0))
    for v in (Variant("S", "S", strips=(split,), dtm_heights=True), Variant("BE", "BE")):
        r, vr, t_adj, t_rel = adjusted_with_reliability(root, v)
        points = {str(p) for g in r.adjustment.solution.groups if g.kind == "observation" and g.snooped for p in g.ids}
        rej = r.adjustment.rejections
        rows = sum(a.size for a, g in zip(vr.status, r.adjustment.solution.groups) if g.kind == "observation")
        print(f"vienna2000 {v.name}: {len(rej)} rejections ({sum(not x.separable for x in rej)} not separable) of "
              f"{len(points)} points ({100 * len(rej) / len(points):.1f} %): {[(x.group, x.id) for x in rej]}; "
              f"adjustment {t_adj:.1f} s, reliability of {rows} rows {t_rel:.1f} s")


def scaling(sizes: list[int], lines: int, work: Path) -> None:
    """Exact against local external reliability on block24 cut to each size (CPU seconds)."""
    import os
    import warnings

    from scangeo.adjustment.keys import Ground
    from scangeo.adjustment.reliability_summary import strip_probes
    from scangeo.lsq.reliability import compute_reliability
    from scangeo.simulate.block import simulate
    from scangeo.simulate.config import config_from_dict
    from tests.benchmarks.block import block_config

    rows = []
    for n in sizes:
        _, data = block_config(lines)
        data["flight"]["strips"] = n
        data["output"]["images"] = False
        cfg = config_from_dict(data, source=f"block24, {n} strips")
        root = work / f"b{n}"
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            simulate(root, cfg)
        result = run_variant(root, "SE")
        sol, st = result.adjustment.solution, result.adjustment.statistics
        st.redundancy_numbers()      # the selected inverse, shared by both
        cpu = {}
        rel = {}
        for name, radius in (("every", None), ("near", 2)):
            t = time.process_time()
            probes = strip_probes(result, radius=radius)
            rel[name] = compute_reliability(sol, st, probes, point_key=Ground)
            cpu[name] = time.process_time() - t
        e, o = rel["every"], rel["near"]
        strip = max(abs(o.ext_strip[k][0] / e.ext_strip[k][0] - 1) for k in e.ext_strip)
        positions = max(float(np.max(np.abs(o.ext_positions[k] / e.ext_positions[k] - 1))) for k in e.ext_positions)
        rows_diff = max(float(np.nanmax(np.abs(b / a - 1), initial=0.0)) for a, b in zip(e.ext_orientation_m,
                                                                                         o.ext_orientation_m))
        rows.append((n, sol.layout.n, cpu["every"], cpu["near"], strip))
        print(f"{n} strips ({sol.layout.n} unknowns): every row {cpu['every']:.1f} CPU s, near rows "
              f"{cpu['near']:.1f} CPU s; relative difference: largest shift per strip {strip:.1e}, per probe "
              f"position {positions:.1e}, per observation {rows_diff:.1e}; load {os.getloadavg()[0]:.1f}", flush=True)
    n0, _, e0, l0, _ = rows[0]
    print(f"ratios to {n0} strips (linear: " + ", ".join(f"{n / n0:.0f}x" for n, *_ in rows[1:]) + "): "
          + "; ".join(f"{n}: every row {e / e0:.2f}x, near rows {lo / l0:.2f}x" for n, _, e, lo, _ in rows[1:]))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--strips", type=int, default=4)
    ap.add_argument("--lines", type=int, default=1500)
    ap.add_argument("--vienna", action="store_true", help="also the false alarms on vienna2000 (a few minutes)")
    ap.add_argument("--scaling", type=int, nargs="+", default=None, help="block sizes (strips) for part 4")
    a = ap.parse_args()
    if a.scaling:
        with tempfile.TemporaryDirectory() as tmp:
            scaling(a.scaling, a.lines, Path(tmp))
        return
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        if a.vienna:
            false_alarms(work / "vienna")
        two = _simulate(work / "two", SHIFT_ONLY)
        three = _simulate(work / "three", {**SHIFT_ONLY, "flight": {"strips": 3, "sidelap": 0.6, "lines": 400},
                                           "points": {"tie_per_overlap": 12, "control_band_lines": 60.0}})
        big = _simulate(work / "big", {**SHIFT_ONLY, "flight": {"strips": a.strips, "lines": a.lines}})
        run_variant(two, VARIANT)  # compile once
        cost(two, "small (2 strips x 600 lines)")
        cost(big, f"{a.strips} strips x {a.lines} lines")
        blunders(two, a.seeds, "2 strips", work)
        blunders(three, a.seeds, "3 strips, 60 % sidelap", work)


if __name__ == "__main__":
    main()
