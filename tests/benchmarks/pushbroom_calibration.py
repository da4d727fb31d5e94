"""How well a pushbroom's own calibration is determined, beside which other unknowns (docs/adjustment.md).

Run: python tests/benchmarks/pushbroom_calibration.py [--keep DIR]

Simulates the ``pushbroom`` preset (3 strips x 600 lines x 384 px at ~700 m above ground, a true
detector calibration off the look-angle table by across_offset 0.05 deg, across_scale 0.004,
along_offset 0.08 deg; GPS/IMU without datum errors, no boresight error) and adjusts it with variants
that free more and more unknowns beside the three. For each: check-point rms (lines along, pixels
across), each calibration unknown's estimate +- sigma against the truth and its data share (1: the
observations alone determine it, 0: its prior does), and the largest correlations among the free
calibration unknowns and with the strips' GPS/IMU corrections (reports.correlations).
"""
from __future__ import annotations

import argparse
import json
import math
import tempfile
import warnings
from pathlib import Path

import numpy as np

warnings.simplefilter("ignore")

CAL = ("across_offset", "across_scale", "along_offset")
VARIANTS = {
    "GPSIMU, none": ({"position_degree": -1, "attitude_degree": -1}, ()),
    "GPSIMU, cal": ({"position_degree": -1, "attitude_degree": -1}, CAL),
    "GPSIMU, bore+cal": ({"position_degree": -1, "attitude_degree": -1}, ("boresight", *CAL)),
    "GPSIMU, bore+dt+cal": ({"position_degree": -1, "attitude_degree": -1}, ("boresight", "time_offset", *CAL)),
    "SE shifts, cal": ({"attitude_degree": -1}, CAL),
    "SE shifts, bore+dt+cal": ({"attitude_degree": -1}, ("boresight", "time_offset", *CAL)),
}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--keep", default=None, help="keep the simulated project in this folder")
    args = ap.parse_args()
    from scangeo.adjustment.calibration import calibration_summary
    from scangeo.adjustment.results import run_variant
    from scangeo.adjustment.variants import Variant
    from scangeo.reports.correlations import correlated_pairs
    from scangeo.simulate.block import simulate
    from scangeo.simulate.config import load_preset

    root = Path(args.keep or tempfile.mkdtemp(prefix="scangeo-pbcal-")) / "pushbroom"
    if not (root / "project.toml").exists():
        simulate(root, load_preset("pushbroom", {"output": {"images": False}}))
    err = json.loads((root / "truth" / "errors.json").read_text())["calibration_error"]
    truth = {"across_offset": err["across_offset_deg"], "across_scale": err["across_scale"],
             "along_offset": err["along_offset_deg"]}
    print(f"truth: {truth} (offsets in deg)")
    for label, (models, cal) in VARIANTS.items():
        r = run_variant(root, Variant(label, "SE", calibrate=cal, snooping=False, **models))
        ok = r.checks.status == 0
        rms = (math.sqrt(np.mean(r.checks.line[ok] ** 2)), math.sqrt(np.mean(r.checks.pixel[ok] ** 2)))
        s = calibration_summary(r)
        print(f"\n{label}: sigma0 {r.adjustment.statistics.sigma0:.2f}, check rms {rms[0]:.3f} lines / "
              f"{rms[1]:.3f} px, regularised {len(r.adjustment.solution.regularisation)}")
        for p in s["parameters"]:
            if p["calibrate"] in CAL:
                print(f"  {p['name']:<14}{p['value']:+.4f} +- {p['sigma']:.4f} (truth {truth[p['name']]:+.4f}), "
                      f"data share {p['data_share']:.3f}")
        names, m = s["correlation"]["names"], np.array(s["correlation"]["matrix"], float)
        for i, a in enumerate(names):
            for j in range(i + 1, len(names)):
                if (a in CAL or names[j] in CAL) and abs(m[i, j]) > 0.3:
                    print(f"  r({a}, {names[j]}) = {m[i, j]:+.3f}")
        for p in correlated_pairs(r, 0.8):
            if any(c.split(" ")[-1] in CAL for c in (p["a"], p["b"])) or "pushbroom" in p["a"] + p["b"]:
                print(f"  r(model {p['model']} {p['a']}, {p['b']}) = {p['r']:+.3f}")


if __name__ == "__main__":
    main()
