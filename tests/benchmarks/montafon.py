"""The montafon preset at full size (its acceptance figures; docs/lidar.md section 6.5a): figures, not timings.

Simulates the preset into DIR when DIR has no project yet (``--set``-like overrides with ``--laser
KEY=VALUE``), finds the patches, adjusts (the preset's ``[adjustment]``: strip models under
preventive regularisation), and prints: how many strips the tie patches lie in; every injected
strip parameter (the mission's shift and misalignment included) and the boresight against the
estimate in units of its sigma; the flat strip differences before, after and with the true
parameters applied (the noise floor); whether each moved roof's patch was rejected by data snooping;
CPU time and peak memory.

Run:  python tests/benchmarks/montafon.py DIR [--laser pulse_rate_hz=4000 ...]
"""

from __future__ import annotations

import argparse
import json
import logging
import resource
import sys
import time
import tomllib
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from scangeo.adjustment.keys import Boresight  # noqa: E402
from scangeo.adjustment.variants import laser_variant  # noqa: E402
from scangeo.io.project import Project  # noqa: E402
from scangeo.lidar.adjust import LaserOptions, build, run  # noqa: E402
from scangeo.lidar.evaluation import apply, evaluate  # noqa: E402
from scangeo.orientation.models import Correction  # noqa: E402
from scangeo.resources import preset_file  # noqa: E402
from scangeo.simulate.laser import load_laser_config, simulate_laser  # noqa: E402
from tests.lidar.test_lidar_adjust import truth_values  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dir", type=Path)
    parser.add_argument("--laser", action="append", default=[], metavar="KEY=VALUE")
    args = parser.parse_args()
    logging.getLogger("scangeo.lsq.solver").setLevel(logging.ERROR)
    root = args.dir
    if not (root / "project.toml").exists():
        overrides = {k: tomllib.loads(f"v = {v}")["v"] for k, v in (a.split("=", 1) for a in args.laser)}
        t = time.process_time()
        simulate_laser(root, load_laser_config(preset_file("montafon"), overrides))
        print(f"simulated in {time.process_time() - t:.0f} s CPU")
    t0 = time.process_time()
    project = Project.load(root)
    block = build(project, LaserOptions.from_table(project.adjustment, str(root / "project.toml")), laser_variant(),
                  root / "ground.csv")
    t1 = time.process_time()
    result = run(block)
    t2 = time.process_time()
    truth = json.loads((root / "truth.json").read_text())["truth"]
    returns = sum(s["returns"] for s in truth["strips"].values())
    print(f"{len(truth['strips'])} strips, {returns / 1e6:.2f} M returns; set-up {t1 - t0:.0f} s, adjustment "
          f"{t2 - t1:.0f} s CPU")
    in_strips = np.array([len(t.members) for t in block.ties])
    print(f"tie patches {in_strips.size}, in up to {in_strips.max()} strips; per number of strips "
          f"{ {k: int(n) for k, n in enumerate(np.bincount(in_strips)) if n} }")
    print(f"patches: { {k: block.kinds.count(k) for k in ('tie', 'control', 'height', 'check')} }, "
          f"sigma0 {result.statistics.sigma0:.3f}, rejected {len(result.rejections)}")
    true = truth_values(block, truth)
    values, stats = result.parameters.values(), result.statistics
    keys = [Boresight()] + [Correction(s) for s in truth["strips"] if Correction(s) in values]
    z = {k: (values[k] - true[k]) / stats.sigmas(k) for k in keys}
    allz = np.abs(np.concatenate(list(z.values())))
    print(f"injected against estimated: {allz.size} parameters, largest |z| {allz.max():.2f}, "
          f"{int(np.sum(allz > 3))} beyond 3 sigma, {int(np.sum(allz > 2))} beyond 2")
    print(f"boresight error {np.round(np.degrees(values[Boresight()] - true[Boresight()]), 5)} deg, sigma "
          f"{np.round(np.degrees(stats.sigmas(Boresight())), 5)} deg")
    centre = dict(zip(block.frames.ids, block.frames.c0))
    for moved in truth["moved_roofs"]:
        hits = [r for r in result.rejections if r.group == f"anchors {moved['strip']}"
                and np.hypot(centre[r.id][0] - moved["x"], centre[r.id][1] - moved["y"]) < 25.0]
        print(f"moved roof {moved['building']} (strip {moved['strip']}, {moved['dz']} m): "
              + (f"rejected, w {max(r.w for r in hits):.1f}" if hits else "NOT rejected"))
    ev = evaluate(block, result, apply(block, values))
    noise = evaluate(block, result, apply(block, true))
    ratio = ev.after.rms(True) / noise.after.rms(True)
    print(f"flat strip differences: before {ev.before.rms(True) * 100:.2f} cm, after {ev.after.rms(True) * 100:.3f} "
          f"cm, true parameters (noise floor) {noise.after.rms(True) * 100:.3f} cm: {ratio:.3f} of the floor "
          f"({ev.before.dz.size} cell pairs)")
    summary = ev.summary()
    print(f"check patches {summary['check_patches_rms_m']['after'] * 100:.2f} cm, check points of control "
          f"patches {summary['control_check_points_rms_m']['after'] * 100:.2f} cm")
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024**2
    print(f"total {time.process_time() - t0:.0f} s CPU, peak memory {peak:.2f} GB")


if __name__ == "__main__":
    main()
