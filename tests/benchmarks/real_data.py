"""The two real HySpex lines of the shared data, imported from their PARGE status files: the figures of
docs/real-data.md.

Run: python tests/benchmarks/real_data.py [--data ../shared/data/hyspex] [--keep DIR]

For each line (SWIR-384, VNIR-1800):

1. **Conventions.** The imported project, then each convention replaced by its alternative (roll as
   stored, heading as a true heading, the look angles mirrored, no along-track look angle, 1-based
   pixels or lines, the GNSS altitude without PARGE's height offset, the time solved in the scan
   plane instead of the measured line's, a 0.2 s spline): PARGE's used GCPs sorted by line,
   alternately control and check, and the check rms (lines along, pixels across) of PARGE's boresight
   held fixed and of BORESIGHT (three angles fitted to the control). A wrong convention shows at the
   check points even after the fit.
2. **Variants.** PARGE, BORESIGHT and CALIBRATED on that split, beside the independent three-angle fit
   in the map grid (tests/importers/reference_fit.py): check rms, the calibration found (change from
   PARGE's boresight +- sigma) and the test_calibration decisions.
3. **scangeo run** on the import as written (PARGE's used GCPs control, the unused ones check):
   cleaning, cross-validated rms of every variant, the recommendation.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import math
import re
import shutil
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

warnings.simplefilter("ignore")
HERE = Path(__file__).resolve()
sys.path.insert(0, str(HERE.parents[2]))

from scangeo.importers.parge import import_parge  # noqa: E402
from scangeo.io.points import ImagePoints  # noqa: E402
from scangeo.trajectory.readers import read_trajectory_csv, write_trajectory_csv  # noqa: E402
from scangeo.workflow import adjust  # noqa: E402
from tests.importers.reference_fit import alternate_split, reference_check_rms  # noqa: E402

LINES = {"SWIR": "20200522_Husky_SWIR_boresight_IFSAR.gcs", "VNIR": "20200522_Husky_VNIR_boresight_IFSAR.gcs"}


def _edit_trajectory(root: Path, change) -> None:
    path = next((root / "nav").glob("*.csv"))
    write_trajectory_csv(path, change(read_trajectory_csv(path)))


def _edit_points(root: Path, dline: float, dpixel: float) -> None:
    p = ImagePoints.read(root / "points.csv")
    dataclasses.replace(p, line=p.line + dline, pixel=p.pixel + dpixel).write(root / "points.csv")


def _edit_look_angles(root: Path, column: int, factor: float) -> None:
    path = root / "sensor" / "look_angles.csv"
    rows = [line.split(",") for line in path.read_text().splitlines()]
    for r in rows[1:]:
        r[column] = repr(float(r[column]) * factor)
    path.write_text("\n".join(",".join(r) for r in rows) + "\n")


def _edit_toml(root: Path, pattern: str, replacement: str) -> None:
    path = root / "project.toml"
    text, n = re.subn(pattern, replacement, path.read_text(), flags=re.M)
    assert n == 1, pattern
    path.write_text(text)


def _convergence(root: Path) -> float:
    record = json.loads((root / "import.json").read_text())
    return record.get("mean_convergence_deg", -0.7665)


ALTERNATIVES = {
    "as imported": lambda r: None,
    "roll as stored (not negated)": lambda r: _edit_trajectory(r, lambda s: dataclasses.replace(s, roll=-s.roll)),
    "heading taken as true (no convergence)": lambda r: _edit_trajectory(
        r, lambda s: dataclasses.replace(s, heading=s.heading - np.radians(_convergence(r)))),
    "convergence with the other sign": lambda r: _edit_trajectory(
        r, lambda s: dataclasses.replace(s, heading=s.heading + np.radians(_convergence(r)))),
    "look angles mirrored (across = +vinkelx)": lambda r: _edit_look_angles(r, 2, -1.0),
    "no along-track look angle": lambda r: _edit_look_angles(r, 1, 0.0),
    "pixels 1-based": lambda r: _edit_points(r, 0.0, -1.0),
    "lines 1-based": lambda r: _edit_points(r, -1.0, 0.0),
    "GNSS altitude as orthometric (N = 0)": lambda r: _edit_toml(r, r"^geoid_undulation_m = .*$",
                                                                 "geoid_undulation_m = 0.0"),
    "time solved in the scan plane": lambda r: _edit_toml(r, r'^measurement_time = "line".*$',
                                                          'measurement_time = "scan_plane"'),
    "a 0.2 s spline (not a knot per record)": lambda r: _edit_toml(r, r"^knot_spacing_s = .*$",
                                                                   "knot_spacing_s = 0.2"),
}


def split_variants(status: Path, root: Path) -> Path:
    """The alternate split of PARGE's used GCPs as roles in a copy of the import's variants.toml."""
    import scipy.io

    gcp = scipy.io.readsav(str(status), python_dict=True)["gcparr"]
    control, check = alternate_split(gcp)
    width = max(2, len(str(len(gcp))))
    roles = {"*": "ignore", **{f"GCP{k + 1:0{width}d}": "control" for k in control},
             **{f"GCP{k + 1:0{width}d}": "check" for k in check}}
    table = ", ".join(f'"{k}" = "{v}"' for k, v in roles.items())
    text = (root / "variants.toml").read_text().replace("[defaults]\n", f"[defaults]\nroles = {{{table}}}\n", 1)
    path = root / "split.toml"
    path.write_text(text)
    return path


def check_rms(root: Path, variant: str, variants: Path) -> tuple[float, float, object]:
    a = adjust(root, variant, variants_file=variants)
    (strip,) = a.result.rms_per_strip().values()
    return strip["check"]["rms_along_lines"], strip["check"]["rms_across_px"], a


def conventions(status: Path, base: Path, work: Path) -> None:
    print(f"  {'convention':42s} {'PARGE fixed':>16s} {'BORESIGHT fitted':>18s}   lines / px at the check points")
    for name, change in ALTERNATIVES.items():
        root = work / re.sub(r"\W+", "_", name)
        shutil.copytree(base, root)
        change(root)
        variants = split_variants(status, root)
        try:
            pa, pp, _ = check_rms(root, "PARGE", variants)
            ba, bp, _ = check_rms(root, "BORESIGHT", variants)
            print(f"  {name:42s} {pa:7.2f} / {pp:6.2f}   {ba:8.2f} / {bp:6.2f}")
        except Exception as exc:  # a wrong convention may not even converge: say so
            print(f"  {name:42s} failed: {exc}")


def variants_table(status: Path, base: Path, work: Path) -> None:
    root = work / "variants"
    shutil.copytree(base, root)
    variants = split_variants(status, root)
    (ra, rp), bs = reference_check_rms(status)
    print(f"  {'reference three-angle fit (map grid)':42s} {ra:7.3f} / {rp:6.3f}  hypot {math.hypot(ra, rp):.3f}  "
          f"boresight {np.round(np.degrees(bs), 4)} deg (relative to the arrays)")
    for v in ("PARGE", "BORESIGHT", "CALIBRATED"):
        a, p, adjusted = check_rms(root, v, variants)
        cal = json.loads((root / "results" / v / "report.json").read_text())["calibration"]
        found = ", ".join(f"{q['name']} {q['change']:+.4f} +- {q['sigma']:.4f}" for q in cal["parameters"]
                          if q["name"].startswith("boresight"))
        tests = ", ".join(f"{t['name']} t={t['t']:.2f}{'' if t['kept'] else ' fixed'}" for t in cal["tests"])
        print(f"  {v:42s} {a:7.3f} / {p:6.3f}  hypot {math.hypot(a, p):.3f}  sigma0 "
              f"{adjusted.result.adjustment.statistics.sigma0:.3f}  {found or ''}  {tests}")


def _ground_roles(root: Path):
    from scangeo.io.points import GroundPoints

    g = GroundPoints.read(root / "ground.csv")
    return g.point, g.role


def run_figures(base: Path, work: Path) -> None:
    from scangeo.pipeline.run import run

    root = work / "run"
    shutil.copytree(base, root)
    result = run(root)
    comparison = json.loads((root / "results" / "comparison.json").read_text())
    cleaning = json.loads((root / "results" / "cleaning" / "cleaning.json").read_text())
    roles = {str(p): str(r) for p, r in zip(*_ground_roles(root))}
    removed = sorted({m["point"] for m in cleaning["measurements_rejected"]})
    unused = sum(roles.get(p) == "check" for p in removed)
    print(f"  cleaning: sigma0 {cleaning['sigma0_before']} -> {cleaning['sigma0_after']}, {len(removed)} GCPs set "
          f"aside, {unused} of them PARGE's unused: {', '.join(removed)}")
    cv = comparison["crossvalidation"]
    for v in comparison["variants"]:
        (strip,) = v["strips"].values()
        ch = strip.get("check", {})
        print(f"  {v['name']:12s} cv {cv['rms_px'].get(v['name'], math.nan):.3f} px   check (PARGE's unused GCPs, "
              f"n={ch.get('n')}) {ch.get('rms_along_px', math.nan):.2f} / {ch.get('rms_across_px', math.nan):.2f}")
    print(f"  recommended: {result.recommended} ({cv['reason']})")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=str(HERE.parents[3] / "shared" / "data" / "hyspex"),
                    help="folder of the PARGE status files")
    ap.add_argument("--keep", default=None, help="keep the projects in this folder")
    args = ap.parse_args()
    work = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="scangeo-real-"))
    for camera, name in LINES.items():
        status = Path(args.data) / name
        base = work / camera / "imported"
        result = import_parge(status, base)
        print(f"== {camera}: {status.name}")
        print(f"  line rate {result.line_rate_hz:.4f} Hz ({result.line_rate_source}); {result.geoid}")
        print(f"  PARGE's boresight in scangeo's convention: {np.round(result.boresight_deg, 4)} deg "
              f"({result.offsets.description})")
        for h in result.hypotheses:
            print(f"    {h.description:86s} {h.fit_px[0]:6.2f} lines {h.fit_px[1]:6.2f} px")
        print(" conventions (alternate split of PARGE's used GCPs):")
        conventions(status, base, work / camera)
        print(" variants (alternate split):")
        variants_table(status, base, work / camera)
        print(" scangeo run (PARGE's used GCPs control, unused check):")
        run_figures(base, work / camera)
    if not args.keep:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
