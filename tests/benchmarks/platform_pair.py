"""Two pushbrooms on one platform (the ``pushbroom_pair`` presets): the joint adjustment against each sensor
alone, a sensor without any control, and the co-registration's sigma against the true relative displacement.

Run: python tests/benchmarks/platform_pair.py [--preset pushbroom_pair_quick] [--seeds 40 41 ...] [--keep DIR]

Per seed:

1. **Each sensor alone, and jointly.** The simulated platform is adjusted as it is (both sensors) and, for
   each sensor, as a project of that sensor alone (its strips, its measurements, the same flight lines):
   the true ground error (``scangeo.truth``: the adjusted ray on the true terrain minus the true ground
   point, rms over a grid of every strip) per sensor.
2. **A sensor without control.** Every control measurement of the second sensor removed (its check and tie
   measurements kept): its true ground error against the first sensor's, in the joint adjustment, and with
   a relative-mounting prior (the true relative mounting) of 0.005/0.005/0.01 deg.
3. **Co-registration.** On a grid of every strip of the second sensor, the propagated 1-sigma relative
   displacement against its flight line's strip of the first sensor (``scangeo.adjustment.coregistration``)
   beside the true relative displacement there (where the two adjusted orientations put one ground point,
   the true ground points of the two pixels that see it, apart): the rms of their ratio (1 when the
   covariance is right), pooled over the strips and seeds.
"""
from __future__ import annotations

import argparse
import json
import re
import shutil
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

warnings.simplefilter("ignore")
sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from scangeo.adjustment.coregistration import coregistration  # noqa: E402
from scangeo.adjustment.results import run_variant  # noqa: E402
from scangeo.adjustment.variants import Variant  # noqa: E402
from scangeo.io.points import ImagePoints  # noqa: E402
from scangeo.io.project import Project  # noqa: E402
from scangeo.simulate.block import simulate  # noqa: E402
from scangeo.simulate.config import load_preset  # noqa: E402
from scangeo.truth.true_error import Truth  # noqa: E402

#: The joint variant: position corrections of degree 2 and attitude of degree 1 per flight line (the problem
#: line's excursions), every sensor's boresight calibrated.
VARIANT = Variant("P2B", "P", position_degree=2, attitude_degree=1, calibrate=("boresight",))


def _one_sensor(root: Path, out: Path, sensor: str) -> Path:
    """The platform's project of one sensor: its [[sensors]] entry, its strips, its measurements."""
    shutil.copytree(root, out, ignore=shutil.ignore_patterns("images", "results"))
    text = (out / "project.toml").read_text()
    blocks = re.split(r"(?m)^(?=\[\[)", text)
    keep = []
    for b in blocks:
        if b.startswith("[[sensors]]") and f'id = "{sensor}"' not in b:
            continue
        if b.startswith("[[strips]]") and f'sensor = "{sensor}"' not in b:
            continue
        if b.startswith("[[relative_mountings]]"):
            continue
        keep.append(b)
    (out / "project.toml").write_text("".join(keep))
    project = Project.load(out)
    ids = {s.id for s in project.strips}
    _keep_rows(out, lambda point, strip: strip in ids)
    roles = _roles(out)   # a tie point between the two sensors of a flight line is, alone, in one strip
    points = ImagePoints.read(out / "points.csv")
    seen: dict[str, set[str]] = {}
    for point, strip in zip(points.point.astype(str), points.strip.astype(str)):
        seen.setdefault(point, set()).add(strip)
    _keep_rows(out, lambda point, strip: point in roles or len(seen[point]) > 1)
    return out


def _keep_rows(root: Path, keep) -> None:
    points = ImagePoints.read(root / "points.csv")
    rows = (root / "points.csv").read_text().splitlines()
    kept = [rows[0]] + [rows[points.file_line[i] - 1] for i in range(len(points))
                        if keep(str(points.point[i]), str(points.strip[i]))]
    (root / "points.csv").write_text("\n".join(kept) + "\n")


def _roles(root: Path) -> dict[str, str]:
    lines = (root / "ground.csv").read_text().splitlines()
    head = lines[0].split(",")
    p, r = head.index("point"), head.index("role")
    return {c[p]: c[r] for c in (line.split(",") for line in lines[1:])}


def true_errors(root: Path, result) -> dict[str, float]:
    """Per sensor the rms true ground error (m) over its strips' sample grids."""
    project = Project.load(root)
    truth = Truth.load(project)
    out: dict[str, list[float]] = {}
    for sid in result.block.strips:
        e = truth.error(sid, result.geometry(sid))
        out.setdefault(project.strip(sid).sensor, []).append(e.rms_ground_m)
    return {s: float(np.sqrt(np.mean(np.square(v)))) for s, v in out.items()}


def coregistration_ratios(root: Path, result) -> np.ndarray:
    """|true relative displacement| / propagated sigma at every grid position of the co-registration."""
    project = Project.load(root)
    truth = Truth.load(project)
    dtm = project.dtm
    out = []
    for grid in coregistration(result):
        adj_s, adj_r = result.geometry(grid.strip), result.geometry(grid.reference)
        p_adj, st = adj_s.image_to_ground(grid.line, grid.pixel, dtm)
        l_r, p_r, st_r = adj_r.ground_to_image(p_adj)
        t_s, _ = truth.geometries[grid.strip].image_to_ground(grid.line, grid.pixel, truth.terrain)
        t_r, _ = truth.geometries[grid.reference].image_to_ground(l_r, p_r, truth.terrain)
        d = np.hypot(*(t_r[:, :2] - t_s[:, :2]).T)
        ok = (st == 0) & ((st_r & ~16) == 0) & np.isfinite(d) & (grid.sigma > 0)
        out.append(d[ok] / grid.sigma[ok])
    return np.concatenate(out) if out else np.zeros(0)


def run_seed(preset: str, seed: int, work: Path) -> dict:
    root = work / f"{preset}-{seed}"
    simulate(root, load_preset(preset, {"output": {"images": False, "truth_ortho": False}}), seed=seed)
    project = Project.load(root)
    sensors = list(project.sensors)
    first, second = sensors[0], sensors[1]
    joint = run_variant(root, VARIANT)
    row = {"seed": seed, "joint": true_errors(root, joint), "sigma0_joint": joint.adjustment.statistics.sigma0}
    for s in sensors:
        alone = run_variant(_one_sensor(root, work / f"{preset}-{seed}-{s}", s), VARIANT)
        row[f"{s}_alone"] = true_errors(work / f"{preset}-{seed}-{s}", alone)[s]
    ratios = coregistration_ratios(root, joint)
    row["coregistration_ratio_rms"] = float(np.sqrt(np.mean(ratios**2))) if ratios.size else None
    row["coregistration_n"] = int(ratios.size)
    # the second sensor without any control
    blind = work / f"{preset}-{seed}-blind"
    shutil.copytree(root, blind)
    roles = _roles(blind)
    ids = {s.id for s in project.strips if s.sensor == second}
    _keep_rows(blind, lambda point, strip: not (strip in ids and roles.get(point) in ("control", "planimetric",
                                                                                      "height")))
    result = run_variant(blind, VARIANT)
    row["blind"] = true_errors(blind, result)
    ratios_blind = coregistration_ratios(blind, result)
    row["blind_coregistration_ratio_rms"] = float(np.sqrt(np.mean(ratios_blind**2))) if ratios_blind.size else None
    row["blind_coregistration_ratio_n"] = int(ratios_blind.size)
    row["first"], row["second"] = first, second
    return row


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--preset", default="pushbroom_pair_quick")
    parser.add_argument("--seeds", type=int, nargs="+", default=[40])
    parser.add_argument("--keep", type=Path, help="keep the projects in this folder")
    args = parser.parse_args(argv)
    work = args.keep or Path(tempfile.mkdtemp(prefix="platform-pair-"))
    work.mkdir(parents=True, exist_ok=True)
    rows = []
    for seed in args.seeds:
        row = run_seed(args.preset, seed, work)
        rows.append(row)
        f, s = row["first"], row["second"]
        print(f"seed {seed}: true ground error rms (m): joint {f} {row['joint'][f]:.3f} {s} {row['joint'][s]:.3f}; "
              f"alone {f} {row[f + '_alone']:.3f} {s} {row[s + '_alone']:.3f}; {s} without control "
              f"{row['blind'][s]:.3f} ({row['blind'][s] / row['blind'][f]:.2f}x {f}'s {row['blind'][f]:.3f}); "
              f"co-registration ratio rms {row['coregistration_ratio_rms']:.2f} over {row['coregistration_n']}, "
              f"without control {row['blind_coregistration_ratio_rms']:.2f}", flush=True)
    print(json.dumps(rows, indent=1))
    if not args.keep:
        shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
