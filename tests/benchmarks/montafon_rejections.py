"""What the montafon block's data snooping rejects besides the moved roofs, read against the simulator's truth.

Adjusts a simulated laser project (as ``tests/benchmarks/montafon.py``; simulates the preset first
when DIR has no project), then, for every tested observation unit (a patch in a strip: the three
combinations of its four anchors), compares:

- ``w``: the data-snooping statistic of the adjustment (largest |w| of the unit's three rows);
- ``e``: the same three combinations of the anchors' *true* errors, i.e. the anchors georeferenced
  with the true GPS/IMU errors and boresight minus the true surface under them (the scene's ground or
  roof), in units of the anchors' sigma: what the observation's error really is;
- ``c``: the curvature part: the true surface's deviation, at the unit's anchors, from the plane
  fitted (weighted, all the patch's members) to the true surface at every member's anchors, in the
  same units: what no plane can take up.

It prints the expected number of chance rejections (alpha of the critical value times the tested
rows), the rejections by cause, and the units' ``e`` by number of returns in the plane fit (the
anchors' sigma comes from the fit's a posteriori sigma, estimated from those returns).

Run:  python tests/benchmarks/montafon_rejections.py DIR [--laser KEY=VALUE ...] [--json OUT]
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
import time
import tomllib
from pathlib import Path

import numpy as np
from scipy.stats import norm

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from scangeo.adjustment.variants import laser_variant  # noqa: E402
from scangeo.io.project import Project  # noqa: E402
from scangeo.lidar.adjust import LaserOptions, anchor_points, build, run  # noqa: E402
from scangeo.lidar.groups import FOUR_TO_THREE, StripAnchors  # noqa: E402
from scangeo.lidar.planes import ANCHORS  # noqa: E402
from scangeo.resources import preset_file  # noqa: E402
from scangeo.simulate.laser import load_laser_config, simulate_laser  # noqa: E402
from scangeo.simulate.laser_plan import block_half_extent, valley_of  # noqa: E402
from scangeo.simulate.laser_scene import LaserScene  # noqa: E402
from tests.lidar.test_lidar_adjust import truth_values  # noqa: E402


def scene_of(cfg) -> LaserScene:
    """The simulation's scene, rebuilt from its seed as ``simulate_laser`` builds it first."""
    rng = np.random.default_rng(cfg.seed)
    if cfg.mission_strips:
        hx, hy = block_half_extent(cfg)
        bounds = (-hx - 300.0, -hy - 300.0, hx + 300.0, hy + 300.0)
    else:
        half = 0.5 * cfg.strip_length + 0.5 * cfg.height * np.tan(np.radians(cfg.fov_deg / 2)) + 50.0
        bounds = (-half, -half, half, half)
    return LaserScene.random(bounds, rng, cfg.building_spacing, cfg.building_fill, valley=valley_of(cfg),
                             building_scale=cfg.building_scale)


def patch_sag(scene: LaserScene, c: np.ndarray, size: float) -> float:
    """Largest deviation (m) of the terrain (without buildings) from its least-squares plane over a patch's
    box (a 9 x 9 grid over ``size`` x ``size`` around ``c``): how curved the ground under the patch is."""
    g = np.linspace(-size / 2, size / 2, 9)
    gx, gy = np.meshgrid(g, g)
    z = scene.ground(c[0] + gx.ravel(), c[1] + gy.ravel())
    A = np.column_stack([np.ones(z.size), gx.ravel(), gy.ravel()])
    return float(np.abs(z - A @ np.linalg.lstsq(A, z, rcond=None)[0]).max())


def units_table(block, result, truth, scene) -> dict[str, np.ndarray]:
    """One row per tested unit (tie, control and height patches in a strip)."""
    true = truth_values(block, truth)
    w_all = result.statistics.w_tests()
    centre = dict(zip(block.frames.ids, block.frames.c0))
    moved = [(m["strip"], m["x"], m["y"]) for m in truth["moved_roofs"]]
    rows: dict[str, list] = {k: [] for k in ("strip", "patch", "kind", "w", "rejected", "e", "c", "sigma",
                                             "count", "members", "moved", "e3", "x", "y", "slope", "sag", "roof")}
    # per patch: the true surface at every member's anchors, to fit the best plane through them
    anchors_true: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
    surface: dict[int, list] = {}
    for sid, a in block.anchors.items():
        p_true = anchor_points(block, sid, true)                 # work frame = the scene's frame
        z_surf = scene.height(p_true[:, 0], p_true[:, 1])
        anchors_true[sid] = (p_true, z_surf, a["sigma"])
        for k in range(0, a["patch"].size, ANCHORS):
            surface.setdefault(int(a["patch"][k]), []).append((p_true[k:k + ANCHORS], z_surf[k:k + ANCHORS],
                                                               a["sigma"][k]))
    planes = {}
    for p, items in surface.items():
        xy = np.vstack([i[0][:, :2] for i in items])
        z = np.concatenate([i[1] for i in items])
        wgt = np.repeat([1.0 / i[2] for i in items], ANCHORS)
        A = np.column_stack([np.ones_like(z), xy - xy.mean(axis=0)])
        coef = np.linalg.lstsq(A * wgt[:, None], z * wgt, rcond=None)[0]
        planes[p] = (xy.mean(axis=0), coef)
    sags = {pid: patch_sag(scene, centre[pid], block.options.patch_size) for pid in block.frames.ids}
    count = {}
    for tie in block.ties:
        for sid, i in tie.members:
            count[(sid, tie.id)] = int(block.found[sid].patches.planes.count[i])
    members = {tie.id: len(tie.members) for tie in block.ties}
    for group, w, act in zip(result.solution.groups, w_all, result.solution.active):
        if not isinstance(group, StripAnchors):
            continue
        sid = group.strip
        p_true, z_surf, sig_a = anchors_true[sid]
        a = block.anchors[sid]
        for u in np.unique(group.row_unit):
            sel = group.row_unit == u
            pid = str(group.ids[sel][0])
            p = block.frames.ids.index(pid)
            k = np.flatnonzero(a["patch"] == p)[:ANCHORS]
            nz = block.frames.n0[p][2]
            err = (p_true[k, 2] - z_surf[k]) * nz / sig_a[k]           # anchors' true normal errors / sigma
            mean, coef = planes[p]
            z_plane = coef[0] + (p_true[k, :2] - mean) @ coef[1:]
            curv = (z_surf[k] - z_plane) * nz / sig_a[k]
            rows["strip"].append(sid)
            rows["patch"].append(pid)
            rows["kind"].append(block.kinds[p])
            rows["w"].append(float(np.nanmax(np.abs(w[sel]))) if np.isfinite(w[sel]).any() else np.nan)
            rows["rejected"].append(not act[sel].all())
            rows["e"].append(float(np.abs(err @ FOUR_TO_THREE).max()))
            rows["e3"].append(err @ FOUR_TO_THREE)
            rows["c"].append(float(np.abs(curv @ FOUR_TO_THREE).max()))
            rows["sigma"].append(float(sig_a[k[0]]))
            rows["count"].append(count.get((sid, pid), -1))
            rows["members"].append(members.get(pid, 0))
            c = centre[pid]
            rows["moved"].append(any(s == sid and np.hypot(c[0] - x, c[1] - y) < 25.0 for s, x, y in moved))
            rows["x"].append(float(c[0]))
            rows["y"].append(float(c[1]))
            rows["slope"].append(float(np.degrees(np.arctan(scene.slope_at(np.array([c[0]]), np.array([c[1]]))[0]))))
            rows["sag"].append(sags[pid])
            rows["roof"].append(bool(scene.building_at(np.array([c[0]]), np.array([c[1]]))[0][0] >= 0))
    table = {k: np.asarray(v) for k, v in rows.items()}
    # data snooping's decisions: one per rejection (a patch in two strips goes whole: its two units are
    # one decision, a non-separable rejection)
    decided = {(r.group.removeprefix("anchors "), r.id) for r in result.rejections}
    table["decision"] = np.array([(s, p) in decided for s, p in zip(table["strip"], table["patch"])])
    return table


def report(t: dict[str, np.ndarray], crit: float) -> dict:
    alpha = 2 * norm.sf(crit)
    tested = np.isfinite(t["w"])
    n_rows = 3 * int(tested.sum())
    expected = alpha * n_rows
    other = t["decision"] & ~t["moved"]
    out = {
        "alpha": alpha, "critical_value": crit, "tested_units": int(tested.sum()), "tested_rows": n_rows,
        "expected_chance_rejections": expected, "rejected": int(t["decision"].sum()),
        "rejected_units": int(t["rejected"].sum()),
        "rejected_moved": int((t["decision"] & t["moved"]).sum()), "rejected_other": int(other.sum()),
        "true_error_beyond_crit": int((tested & ~t["moved"] & (t["e"] > crit)).sum()),
        "curvature_beyond_1": int((tested & (t["c"] > 1.0)).sum()),
    }
    print(f"alpha {alpha:.2e} (|w| > {crit}), {out['tested_units']} tested units ({n_rows} rows): "
          f"{expected:.1f} chance rejections expected, 3x: {3 * expected:.1f}")
    print(f"rejected {out['rejected']} ({out['rejected_units']} units): {out['rejected_moved']} in the moved roofs' "
          f"strips, {out['rejected_other']} others")
    good = tested & ~t["moved"]
    print(f"units whose true error (anchors against the true surface, true parameters) exceeds {crit} sigma: "
          f"{out['true_error_beyond_crit']} of {int(good.sum())}; of the rejected others: "
          f"{int((other & (t['e'] > crit)).sum())}")
    print(f"curvature part (true surface off the best plane) above 1 sigma: {out['curvature_beyond_1']} units; "
          f"of the rejected others: {int((other & (t['c'] > 1.0)).sum())}")
    for kind in ("tie", "control", "height"):
        s = good & (t["kind"] == kind)
        print(f"  {kind:8s} units {int(s.sum()):6d}, rejected {int((s & t['decision']).sum()):4d}")
    print("by the curvature part c (true surface off the best plane through every member's anchors, in sigmas): "
          "units, rejected, per 1000, median sag of the terrain over the patch (cm), median slope (deg), on roofs")
    classes = []
    for lo, hi in ((0.0, 0.5), (0.5, 1.0), (1.0, 2.0), (2.0, np.inf)):
        s = good & (t["c"] >= lo) & (t["c"] < hi)
        if s.any():
            n, r = int(s.sum()), int((s & t["decision"]).sum())
            classes.append([lo, hi, n, r, float(np.median(t["sag"][s])), float(np.median(t["slope"][s])),
                            int((s & t["roof"]).sum())])
            print(f"  {lo:3.1f}-{hi:<4.1f} {n:6d} {r:5d} {1000 * r / n:6.1f}   {100 * classes[-1][4]:5.2f} cm "
                  f"{classes[-1][5]:5.1f} deg {classes[-1][6]:5d}")
    out["by_curvature"] = classes
    edges = [13, 16, 20, 30, 50, 100, 1_000_000]
    print("by returns in the strip's plane fit (tie patches): units, rejected, true error > crit, rms of the true "
          "errors' combinations in sigmas (the 1 % largest left out)")
    bins = []
    for lo, hi in zip(edges[:-1], edges[1:]):
        s = good & (t["kind"] == "tie") & (t["count"] >= lo) & (t["count"] < hi)
        if s.any():
            e3 = np.abs(t["e3"][s]).ravel()
            e3 = np.sort(e3)[: int(np.ceil(0.99 * e3.size))]
            rms = float(np.sqrt(np.mean(e3**2)) / 0.9613)  # the rms of a normal variable's 99 % smallest |x|
            bins.append([lo, hi, int(s.sum()), int((s & t["decision"]).sum()), int((s & (t["e"] > crit)).sum()), rms])
            print(f"  {lo:5d}-{hi:<7d} {int(s.sum()):6d} {int((s & t['decision']).sum()):5d} "
                  f"{int((s & (t['e'] > crit)).sum()):5d}   {rms:.2f}")
    out["by_count"] = bins
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dir", type=Path)
    parser.add_argument("--laser", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument("--json", type=Path, help="write the per-unit table and the summary here")
    args = parser.parse_args()
    logging.getLogger("scangeo.lsq.solver").setLevel(logging.ERROR)
    root = args.dir
    overrides = {k: tomllib.loads(f"v = {v}")["v"] for k, v in (a.split("=", 1) for a in args.laser)}
    cfg = load_laser_config(preset_file("montafon"), overrides)
    if not (root / "project.toml").exists():
        simulate_laser(root, cfg)
    saved = json.loads((root / "truth.json").read_text())
    if saved["config"] != json.loads(json.dumps(cfg.__dict__ if not hasattr(cfg, "__dataclass_fields__")
                                                else __import__("dataclasses").asdict(cfg))):
        print("note: DIR was simulated with another configuration than --laser gives; the scene may differ")
    t0 = time.process_time()
    project = Project.load(root)
    options = LaserOptions.from_table(project.adjustment, str(root / "project.toml"))
    block = build(project, options, laser_variant(), root / "ground.csv")
    result = run(block)
    print(f"set-up and adjustment {time.process_time() - t0:.0f} s CPU; sigma0 {result.statistics.sigma0:.3f}")
    table = units_table(block, result, saved["truth"], scene_of(cfg))
    summary = report(table, block.variant.critical_value)
    if args.json:
        args.json.write_text(json.dumps({"summary": summary, "units": {k: v.tolist() for k, v in table.items()}}))


if __name__ == "__main__":
    main()
