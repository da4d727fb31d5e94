"""Benchmark: scangeo's laser strip adjustment against pairwise ICP (Open3D), side by side, with known truth.

Run: python tests/benchmarks/peer_icp.py [--seed N] [--blocks laser montafon] [--work DIR] [--venv DIR]

The blocks (set-up, not timed; kept in ``--work`` and reused for the same seed):

* ``laser``: the ``laser`` preset (three parallel strips and a cross strip over flat ground and gable
  roofs, per strip a GPS shift and drift and an IMU offset and drift, a boresight error, 2 cm range
  noise; docs/lidar.md section 6.5);
* ``montafon``: the ``montafon`` preset at CI's reduced size (``tests/lidar/test_montafon.py``'s
  ``REDUCED``: two missions, 3 + 6 parallel strips and a cross strip each over 300 m of the alpine
  valley, 6 kHz; each mission's own GPS shift and IMU misalignment on top of the strips' errors).

Each tool runs in a child process of its own from the project's LAS files to corrected strips
written as LAZ, measured from outside (``os.wait4``: CPU seconds with its waited-for children, wall
seconds, peak resident memory):

* scangeo: the patch search, the strip adjustment of the recommended variant (``strip``: per strip
  degree 1 in position and attitude, the boresight, control patches, data snooping) and the corrected
  strips (``write_corrected``);
* ICP, in its own virtual environment (Open3D and laspy, ``peer_env.py``): the same strips and the
  same overlaps (the strip pairs that share tie patches, weighted by their number), a rigid transform
  per strip chained from a reference strip: the reference is the strip with the most shared tie
  patches; every other strip joins along a maximum spanning tree of the overlaps, registered by
  point-to-plane ICP (normals from 20 neighbours, its points cropped to the already aligned strip's
  box) onto that strip, with correspondence distances 3.0 then 1.5 m; its transform is
  applied to all its returns.

Then, against the simulator's truth (not timed): every return corrected with the injected errors
(``truth.json``, the adjustment's own model with the true values: the true point with its range
noise) and each tool's corrected return minus it: the **true error**, rms in 3D, horizontally and
vertically, and the same after the best rigid transform of the whole block onto the truth (the
block's relative error, which ICP without control can reach at best); the **flat strip differences**
as scangeo's laser report computes them (``lidar/differences.py``: planar cells of the corrected
strips, every pair of overlapping strips, flat cells only) on the cells and pairs all three states
share (before, scangeo, ICP), beside the same with the true corrections (the noise floor).
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

CORRESPONDENCE_M = (3.0, 1.5)
NEIGHBOURS = 20


# ---------------------------------------------------------------------------------------------
# set-up and evaluation (scangeo's environment)

def simulate_block(kind: str, root: Path, seed: int) -> None:
    from scangeo.resources import preset_file
    from scangeo.simulate.laser import load_laser_config, simulate_laser
    from tests.lidar.test_montafon import REDUCED

    overrides = dict(REDUCED) if kind == "montafon" else {}
    overrides["seed"] = seed
    simulate_laser(root, load_laser_config(preset_file(kind), overrides))


def load_block(root: Path):
    import logging

    from scangeo.adjustment.variants import laser_variant
    from scangeo.io.project import Project
    from scangeo.lidar.adjust import LaserOptions, build

    logging.getLogger("scangeo.lsq.solver").setLevel(logging.ERROR)
    project = Project.load(root)
    options = LaserOptions.from_table(project.adjustment, str(root / "project.toml"))
    return build(project, options, laser_variant(), root / "ground.csv")


def icp_plan(block, root: Path, out: Path, distances=CORRESPONDENCE_M) -> dict:
    """The strips, their overlaps (pairs sharing tie patches), the reference strip and the chain."""
    import numpy as np

    from scangeo.lidar.lasio import bounds

    ids = [s.id for s in block.project.strips]
    weight: dict[tuple[str, str], int] = {}
    for tie in block.ties:
        members = sorted({s for s, _ in tie.members})
        for i, a in enumerate(members):
            for b in members[i + 1:]:
                weight[(a, b)] = weight.get((a, b), 0) + 1
    total = {s: sum(w for (a, b), w in weight.items() if s in (a, b)) for s in ids}
    reference = max(ids, key=lambda s: (total[s], -ids.index(s)))
    joined, chain = {reference}, []
    while len(joined) < len(ids):  # Prim: the heaviest overlap from the aligned strips to a new one
        edges = [(w, a, b) for (a, b), w in weight.items() if (a in joined) != (b in joined)]
        if not edges:
            raise SystemExit(f"strips {sorted(set(ids) - joined)} share no tie patch with the others: no chain")
        w, a, b = max(edges)
        child, parent = (b, a) if a in joined else (a, b)
        chain.append([child, parent, w])
        joined.add(child)
    boxes = np.array([bounds(p) for s in block.project.strips for p in s.las])
    origin = [float(np.floor((boxes[:, 0].min() + boxes[:, 2].max()) / 2)),
              float(np.floor((boxes[:, 1].min() + boxes[:, 3].max()) / 2)), 0.0]
    return {
        "strips": {s.id: {"las": [str(p) for p in s.las], "point_source_id": s.point_source_id}
                   for s in block.project.strips},
        "overlaps": [[a, b, w] for (a, b), w in sorted(weight.items())], "reference": reference, "chain": chain,
        "origin": origin, "correspondence_m": list(distances),
        "neighbours": NEIGHBOURS, "out": str(out), "root": str(root),
    }


def strip_returns(strip, path=None):
    """(xyz map, t) of a strip's returns, from its LAS (or a corrected file of it)."""
    from scangeo.lidar.lasio import read_strip

    files = [path] if path is not None else list(strip.las)
    cloud = read_strip(strip.id, files, strip.point_source_id if path is None else None)
    return cloud.xyz, cloud.time


def planar_cells(block, sid: str, xyz, t):
    from scangeo.lidar.cells import GridCellStream
    from scangeo.lidar.evaluation import _options

    popt, prior = _options(block)
    grid = GridCellStream(sid, popt, prior)
    step = 1_000_000
    for k in range(0, t.size, step):
        grid.feed(xyz[k:k + step], t[k:k + step])
    return grid.finish()


def rigid_fit(a, b):
    """The rotation R and translation s minimising |R a + s - b| (Kabsch), and R a + s."""
    import numpy as np

    ca, cb = a.mean(axis=0), b.mean(axis=0)
    u, _, vt = np.linalg.svd((a - ca).T @ (b - cb))
    d = np.sign(np.linalg.det(vt.T @ u.T))
    R = vt.T @ np.diag([1.0, 1.0, d]) @ u.T
    return R, cb - R @ ca


def evaluate(block, root: Path, outputs: dict[str, Path]) -> dict:
    """True errors and flat strip differences of each tool's corrected strips (module doc)."""
    import numpy as np

    from scangeo.lidar.adjust import corrector
    from scangeo.lidar.differences import strip_differences
    from scangeo.lidar.evaluation import _options
    from tests.lidar.test_lidar_adjust import truth_values

    truth = json.loads((root / "truth.json").read_text())["truth"]
    true = truth_values(block, truth)
    popt = _options(block)[0]
    args = (popt.size, popt.flat_deg, popt.max_angle_deg, popt.max_offset)
    found = {name: {} for name in ("truth", *outputs)}
    err = {name: [] for name in outputs}
    raw_all, true_all = [], []
    for strip in block.project.strips:
        xyz, t = strip_returns(strip)
        xyz_true = corrector(block, strip.id, true)(xyz, t)
        found["truth"][strip.id] = planar_cells(block, strip.id, xyz_true, t)
        true_all.append(xyz_true)
        raw_all.append(xyz - xyz_true)
        for name, folder in outputs.items():
            xyz_tool, t_tool = strip_returns(strip, folder / f"{strip.id}.laz")
            if t_tool.size != t.size or np.abs(t_tool - t).max() > 1e-6:
                raise SystemExit(f"{name}: {folder / (strip.id + '.laz')} does not hold strip {strip.id}'s returns "
                                 "in its order")
            found[name][strip.id] = planar_cells(block, strip.id, xyz_tool, t_tool)
            err[name].append(xyz_tool - xyz_true)
    before = strip_differences({s: f.cells for s, f in block.found.items()}, *args)
    diffs = {"before": before, **{k: strip_differences(v, *args) for k, v in found.items()}}
    keys = {k: d.key() for k, d in diffs.items()}
    common = keys["before"]
    for k in keys.values():
        common = np.intersect1d(common, k)
    out: dict = {"cells": int(common.size)}
    for k, d in diffs.items():
        idx = np.flatnonzero(np.isin(keys[k], common))
        out[f"flat_{k}_m"] = d.take(idx).rms(True)
        out[f"all_{k}_m"] = d.take(idx).rms()
    true_xyz = np.concatenate(true_all)
    rng = np.random.default_rng(0)
    sample = rng.choice(true_xyz.shape[0], min(true_xyz.shape[0], 200_000), replace=False)
    for name, parts in (("before", raw_all), *err.items()):
        e = np.concatenate(parts)
        R, s = rigid_fit((true_xyz + e)[sample], true_xyz[sample])
        e_rel = (true_xyz + e) @ R.T + s - true_xyz
        out[name] = {
            "true_3d_m": float(np.sqrt(np.mean(np.sum(e**2, axis=1)))),
            "true_h_m": float(np.sqrt(np.mean(np.sum(e[:, :2] ** 2, axis=1)))),
            "true_v_m": float(np.sqrt(np.mean(e[:, 2] ** 2))),
            "true_p99_3d_m": float(np.percentile(np.linalg.norm(e, axis=1), 99)),
            "relative_3d_m": float(np.sqrt(np.mean(np.sum(e_rel**2, axis=1)))),
            "per_strip_3d_m": {s.id: float(np.sqrt(np.mean(np.sum(p**2, axis=1))))
                               for s, p in zip(block.project.strips, parts)},
        }
    out["returns"] = int(true_xyz.shape[0])
    return out


# ---------------------------------------------------------------------------------------------
# the timed children

def scangeo_run(root: str, out: str) -> None:
    """scangeo: patches, the strip adjustment, the corrected strips (LAZ)."""
    from scangeo.lidar.adjust import corrector, run
    from scangeo.lidar.lasio import write_corrected

    block = load_block(Path(root))
    result = run(block)
    values = result.parameters.values()
    Path(out).mkdir(parents=True, exist_ok=True)
    for strip in block.project.strips:
        write_corrected(list(strip.las), strip.point_source_id, Path(out) / f"{strip.id}.laz",
                        corrector(block, strip.id, values))
    print(f"sigma0 {result.statistics.sigma0:.3f}, {len(result.rejections)} rejections")


def icp_run(plan_path: str) -> None:
    """Open3D: point-to-plane ICP chained from the reference strip along the overlaps (module doc);
    runs with the peer's Python (Open3D, laspy)."""
    import laspy
    import numpy as np
    import open3d as o3d

    o3d.utility.set_verbosity_level(o3d.utility.VerbosityLevel.Error)
    plan = json.loads(Path(plan_path).read_text())
    origin = np.asarray(plan["origin"])
    las, clouds = {}, {}
    for sid, s in plan["strips"].items():
        if len(s["las"]) != 1:
            raise SystemExit(f"strip {sid}: the ICP child reads one LAS file per strip, found {len(s['las'])}")
        data = laspy.read(s["las"][0])
        if s["point_source_id"] is not None:
            data = data[np.asarray(data.point_source_id) == s["point_source_id"]]
        las[sid] = data
        xyz = np.column_stack([las[sid].x, las[sid].y, las[sid].z]) - origin
        pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(xyz))
        pcd.estimate_normals(o3d.geometry.KDTreeSearchParamKNN(plan["neighbours"]))
        pcd.orient_normals_to_align_with_direction(np.array([0.0, 0.0, 1.0]))
        clouds[sid] = pcd
    transforms = {plan["reference"]: np.eye(4)}
    log = []
    for child, parent, weight in plan["chain"]:
        target = o3d.geometry.PointCloud(clouds[parent]).transform(transforms[parent])
        box = target.get_axis_aligned_bounding_box()
        box = o3d.geometry.AxisAlignedBoundingBox(box.min_bound - 2.0, box.max_bound + 2.0)
        source = clouds[child].crop(box)
        T = np.eye(4)
        for distance in plan["correspondence_m"]:
            reg = o3d.pipelines.registration.registration_icp(
                source, target, distance, T, o3d.pipelines.registration.TransformationEstimationPointToPlane(),
                o3d.pipelines.registration.ICPConvergenceCriteria(relative_fitness=1e-7, relative_rmse=1e-7,
                                                                  max_iteration=50))
            T = reg.transformation
        transforms[child] = T
        log.append({"strip": child, "onto": parent, "tie_patches": weight, "points": len(source.points),
                    "fitness": reg.fitness, "inlier_rmse_m": reg.inlier_rmse,
                    "shift_m": T[:3, 3].tolist()})
    out = Path(plan["out"])
    out.mkdir(parents=True, exist_ok=True)
    for sid, data in las.items():
        T = transforms[sid]
        xyz = np.column_stack([data.x, data.y, data.z]) - origin
        new = xyz @ T[:3, :3].T + T[:3, 3] + origin
        data.x, data.y, data.z = new[:, 0], new[:, 1], new[:, 2]
        data.write(str(out / f"{sid}.laz"))
    (out / "icp.json").write_text(json.dumps({"transforms": {k: v.tolist() for k, v in transforms.items()},
                                              "pairs": log}, indent=1))


# ---------------------------------------------------------------------------------------------

def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=16, help="the simulation's seed (the laser preset's is 16)")
    ap.add_argument("--blocks", nargs="+", default=["laser", "montafon"], choices=("laser", "montafon"))
    ap.add_argument("--work", default="/tmp/scangeo_peer_icp", help="kept between runs")
    ap.add_argument("--venv", default=None, help="Open3D's virtual environment (default ~/.cache/scangeo-peers)")
    ap.add_argument("--icp-distances", type=float, nargs="+", default=list(CORRESPONDENCE_M),
                    help="ICP's correspondence distances in turn, m")
    ap.add_argument("--only", choices=("scangeo", "icp"), default=None,
                    help="run one tool (the other's last output is evaluated again)")
    args = ap.parse_args()
    import numpy as np
    from peer_env import Measured, PeerUnavailable, ensure, icp_peer, load_average, peer_environ, run_measured

    try:
        peer_python = ensure(icp_peer(), Path(args.venv) if args.venv else None)
    except PeerUnavailable as exc:
        print(f"SKIPPED ICP: {exc}")
        return
    version = subprocess.run([str(peer_python), "-c", "import open3d; print(open3d.__version__)"],
                             capture_output=True, text=True).stdout.strip()
    me = str(Path(__file__).resolve())
    env = {**os.environ, "PYTHONPATH": str(HERE.parents[1])}
    lines = []
    for kind in args.blocks:
        work = Path(args.work) / f"{kind}_s{args.seed}"
        root = work / "project"
        t = time.perf_counter()
        if not (root / "project.toml").exists():
            shutil.rmtree(root, ignore_errors=True)
            simulate_block(kind, root, args.seed)
        block = load_block(root)
        plan = icp_plan(block, root, work / "icp", args.icp_distances)
        (work / "icp_plan.json").write_text(json.dumps(plan, indent=1))
        n_returns = sum(int(v["returns"]) for v in json.loads((root / "truth.json").read_text())["truth"]["strips"]
                        .values())
        print(f"\n{kind} (seed {args.seed}): {len(plan['strips'])} strips, {n_returns / 1e6:.2f} M returns, "
              f"{len(block.ties)} tie patches; ICP reference strip {plan['reference']}, chain "
              + ", ".join(f"{c}->{p} ({w})" for c, p, w in plan["chain"]) + f"; set-up {time.perf_counter() - t:.0f} s")
        print(f"load average before: {load_average()}")
        measured = {}
        for name, cmd, e in (
            ("scangeo", [sys.executable, me, "--child", "scangeo", str(root), str(work / "scangeo")], env),
            ("icp", [str(peer_python), me, "--child", "icp", str(work / "icp_plan.json")],
             peer_environ(icp_peer(), peer_python)),
        ):
            if args.only and name != args.only:
                previous = work / "results.json"
                if previous.exists() and name in json.loads(previous.read_text())["measured"]:
                    measured[name] = Measured(**json.loads(previous.read_text())["measured"][name])
                    continue
            shutil.rmtree(work / name, ignore_errors=True)
            r = run_measured(cmd, e, work / f"{name}.log")
            if r.returncode:
                sys.exit(f"{name}'s child failed ({r.returncode}): {work / (name + '.log')}")
            measured[name] = r
        print(f"load average after: {load_average()}")
        ev = evaluate(block, root, {"scangeo": work / "scangeo", "icp": work / "icp"})
        icp_log = json.loads((work / "icp" / "icp.json").read_text())["pairs"]
        for p in icp_log:
            print(f"  ICP {p['strip']} onto {p['onto']}: {p['points']} points, fitness {p['fitness']:.2f}, inlier rmse "
                  f"{p['inlier_rmse_m'] * 100:.1f} cm, shift {np.round(np.asarray(p['shift_m']) * 100, 1)} cm")
        print(f"  flat strip differences (rms over {ev['cells']} cell pairs all share): before "
              f"{ev['flat_before_m'] * 100:.2f} cm, scangeo {ev['flat_scangeo_m'] * 100:.3f} cm, ICP "
              f"{ev['flat_icp_m'] * 100:.3f} cm, true corrections (noise floor) {ev['flat_truth_m'] * 100:.3f} cm")
        print(f"  {'':<9}{'CPU s':>8}{'wall s':>8}{'peak MB':>9}{'true error 3D / horiz. / vert. cm':>36}"
              f"{'p99 3D cm':>11}{'after a rigid fit cm':>22}")
        for name in ("before", "scangeo", "icp"):
            e = ev[name]
            r = measured.get(name)
            cost = f"{r.cpu:>8.1f}{r.wall:>8.1f}{r.peak_mb:>9.0f}" if r else f"{'':>8}{'':>8}{'':>9}"
            print(f"  {name:<9}{cost}{e['true_3d_m'] * 100:>16.2f} / {e['true_h_m'] * 100:.2f} / "
                  f"{e['true_v_m'] * 100:.2f}{e['true_p99_3d_m'] * 100:>11.2f}{e['relative_3d_m'] * 100:>22.2f}")
        for name in ("scangeo", "icp"):
            print("  per strip " + name + ": " + ", ".join(f"{k} {v * 100:.1f}" for k, v in
                                                          ev[name]["per_strip_3d_m"].items()) + " cm")
        (work / "results.json").write_text(json.dumps({"evaluation": ev, "measured": {k: vars(v) for k, v in
                                                                                     measured.items()}}, indent=1))
        for name, label in (("scangeo", "scangeo"), ("icp", f"ICP (Open3D {version})")):
            r, e = measured[name], ev[name]
            lines.append(f"SUMMARY {kind} {label}: {r.cpu:.1f} CPU s, {r.peak_mb:.0f} MB peak, true error "
                         f"{e['true_3d_m'] * 100:.2f} cm rms (3D), flat strip differences "
                         f"{ev['flat_' + name + '_m'] * 100:.3f} cm (noise floor {ev['flat_truth_m'] * 100:.3f} cm)")
    print()
    print("\n".join(lines))


def child(argv: list[str]) -> None:
    if argv[0] == "scangeo":
        scangeo_run(argv[1], argv[2])
    elif argv[0] == "icp":
        icp_run(argv[1])
    else:
        raise SystemExit(f"unknown child {argv[0]}")


if __name__ == "__main__":
    if len(sys.argv) > 2 and sys.argv[1] == "--child":
        child(sys.argv[2:])
    else:
        main()
