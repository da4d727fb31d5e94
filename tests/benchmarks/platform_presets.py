"""Benchmark: the criteria of the platform presets, measured against the simulated truth.

Two pushbrooms (``pushbroom_pair``), the SWIR without any control: per variant the true ground error
(``scangeo.truth``, rms over the strips' sample grids) of each sensor in the joint adjustment, their ratio
(the criterion: SWIR within 1.5 x VNIR), and the relative boresight against the truth; by the tie points
alone and with a relative-mounting prior (0.005, 0.005, 0.01 deg).

A laser and an imager (``platform``, control on one third of the flight lines): the image strips' true
ground error of the imager alone and of the joint adjustment (``scangeo.lidar.joint``), and the laser's
strip differences on flat cells and check patches alone and joint. CPU seconds of each step, in this
process.

Run:  python tests/benchmarks/platform_presets.py [--full] [--seeds 40 41 ...] [--snooping]
      (default: the _quick presets, their own seeds, data snooping off: on the SE variants the laser's
      anchors keep the GPS/IMU's height wander, which SE cannot follow, and snooping then removes
      about 170 units in 99 rounds on platform_quick: five minutes of CPU per variant)
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import tempfile
import time
from pathlib import Path

import numpy as np

from scangeo.adjustment.results import run_variant
from scangeo.adjustment.variants import Variant
from scangeo.io.project import Project
from scangeo.lidar.adjust import build, run
from scangeo.lidar.evaluation import apply, evaluate
from scangeo.lidar.joint import laser_part, run_joint
from scangeo.lidar.options import LaserOptions
from scangeo.simulate.block import simulate
from scangeo.simulate.config import load_preset
from scangeo.truth.true_error import Truth


def variants(snooping: bool) -> list[Variant]:
    common = dict(attitude_degree=-1, calibrate=("boresight",), snooping=snooping)
    return [Variant("SE_B", "SE", **common), Variant("SE_B_GPS", "SE", constant_sigma_m=1.0, **common),
            Variant("P1_B_GPS", "P", position_degree=1, constant_sigma_m=1.0, **common),
            Variant("P2_B_GPS", "P", position_degree=2, constant_sigma_m=1.0, **common)]


def _errors(project: Project, truth: Truth, result) -> dict[str, float]:
    return {sid: truth.error(sid, result.geometry(sid)).rms_ground_m for sid in truth.geometries}


def _rms(values) -> float:
    return float(np.sqrt(np.mean(np.square(list(values)))))


def pair(root: Path, seed: int | None, full: bool, snooping: bool) -> None:
    for prior in (False, True):
        over: dict = {"output": {"images": False, "truth_ortho": False}}
        if prior:
            over["platform"] = {"relative_mountings": [{"sensor": "swir", "reference": "vnir",
                                                        "boresight_sigma_deg": [0.005, 0.005, 0.01]}]}
        config = load_preset("pushbroom_pair" if full else "pushbroom_pair_quick", over)
        sensors = tuple(dataclasses.replace(s, measures_control=s.id != "swir") for s in config.platform.sensors)
        config = dataclasses.replace(config, platform=dataclasses.replace(config.platform, sensors=sensors))
        out = root / f"pair_{prior}"
        block = simulate(out, config, seed=seed)
        project = Project.load(out)
        truth = Truth.load(project)
        true_rel = json.loads((out / "truth" / "errors.json").read_text())["true_relative_mountings"][0]
        print(f"pushbroom_pair{'' if full else '_quick'} seed {block.seed}, SWIR without control, "
              f"{'with a relative-mounting prior' if prior else 'ties only'}:")
        for v in variants(snooping):
            t0 = time.process_time()
            result = run_variant(project, v)
            errors = _errors(project, truth, result)
            by = {s: _rms(e for sid, e in errors.items() if sid.startswith(s + "-")) for s in ("vnir", "swir")}
            (rel,) = result.relative_mountings()
            d = np.degrees(rel.boresight) - true_rel["boresight_deg"]
            ratio = by["swir"] / by["vnir"]
            print(f"  {v.name:9s} VNIR {by['vnir']:.3f} m  SWIR {by['swir']:.3f} m  ratio {ratio:.2f}  "
                  f"relative boresight - truth {d[0]:+.4f} {d[1]:+.4f} {d[2]:+.4f} deg  "
                  f"(per strip: {' '.join(f'{k} {e:.3f}' for k, e in errors.items())})  "
                  f"{time.process_time() - t0:.1f} CPU s", flush=True)


def platform(root: Path, seed: int | None, full: bool, snooping: bool) -> None:
    config = load_preset("platform" if full else "platform_quick", {"output": {"images": False, "truth_ortho": False}})
    t0 = time.process_time()
    block = simulate(root / "platform", config, seed=seed)
    print(f"platform{'' if full else '_quick'} seed {block.seed}: simulated in {time.process_time() - t0:.1f} CPU s "
          f"({sum(s.returns for s in block.laser_strips)} returns)", flush=True)
    project = Project.load(root / "platform")
    truth = Truth.load(project)
    found = None
    for v in variants(snooping):
        t0 = time.process_time()
        alone = _errors(project, truth, run_variant(project, v))
        t1 = time.process_time()
        joint = run_joint(project, v, found=found)
        found = joint.block.laser.found
        t2 = time.process_time()
        mine = _errors(project, truth, joint.images)
        view = laser_part(project)
        options = LaserOptions.from_table(project.adjustment, str(project.file))
        lb = build(view, options, v, project.root / "patches.csv", found=found)
        la = run(lb)
        laser_alone = evaluate(lb, la, apply(lb, la.parameters.values())).summary()
        t3 = time.process_time()
        s = joint.laser.summary()
        flat, checks = "strip_differences_flat_rms_m", "check_patches_rms_m"
        print(f"  {v.name:9s} images: alone {_rms(alone.values()):.3f} m, joint {_rms(mine.values()):.3f} m "
              f"(ratio {_rms(mine.values()) / _rms(alone.values()):.2f}); laser flat differences "
              f"{s[flat]['before']:.3f} -> alone {laser_alone[flat]['after']:.3f}, joint {s[flat]['after']:.3f} m; "
              f"check patches {s[checks]['before']:.3f} -> alone {laser_alone[checks]['after']:.3f}, "
              f"joint {s[checks]['after']:.3f} m  (CPU s: imager {t1 - t0:.1f}, joint {t2 - t1:.1f}, "
              f"laser {t3 - t2:.1f})", flush=True)
        print(f"            per strip alone {' '.join(f'{k} {e:.3f}' for k, e in alone.items())}; "
              f"joint {' '.join(f'{k} {e:.3f}' for k, e in mine.items())}", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--full", action="store_true", help="the full presets instead of the _quick ones")
    parser.add_argument("--seeds", type=int, nargs="*", default=[None], help="seeds (default: the presets')")
    parser.add_argument("--snooping", action="store_true", help="data snooping on (slow on the SE variants)")
    parser.add_argument("--only", choices=("pair", "platform"), default=None)
    args = parser.parse_args()
    for seed in args.seeds:
        with tempfile.TemporaryDirectory() as tmp:
            if args.only in (None, "pair"):
                pair(Path(tmp), seed, args.full, args.snooping)
            if args.only in (None, "platform"):
                platform(Path(tmp), seed, args.full, args.snooping)


if __name__ == "__main__":
    main()
