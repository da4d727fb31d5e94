"""Reliability (Baarda): closed forms on a levelling line and a single ray with control, agreement with
a dense inverse on a simulated block, and the separability of injected blunders."""
from __future__ import annotations

import csv
import json
import os
import shutil

import numpy as np
import pytest
import scipy.sparse as sp

from scangeo.adjustment.keys import Ground
from scangeo.adjustment.outputs import write_results
from scangeo.adjustment.reliability_summary import strip_probes, variant_reliability
from scangeo.adjustment.results import run_variant
from scangeo.adjustment.variants import Variant
from scangeo.io.project import Project
from scangeo.lsq import JacobianPart, Linearisation, ObservationGroup, Parameters, SnoopingOptions, Unknown, adjust
from scangeo.lsq.reliability import blunder_effect, compute_reliability, delta0
from scangeo.reports.reliability import reliability_section
from tests.lsq.problems import HeightDifferences

from .test_block import SHIFT_ONLY, _simulate

NO_SNOOPING = SnoopingOptions(enabled=False)
D0 = delta0()


def test_delta0_is_baardas_for_alpha_01_percent_and_power_80_percent():
    assert D0 == pytest.approx(3.2905 + 0.8416, abs=1e-4)
    assert D0 ** 2 == pytest.approx(17.07, abs=0.01)


def test_levelling_line_between_two_benchmarks_closed_forms():
    # A - P1 - ... - P5 - B, A and B fixed: one condition; r_i = s_i^2 / S, MDB_i = delta0 sqrt(S),
    # and an MDB-sized blunder in segment i moves H_k by MDB (S_k / S) (k < i) or -MDB (1 - S_k / S)
    s = np.array([0.002, 0.003, 0.001, 0.004, 0.002, 0.0025])
    names = ["A", "P1", "P2", "P3", "P4", "P5", "B"]
    truth = {n: 100.0 + 3.0 * k for k, n in enumerate(names)}
    dh = np.diff(list(truth.values()))
    group = HeightDifferences(names[:-1], names[1:], dh, s)
    params = Parameters()
    for n in names:
        params.add(Unknown(n), [truth[n]], free=n not in ("A", "B"))
    result = adjust(params, [group], snooping=NO_SNOOPING)
    rel = compute_reliability(result.solution, result.statistics)
    S = np.sum(s ** 2)
    np.testing.assert_allclose(rel.redundancy[0], s ** 2 / S, rtol=1e-9)
    np.testing.assert_allclose(rel.mdb[0], D0 * np.sqrt(S), rtol=1e-9)
    np.testing.assert_allclose(rel.sqrt_lambda[0], D0 * np.sqrt((S - s ** 2) / s ** 2), rtol=1e-9)
    layout = result.solution.layout
    S_k = np.cumsum(s ** 2)     # S_k after the segment ending at P_{k+1}
    for i in range(s.size):
        dx = blunder_effect(result.solution, 0, i, rel.mdb[0][i])
        for k, n in enumerate(names[1:-1]):
            expected = rel.mdb[0][i] * ((1.0 if k >= i else 0.0) - S_k[k] / S)
            assert dx[layout.columns(Unknown(n))[0]] == pytest.approx(expected, rel=1e-9, abs=1e-15)


class DirectCoordinates(ObservationGroup):
    """Control coordinates of ``Ground(point)`` observed directly (metres)."""

    name = "control"

    def __init__(self, point, xyz, sigma):
        self.key = Ground(point)
        self.xyz = np.asarray(xyz, float)
        self.sigma = np.asarray(sigma, float)
        self._describe(point, ["x", "y", "z"], "m", np.zeros(3, int))

    def keys(self):
        return [self.key]

    def linearise(self, values):
        r = (values[self.key] - self.xyz) / self.sigma
        return Linearisation(r, [JacobianPart([self.key], np.arange(3), np.arange(3), 1 / self.sigma)])


class VerticalRay(ObservationGroup):
    """A vertical image ray through ``Ground(point)``: it fixes x and y (sigma on the ground, m), not z."""

    name = "ray"

    def __init__(self, point, xy, sigma):
        self.key = Ground(point)
        self.xy = np.asarray(xy, float)
        self.sigma = np.full(2, float(sigma))
        self._describe(point, ["x", "y"], "m", np.zeros(2, int))

    def keys(self):
        return [self.key]

    def linearise(self, values):
        r = (values[self.key][:2] - self.xy) / self.sigma
        return Linearisation(r, [JacobianPart([self.key], np.arange(2), np.arange(2), 1 / self.sigma)])


def test_single_ray_with_control_closed_forms():
    sc, sg = 0.05, 0.12
    params = Parameters()
    params.add(Ground("C"), [10.0, 20.0, 30.0])
    groups = [DirectCoordinates("C", [10.0, 20.0, 30.0], [sc, sc, 0.08]), VerticalRay("C", [10.0, 20.0], sg)]
    result = adjust(params, groups, snooping=NO_SNOOPING)
    rel = compute_reliability(result.solution, result.statistics, point_key=Ground)
    assert np.isnan(compute_reliability(result.solution, result.statistics).ext_point_m[1]).all()  # no hook: no point
    q = sc ** 2 + sg ** 2   # two direct measurements of x (and of y): r_i = sigma_i^2 / q
    np.testing.assert_allclose(rel.redundancy[0][:2], sc ** 2 / q, rtol=1e-9)
    np.testing.assert_allclose(rel.redundancy[1], sg ** 2 / q, rtol=1e-9)
    # the control's z is not checked by anything: r = 0, no detectable blunder, no bound on its effect
    assert rel.redundancy[0][2] == pytest.approx(0.0, abs=1e-12)
    assert np.isinf(rel.mdb[0][2]) and np.isinf(rel.ext_point_m[0][2])
    np.testing.assert_allclose(rel.mdb[0][:2], D0 * np.sqrt(q), rtol=1e-9)
    np.testing.assert_allclose(rel.mdb[1], D0 * np.sqrt(q), rtol=1e-9)
    # an MDB-sized blunder moves the point by the other measurement's share of the MDB
    np.testing.assert_allclose(rel.ext_point_m[1], D0 * sc ** 2 / np.sqrt(q), rtol=1e-9)
    np.testing.assert_allclose(rel.ext_point_m[0][:2], D0 * sg ** 2 / np.sqrt(q), rtol=1e-9)
    np.testing.assert_allclose(rel.sqrt_lambda[1], D0 * np.sqrt(sc ** 2 / sg ** 2), rtol=1e-9)


def test_single_ray_with_control_blunder_is_not_separable():
    # two control points seen by one vertical ray each, and a common shift of both rays (an orientation)
    params = Parameters()
    pts = {"C1": [0.0, 0.0, 5.0], "C2": [100.0, 0.0, 7.0], "C3": [0.0, 100.0, 6.0]}
    groups = []
    for p, xyz in pts.items():
        params.add(Ground(p), xyz)
        groups.append(DirectCoordinates(p, xyz, [0.05, 0.05, 0.08]))
        ray = VerticalRay(p, np.array(xyz[:2]) + (0.4 if p == "C2" else 0.0), 0.1)   # blunder 0.4 m in C2's x
        ray.name = f"ray {p}"
        groups.append(ray)
    result = adjust(params, groups, snooping=SnoopingOptions(), point_key=Ground)
    assert len(result.rejections) == 1
    rej = result.rejections[0]
    assert rej.id == "C2" and not rej.separable and "not separable" in rej.note
    # the point left without measurements is regularised, and the note says why (the point_key hook)
    notes = {n.key: n.reason for n in result.solution.regularisation}
    assert "every measurement of the point removed" in notes[Ground("C2")]
    # the whole point is out: its ray and its control coordinates
    for g, act in zip(result.solution.groups, result.solution.active):
        if g.kind == "observation":
            assert act.all() == (g.ids[0] != "C2")


# ------------------------------------------------------------------------------ simulated blocks
VARIANT = Variant("SHIFT", "SE", attitude_degree=-1, dtm_heights=True)


@pytest.fixture(scope="module")
def block(tmp_path_factory):
    return _simulate(tmp_path_factory.mktemp("rel") / "small", SHIFT_ONLY)


@pytest.fixture(scope="module")
def clean(block):
    return run_variant(block, VARIANT)


@pytest.mark.numerics  # two numerical routes: run under a second BLAS kernel too (.ci/run)
def test_reliability_agrees_with_a_dense_inverse(clean):
    rel = variant_reliability(clean).reliability
    sol = clean.adjustment.solution
    J = sol.system.jacobian.toarray() / sol.system.scale          # whitened, scaled columns
    Q = np.linalg.inv(J.T @ J)
    h = np.einsum("ij,ij->i", J @ Q, J)
    P = sp.vstack([p.matrix for p in strip_probes(clean)]).toarray() / sol.system.scale
    checked = 0
    for gi, (g, sl) in enumerate(zip(sol.groups, sol.system.row_slices)):
        if g.kind != "observation":
            continue
        r = 1.0 - h[sl]
        ok = r >= 1e-3
        assert np.all(np.isinf(rel.mdb[gi][~ok]))
        np.testing.assert_allclose(rel.redundancy[gi][ok], r[ok], rtol=1e-9)
        np.testing.assert_allclose(rel.mdb[gi][ok], g.sigma[ok] * D0 / np.sqrt(r[ok]), rtol=1e-9)
        for i in np.flatnonzero(ok)[:: max(1, ok.sum() // 40)]:
            dx = Q @ J[sl.start + i] * D0 / np.sqrt(r[i])
            shift = P @ dx
            assert rel.ext_orientation_m[gi][i] == pytest.approx(np.hypot(shift[0::2], shift[1::2]).max(), rel=1e-9)
            key = Ground(str(g.ids[i]))
            if key in sol.layout.start:
                c = sol.layout.columns(key)
                assert rel.ext_point_m[gi][i] == pytest.approx(np.linalg.norm(dx[c] / sol.system.scale[c]), rel=1e-9)
            checked += 1
    assert checked > 100
    assert np.nansum(np.concatenate(rel.redundancy)) <= clean.adjustment.statistics.redundancy + 1e-6


def test_no_uncontrolled_measurement_is_verified(clean):
    vr = variant_reliability(clean)
    for r, st, g in zip(vr.reliability.redundancy, vr.status, clean.adjustment.solution.groups):
        if g.kind == "observation":
            assert not np.any((st == "verified") & ~(r >= 1e-3))
            assert np.all(st[~(r >= 1e-3) & np.isfinite(r)] == "uncontrolled")


def test_a_clean_block_has_no_false_alarms(clean):
    n_points = len({str(p) for g in clean.adjustment.solution.groups if g.kind == "observation" for p in g.ids})
    assert len(clean.adjustment.rejections) <= 0.01 * n_points


def inject(source, root, seed, n=6, size=(10.0, 30.0)):
    """A copy of the project with blunders of ``size`` px in ``n`` image measurements of distinct
    control, height and tie points; returns {(point, strip)}."""
    shutil.copytree(source, root, ignore=shutil.ignore_patterns("results"))
    rows = list(csv.reader(open(root / "points.csv")))
    head, body = rows[0], rows[1:]
    roles = {r[0]: r[6] for r in list(csv.reader(open(root / "ground.csv")))[1:]}
    rng = np.random.default_rng(seed)
    picked, points = [], set()
    for i in rng.permutation([i for i, r in enumerate(body) if roles.get(r[0], "tie") != "check"]):
        if body[i][0] not in points and len(picked) < n:
            points.add(body[i][0])
            picked.append(int(i))
    project = Project.load(root)
    for i in picked:
        a, b = rng.uniform(0, 2 * np.pi), rng.uniform(*size)
        size_of = {2: project.n_lines(body[i][1]), 3: project.sensor.model.pixels}
        for col, d in ((2, b * np.cos(a)), (3, b * np.sin(a))):
            top = size_of[col]
            x = float(body[i][col]) + d
            body[i][col] = f"{x if 0 <= x <= top - 1 else x - 2 * d:.4f}"   # inside the image
    with open(root / "points.csv", "w", newline="") as f:
        csv.writer(f).writerows([head] + body)
    return {(body[i][0], body[i][1]) for i in picked}


def _detectable(clean, blunders):
    """The blunders whose measurement has a finite MDB (in both coordinates) in the clean block."""
    rel = variant_reliability(clean, external=False).reliability
    out = set()
    for g, mdb in zip(clean.adjustment.solution.groups, rel.mdb):
        if g.name.startswith("image "):
            for p, s in blunders:
                sel = (g.ids.astype(str) == p) & (g.strip == s)
                if sel.any() and np.isfinite(mdb[sel]).all() and mdb[sel].max() < 10.0:
                    out.add((p, s))
    return out


def test_injected_blunders_are_rejected_or_flagged_never_blamed_on_a_good_measurement(block, clean, tmp_path):
    caught, detectable, blamed = 0, 0, []
    for seed in range(3):
        blunders = inject(block, tmp_path / f"b{seed}", seed)
        result = run_variant(tmp_path / f"b{seed}", VARIANT)
        for p, s in _detectable(clean, blunders):
            detectable += 1
            caught += any(r.id == p and (not r.separable or r.group == f"image {s}")
                          for r in result.adjustment.rejections)
        bad_points = {p for p, _ in blunders}
        for r in result.adjustment.rejections:
            if r.separable and not (r.group.startswith("image ") and (r.id, r.group[6:]) in blunders):
                blamed.append((seed, r.group, r.id))
            assert r.id in bad_points or not r.separable
    assert detectable >= 15
    assert caught >= 0.95 * detectable
    assert blamed == []


def _shift_line(source, root, point, strip, lines):
    """A copy of the project with ``lines`` added to the line of ``point`` in ``strip``."""
    shutil.copytree(source, root, ignore=shutil.ignore_patterns("results"))
    rows = list(csv.reader(open(root / "points.csv")))
    for r in rows[1:]:
        if r[0] == point and r[1] == strip:
            r[2] = f"{float(r[2]) + lines:.6f}"
    with open(root / "points.csv", "w", newline="") as f:
        csv.writer(f).writerows(rows)
    return root


def test_an_undetected_blunder_below_its_mdb_stays_within_the_external_reliability(block, clean, tmp_path):
    vr = variant_reliability(clean)
    sol = clean.adjustment.solution
    gi = next(k for k, g in enumerate(sol.groups) if g.name == "image 01")
    g = sol.groups[gi]
    rows = [i for i in range(g.n_rows) if g.components[i] == "line" and vr.status[gi][i] == "verified"
            and clean.block.role(str(g.ids[i])) == "tie"]
    i = max(rows, key=lambda k: vr.reliability.ext_point_m[gi][k])      # the tie measurement with most leverage
    size = 0.9 * vr.reliability.mdb[gi][i]
    result = run_variant(_shift_line(block, tmp_path / "small", str(g.ids[i]), "01", size), VARIANT)
    assert result.adjustment.rejections == []                          # it stays undetected
    point = Ground(str(g.ids[i]))
    moved = np.linalg.norm(result.adjustment.parameters[point].values - sol.parameters[point].values)
    assert 0.5 * 0.9 * vr.reliability.ext_point_m[gi][i] < moved < vr.reliability.ext_point_m[gi][i]
    # the strips' ground positions: the probes applied to the change of the unknowns
    dx = np.concatenate([result.adjustment.parameters[k].values - sol.parameters[k].values
                         for k in sol.layout.keys])[sol.layout.free_to_full]
    for probe in vr.probes:
        shift = probe.matrix @ dx
        assert np.hypot(shift[0::2], shift[1::2]).max() < vr.reliability.ext_orientation_m[gi][i]


def test_results_hold_the_reliability(clean, tmp_path):
    out = write_results(clean, tmp_path / "out")
    rows = list(csv.DictReader(open(out / "residuals.csv")))
    assert {"mdb", "ext_point_m", "ext_orientation_m", "sqrt_lambda", "status"} <= set(rows[0])
    for r in rows:
        if r["redundancy"] and float(r["redundancy"]) < 1e-3:
            assert r["status"] == "uncontrolled" and r["mdb"] == "inf"
        if r["status"] == "verified":
            assert float(r["redundancy"]) >= 1e-3 and 0 < float(r["mdb"]) < 100
    assert {r["status"] for r in rows if r["kind"] == "check"} <= {"check", "check failed", "not projected"}
    units = list(csv.DictReader(open(out / "reliability.csv")))
    assert {u["kind"] for u in units} >= {"control", "tie", "dtm"}
    assert all(np.isfinite(float(u["x"])) for u in units)
    # a point's map position to the mm (its adjusted position: within a metre of ground.csv's for control)
    given = {str(p): xyz for p, xyz in zip(clean.block.ground.point, clean.block.ground.xyz)}
    control = [u for u in units if u["kind"] == "control" and u["point"] in given]
    assert control and all(len(u["y"].split(".")[1]) == 3 for u in control)
    assert max(np.hypot(float(u["x"]) - given[u["point"]][0], float(u["y"]) - given[u["point"]][1])
               for u in control) < 1.0
    summary = json.loads((out / "reliability.json").read_text())
    assert summary["delta0"] == pytest.approx(D0)
    assert set(summary["strips"]) == {"01", "02"} and set(summary["positions"]) == {"01", "02"}
    assert {s["kind"] for s in summary["summary"]} >= {"control", "tie", "dtm", "gpsimu", "check"}
    check = next(s for s in summary["summary"] if s["kind"] == "check" and s["unit"] == "px")
    assert check["mdb_max"] == pytest.approx(D0 * 0.3) and check["ext_point_max_m"] is None
    section = reliability_section(tmp_path, ["out"])
    text = "".join(section.parts)
    assert text.count("<img") == 2 and "external reliability" in text and "r = 0" in text


@pytest.mark.scale
def test_three_strip_block_rejects_separable_blunders_themselves(tmp_path):
    # 60 % sidelap: tie points in three strips, where a blunder in one ray is separable and that ray is
    # rejected itself; one seed in CI, three with SCANGEO_SCALE=full
    seeds = 3 if os.environ.get("SCANGEO_SCALE", "").lower() == "full" else 1
    root = _simulate(tmp_path / "three", {**SHIFT_ONLY, "flight": {"strips": 3, "sidelap": 0.6, "lines": 400},
                                          "points": {"tie_per_overlap": 12, "control_band_lines": 60.0}})
    clean = run_variant(root, VARIANT)
    assert clean.adjustment.rejections == []
    caught, detectable, separable = 0, 0, 0
    for seed in range(seeds):
        blunders = inject(root, tmp_path / f"b{seed}", seed)
        rejections = run_variant(tmp_path / f"b{seed}", VARIANT).adjustment.rejections
        for p, s in _detectable(clean, blunders):
            detectable += 1
            caught += any(r.id == p and (not r.separable or r.group == f"image {s}") for r in rejections)
        for r in rejections:
            assert not r.separable or (r.group.startswith("image ") and (r.id, r.group[6:]) in blunders), r
            separable += r.separable
    assert caught >= 0.95 * detectable and detectable >= 5 * seeds
    assert separable >= 1
