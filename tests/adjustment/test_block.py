"""The adjustment of simulated blocks (``scangeo simulate --preset small``) against their truth."""
from __future__ import annotations

import csv
import fnmatch
import json
import shutil

import numpy as np
import pytest

from scangeo.adjustment.block import adjust_block, adjust_variant, build_block
from scangeo.adjustment.outputs import write_results
from scangeo.adjustment.results import evaluate_checks, read_measurements, run_variant
from scangeo.adjustment.variants import StripModels, Variant, read_variants
from scangeo.cli import main
from scangeo.errors import ProjectFileError
from scangeo.io.project import Project
from scangeo.sensors.strip import Mounting, StripGeometry
from scangeo.simulate.block import simulate
from scangeo.simulate.config import load_preset
from scangeo.trajectory.readers import read_trajectory
from scangeo.trajectory.spline import OrientationSpline
from tests.lsq.backends import require_cholmod

NO_IMAGES = {"output": {"images": False, "truth_ortho": False}}
#: GPS/IMU errors a degree-0 model describes exactly: per-strip position shifts only.
SHIFT_ONLY = {"sensor": {"boresight_error_deg": [0.0, 0.0, 0.0]}, "gpsimu_errors": {"defaults": {
    "drift_m": 0.0, "drift_deg": 0.0, "random_walk_m": 0.0, "random_walk_deg": 0.0, "attitude_offset_deg": 0.0,
    "white_noise_m": 0.0, "white_noise_deg": 0.0, "height_wander_m": 0.0, "rotation_deg": 0.0}}}


def _simulate(root, overrides):
    simulate(root, load_preset("small", {**NO_IMAGES, **overrides}))
    ground = root / "ground.csv"
    # simulate writes sigma_xy = 0 for height points, which the ground.csv reader rejects (reported);
    # the value plays no role for a height point
    ground.write_text(ground.read_text().replace(",0,0.1,height", ",1,0.1,height"))
    return root


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    return _simulate(tmp_path_factory.mktemp("adj") / "small", {})


@pytest.fixture(scope="module")
def shifted(tmp_path_factory):
    return _simulate(tmp_path_factory.mktemp("adj") / "shift", SHIFT_ONLY)


def true_geometry(result, root, sid):
    proj = result.block.project
    err = json.loads((root / "truth" / "errors.json").read_text())
    traj = read_trajectory(root / "truth" / f"trajectory_{sid}.csv", crs=proj.crs).to_project(proj.map_frame.frame)
    m = proj.sensor.mounting
    return StripGeometry(proj.sensor.model, OrientationSpline.from_trajectory(traj, proj.knot_spacing),
                         proj.timing(sid), proj.n_lines(sid),
                         Mounting(m.lever_arm_B, np.radians(err["true_boresight_deg"]), m.time_offset), sid)


def _pooled_rms(checks):
    ok = checks.status == 0
    return float(np.sqrt(np.mean(np.concatenate([checks.line[ok], checks.pixel[ok]]) ** 2)))


def test_se_recovers_each_strips_datum_shift_within_3_sigma(small):
    result = run_variant(small, "SE")
    err = json.loads((small / "truth" / "errors.json").read_text())
    stats = result.adjustment.statistics
    assert result.adjustment.solution.converged
    for m in result.block.models:
        (sid,) = m.strips
        shift = np.array(err["strips"][sid]["shift_m"])
        est = result.adjustment.parameters[m.key].values[:3]   # x0, y0, z0: the correction = -error
        sigma = stats.sigmas(m.key)[:3]
        assert np.all(np.abs(est + shift) < 3 * sigma), (sid, est, -shift, sigma)
        assert np.all(sigma < 20.0)


def test_shift_only_block_recovers_shifts_and_checks_reach_the_noise(shifted):
    variant = Variant("SHIFT", "SE", attitude_degree=-1)
    result = run_variant(shifted, variant)
    err = json.loads((shifted / "truth" / "errors.json").read_text())
    stats = result.adjustment.statistics
    for m in result.block.models:
        (sid,) = m.strips
        shift = np.array(err["strips"][sid]["shift_m"])
        est, sigma = result.adjustment.parameters[m.key].values, stats.sigmas(m.key)
        assert np.all(np.abs(est + shift) < 3 * sigma), (sid, est, -shift, sigma)
        assert np.all(sigma[:2] < 0.5)     # planimetric shifts to decimetres
    assert 0.7 < stats.sigma0 < 1.3
    # check points: their rms with the true orientation is the measurement noise alone
    noise = _pooled_rms(evaluate_checks(result.block, lambda s: true_geometry(result, shifted, s)))
    adjusted = _pooled_rms(result.checks)
    assert adjusted < 1.2 * noise, (adjusted, noise)
    # direct georeferencing is clearly worse
    dg = run_variant(shifted, "DG")
    assert _pooled_rms(dg.checks) > 1.5 * adjusted


def with_blunders(source, root, seed=11, n=6):
    """A copy of a project with blunders of 10-30 px in ``n`` measurements of distinct control and
    tie points measured in 2+ strips; returns the copy, the blunder points and all point ids."""
    shutil.copytree(source, root)
    rows = list(csv.reader(open(root / "points.csv")))
    head, body = rows[0], rows[1:]
    count = {}
    for r in body:
        count[r[0]] = count.get(r[0], 0) + 1
    rng = np.random.default_rng(seed)
    candidates = [i for i, r in enumerate(body) if count[r[0]] >= 2 and r[0][0] in "ET"]
    blunder_points, picked = set(), []
    for i in rng.permutation(candidates):
        if body[i][0] not in blunder_points and len(picked) < n:
            blunder_points.add(body[i][0])
            picked.append(i)
    for i in picked:
        a, size = rng.uniform(0, 2 * np.pi), rng.uniform(10, 30)
        body[i][2] = f"{float(body[i][2]) + size * np.cos(a):.4f}"
        body[i][3] = f"{float(body[i][3]) + size * np.sin(a):.4f}"
    with open(root / "points.csv", "w", newline="") as f:
        csv.writer(f).writerows([head] + body)
    return root, blunder_points, count


def test_injected_blunders_are_flagged(shifted, tmp_path):
    root, blunder_points, count = with_blunders(shifted, tmp_path / "blunders")
    result = run_variant(root, Variant("SHIFT", "SE", attitude_degree=-1))
    flagged_points = {r.id for r in result.adjustment.rejections}
    # a tie point seen in two strips shows a blunder but cannot say which of its two rays holds it:
    # detection is counted per point
    assert len(flagged_points & blunder_points) >= 0.95 * len(blunder_points)
    good = len(set(count) - blunder_points)
    assert len(flagged_points - blunder_points) <= 0.01 * good


def test_adjust_variant_is_build_then_adjust_with_the_variants_settings(shifted, tmp_path):
    # one call builds and adjusts a variant: with the variant's snooping it is run_variant's adjustment;
    # snooping=False rejects nothing; started from a solution it stays there
    root, _, _ = with_blunders(shifted, tmp_path / "blunders", seed=13, n=3)
    v = Variant("SHIFT", "SE", attitude_degree=-1)
    project = Project.load(root)
    points, ground = read_measurements(project)
    block, adj = adjust_variant(project, v, points, ground)
    reference = run_variant(root, v).adjustment
    assert [r.id for r in adj.rejections] == [r.id for r in reference.rejections] and adj.rejections
    assert adj.statistics.sigma0 == pytest.approx(reference.statistics.sigma0, rel=1e-12)
    _, plain = adjust_variant(project, v, points, ground, snooping=False)
    assert not plain.rejections and plain.statistics.sigma0 > 1.5 * adj.statistics.sigma0
    solved = {b.key: b.values.copy() for b in plain.parameters}
    again = adjust_block(build_block(project, v, points, ground), snooping=False, start=solved)
    # the first step from the solution is a small fraction of the first step from the block's start values
    first, first_plain = again.solution.iterations[0], plain.solution.iterations[0]
    assert first.max_scaled_step < 0.05 * first_plain.max_scaled_step
    assert first.cost == pytest.approx(plain.solution.iterations[-1].cost, rel=1e-4)
    assert again.statistics.sigma0 == pytest.approx(plain.statistics.sigma0, rel=1e-5)  # both converged


@pytest.mark.numerics  # two numerical routes: run under a second BLAS kernel too (.ci/run)
def test_snooping_by_update_agrees_with_full_resolutions(shifted, tmp_path):
    # the low-rank update after each removal against a full solution and selected inversion after
    # each removal: the same observations rejected, the same final adjustment
    root, _, _ = with_blunders(shifted, tmp_path / "blunders", seed=12, n=5)
    results = {m: run_variant(root, Variant("SHIFT", "SE", attitude_degree=-1, dtm_heights=True, snooping_method=m))
               for m in ("update", "resolve")}
    upd, ref = results["update"].adjustment, results["resolve"].adjustment
    assert len(ref.rejections) >= 5
    assert [r.id for r in upd.rejections] == [r.id for r in ref.rejections]
    np.testing.assert_allclose([r.w for r in upd.rejections], [r.w for r in ref.rejections], rtol=0.01)
    assert upd.statistics.sigma0 == pytest.approx(ref.statistics.sigma0, rel=1e-6)
    for m in results["update"].block.models:
        np.testing.assert_allclose(upd.parameters[m.key].values, ref.parameters[m.key].values, atol=1e-4)
    assert upd.full_solutions < ref.full_solutions


def test_rank_deficient_setup_ends_with_a_regularisation_note(small, tmp_path):
    # a degree-4 position and attitude polynomial per strip, no preventive regularisation, control
    # only at one end of the block: the far end's polynomial terms are undetermined
    points = list(csv.DictReader(open(small / "points.csv")))
    far = sorted({p["point"] for p in points if p["point"].startswith(("E", "H")) and float(p["line"]) > 300})
    roles = {p: "check" for p in far}
    variant = Variant("P4ONE", "P", position_degree=4, attitude_degree=4, coefficient_sigma_m=1e12,
                      coefficient_sigma_deg=1e12, roles=tuple(roles.items()), snooping=False)
    result = run_variant(small, variant)
    notes = result.adjustment.solution.regularisation
    assert notes, "expected regularised unknowns"
    assert all(n.sigma > 0 for n in notes)
    report = json_report(result, tmp_path)
    assert report["regularisation"] and report["regularisation"][0]["sigma"] > 0


def json_report(result, tmp_path):
    out = write_results(result, tmp_path / "out")
    return json.loads((out / "report.json").read_text())


def test_split_model_is_continuous_in_the_adjusted_block(small):
    variant = Variant("S2", "S", strips=(StripModels("01", position_degree=2, breaks_lines=(200.0, 400.0)),),
                      dtm_heights=True)
    result = run_variant(small, variant)
    models = result.block.models
    subs = [m for m in models if m.id.startswith("01.")]
    assert [m.id for m in subs] == ["01.1", "01.2", "01.3"]
    coef = {m.key: result.adjustment.parameters[m.key].values for m in models}
    strip = result.block.strips["01"]
    for m in subs[1:]:
        t = np.array([m.t_start - 1e-7, m.t_start + 1e-7])
        p = np.interp(t, strip.epochs, strip.gpsimu[:, 0])[:, None] * np.ones(3)
        c = models.correction("01", t, p, coef)
        assert np.abs(c[1] - c[0]).max() < 1e-3
    acc = result.adjustment.statistics.accounting
    assert acc.conditions == 2 * 6   # 2 breaks x (3 position + 3 attitude) continuity conditions
    assert acc.parameters == acc.unknowns + acc.conditions


def test_cli_writes_results(small, capsys):
    assert main(["adjust", str(small), "--variant", "SE", "--no-progress"]) == 0
    out = small / "results" / "SE"
    report = json.loads((out / "report.json").read_text())
    assert report["accounting"]["redundancy"] > 0 and report["sigma0"] > 0
    assert set(report["strips"]) == {"01", "02"} and report["strips"]["01"]["check"]["n"] > 0
    assert {c["block"] for c in report["coefficients"]} == {"Correction(model=01)", "Correction(model=02)"}
    rows = list(csv.DictReader(open(out / "residuals.csv")))
    kinds = {r["kind"] for r in rows}
    assert {"gpsimu", "control", "tie", "check"} <= kinds
    for sid in ("01", "02"):
        traj = read_trajectory(out / f"trajectory_{sid}.csv")
        assert len(traj.time) > 100
        strip = next(s for s in json.loads((out / "orientation.json").read_text())["strips"] if s["id"] == sid)
        assert np.array(strip["spline"]["coefficients"]).shape[1] == 6
    assert "sigma0" in capsys.readouterr().out
    assert not list((small / "results").glob(".*"))   # no temporary folder left behind


def test_bad_inputs_give_clear_errors(small, tmp_path, capsys):
    root = tmp_path / "bad"
    shutil.copytree(small, root, ignore=shutil.ignore_patterns("results"))
    (root / "variants.toml").write_text('[variants.X]\nstrategy = "SE"\ndegree = 3\n')
    with pytest.raises(ProjectFileError, match="unknown key 'degree'"):
        read_variants(root / "variants.toml")
    assert main(["adjust", str(root), "--variant", "X", "--no-progress"]) == 1
    assert "unknown key 'degree'" in capsys.readouterr().err
    (root / "variants.toml").unlink()
    assert main(["adjust", str(root), "--variant", "NOPE", "--no-progress"]) == 1
    assert "no variant 'NOPE'" in capsys.readouterr().err
    text = (root / "points.csv").read_text().splitlines()
    text.append("Z999,99,10.0,10.0,0.3")
    (root / "points.csv").write_text("\n".join(text) + "\n")
    assert main(["adjust", str(root), "--variant", "SE", "--no-progress"]) == 1
    err = capsys.readouterr().err
    assert "strip '99' is not in the project" in err and "line" in err


def test_strip_without_control_gives_a_warning(small, caplog):
    points = list(csv.DictReader(open(small / "points.csv")))
    in01 = {p["point"] for p in points if p["strip"] == "01"}
    in02 = {p["point"] for p in points if p["strip"] == "02"}
    only01 = sorted(p for p in in01 - in02 if p[0] in "EH")
    variant = Variant("NOCTL", "SE", roles=tuple((p, "check") for p in sorted(in02 - in01) if p[0] in "EH")
                      + tuple((p, "check") for p in sorted(in01 & in02) if p[0] in "EH"), snooping=False)
    result = run_variant(small, variant)
    assert only01
    assert any("strip 02 has no control point" in n for n in result.notes)


def test_boresight_calibration_and_the_index_error_it_cannot_tell_apart(tmp_path):
    over = {"gpsimu_errors": SHIFT_ONLY["gpsimu_errors"]}   # keep small's boresight error
    root = _simulate(tmp_path / "bore", over)
    true = np.radians(json.loads((root / "truth" / "errors.json").read_text())["true_boresight_deg"])
    from scangeo.adjustment.keys import Boresight, ScanIndex
    result = run_variant(root, Variant("CAL", "SE", attitude_degree=-1, calibrate=("boresight",), dtm_heights=True))
    est = result.adjustment.parameters[Boresight()].values
    sigma = result.adjustment.statistics.sigmas(Boresight())
    assert np.all(np.abs(est - true) < 3 * sigma), (np.degrees(est), np.degrees(true), np.degrees(sigma))
    assert sigma[2] < np.radians(0.05)          # heading well determined by the two opposite strips
    assert not result.adjustment.solution.regularisation
    # a whiskbroom's index error is a boresight roll: calibrating both is a rank defect, regularised
    both = run_variant(root, Variant("CAL2", "SE", attitude_degree=-1, calibrate=("boresight", "index_error"),
                                     dtm_heights=True))
    keys = {n.key for n in both.adjustment.solution.regularisation}
    assert keys & {ScanIndex(), Boresight()}


@pytest.mark.numerics  # two numerical routes: run under a second BLAS kernel too (.ci/run)
def test_scipy_fallback_gives_the_same_adjustment(shifted):
    require_cholmod()  # SuperLU against CHOLMOD, never SuperLU against itself
    fast = run_variant(shifted, Variant("A", "SE", attitude_degree=-1, snooping=False, backend="cholmod"))
    slow = run_variant(shifted, Variant("B", "SE", attitude_degree=-1, snooping=False, backend="superlu"))
    assert fast.adjustment.solution.factor.backend == "cholmod"
    assert slow.adjustment.solution.factor.backend == "superlu"
    assert slow.adjustment.statistics.sigma0 == pytest.approx(fast.adjustment.statistics.sigma0, rel=1e-6)
    for m in fast.block.models:
        np.testing.assert_allclose(slow.adjustment.parameters[m.key].values, fast.adjustment.parameters[m.key].values,
                                   atol=1e-4)
        np.testing.assert_allclose(slow.adjustment.statistics.sigmas(m.key), fast.adjustment.statistics.sigmas(m.key),
                                   rtol=1e-5)


def test_roles_of_names_and_globs_last_pattern_wins():
    # names (as the cross-validation holds points out) and globs interleaved; the rule written out: every
    # pattern in order, the last that matches decides
    roles = (("E*", "check"), ("E01", "control"), ("H?2", "ignore"), ("E01", "ignore"), ("T[0-4]*", "check"),
             ("T15", "control"), ("*5", "tie"))
    v = Variant("R", "SE", roles=roles)
    points = [(f"{k}{i:02d}", r) for k, r in (("E", "control"), ("H", "height"), ("T", "tie")) for i in range(20)]

    def written_out(point, role):
        for pattern, new in roles:
            if fnmatch.fnmatchcase(point, pattern):
                role = new
        return role

    got = v.roles_of(points)
    assert got == {p: written_out(p, r) for p, r in points}
    assert got["E01"] == "ignore" and got["E02"] == "check" and got["T15"] == "tie" and got["T16"] == "check"
    assert got["H02"] == "ignore" and got["H12"] == "ignore" and got["H03"] == "height"
    assert v.role_of("T15", "tie") == "tie" and v.role_of("X1", "tie") == "tie"


def test_rows_of_each_strip_found_in_one_pass_equal_the_per_strip_selection(small):
    from scangeo.adjustment.block import _choose_points, _Setup, block_strips, build_models

    project = Project.load(small)
    points, ground = read_measurements(project)
    variant = Variant("SOME", "SE", roles=(("E0*", "check"), ("T01*", "ignore")))
    lines, strips = block_strips(project)
    setup = _Setup(project, variant, points, ground, lines, strips, build_models(project, variant, lines))
    _choose_points(setup)
    assert 0 < len(setup.used) < len(set(map(str, points.point)))
    total = 0
    for sid in [s.id for s in project.strips] + ["no such strip"]:
        expected = np.flatnonzero((points.strip.astype(str) == sid) & np.isin(points.point.astype(str), setup.used))
        got = setup.measured_in(sid)
        assert np.array_equal(got, expected), sid
        total += len(got)
    assert total == np.isin(points.point.astype(str), setup.used).sum() > 0


def test_strips_read_once_reads_each_trajectory_once_and_hands_out_copies(tiny_project, monkeypatch):
    import os

    from scangeo.adjustment.block import strip_data, strips_read_once
    from scangeo.io.project import Project

    project = Project.load(tiny_project.root)
    reads: list[str] = []
    stream = Project.flight_line_stream

    def counted(self, flight_line, check=True):
        reads.append(flight_line)
        return stream(self, flight_line, check)

    monkeypatch.setattr(Project, "flight_line_stream", counted)
    plain = strip_data(project, "1")
    with strips_read_once():
        first = strip_data(project, "1")
        with strips_read_once():  # nested: the same memory
            second = strip_data(project, "1")
        assert reads == ["1", "1"]  # once outside, once inside
        # the same numbers as without the memory, in arrays of its own
        for a, b in ((first, plain), (second, plain)):
            assert np.array_equal(a.spline.coef, b.spline.coef) and np.array_equal(a.gpsimu, b.gpsimu)
            assert np.array_equal(a.trajectory.p_P, b.trajectory.p_P) and np.array_equal(a.epochs, b.epochs)
        first.spline.coef[:] = 0.0
        first.gpsimu[:] = 0.0
        first.trajectory.p_P[:] = 0.0
        third = strip_data(project, "1")
        assert np.array_equal(third.spline.coef, plain.spline.coef) and np.array_equal(third.gpsimu, plain.gpsimu)
        assert np.array_equal(third.trajectory.p_P, plain.trajectory.p_P)
        assert third.geometry.spline is third.spline
        assert reads == ["1", "1"]
        # a rewritten trajectory file is read again
        nav = tiny_project.root / "nav" / "1.csv"
        st = nav.stat()
        os.utime(nav, ns=(st.st_atime_ns, st.st_mtime_ns + 10**9))
        strip_data(project, "1")
        assert reads == ["1", "1", "1"]
    strip_data(project, "1")  # outside: read every time again
    assert reads == ["1", "1", "1", "1"]


def test_a_model_per_mission_for_images(small, tmp_path):
    """Strategy ME: one GPS/IMU model per mission ([[strips]] mission); one mission is the block's model."""
    from scangeo.adjustment.block import block_strips, build_models

    project = Project.load(small)
    strips, _ = block_strips(project)  # the flight lines: one per strip
    per_mission, block = Variant("M", "ME"), Variant("B", "BE")
    one = build_models(project, per_mission, strips)
    assert [m.id for m in one] == ["mission 1"] and one.models["mission 1"].strips == tuple(strips)
    be = build_models(project, block, strips).models["block"]
    assert (one.models["mission 1"].t_start, one.models["mission 1"].t_end) == (be.t_start, be.t_end)
    root = tmp_path / "p"
    shutil.copytree(small, root)
    text = (root / "project.toml").read_text()
    for k, sid in enumerate(strips):
        text = text.replace(f'id = "{sid}"\n', f'id = "{sid}"\nmission = "{"AB"[k % 2]}"\n')
    (root / "project.toml").write_text(text)
    two = Project.load(root)
    models = build_models(two, per_mission, block_strips(two)[0])
    expected: dict[str, tuple[str, ...]] = {}
    for k, sid in enumerate(strips):
        expected[f"mission {'AB'[k % 2]}"] = expected.get(f"mission {'AB'[k % 2]}", ()) + (sid,)
    assert {m.id: m.strips for m in models} == expected and len(expected) == 2


def test_direct_georeferencing_with_check_points_only_is_evaluated(small, tmp_path):
    """DG on a project whose every point is a check point: nothing to adjust (no observation group at all),
    and the check points measure the GPS/IMU as flown; its results folder is written."""
    from scangeo.adjustment.outputs import write_results

    root = tmp_path / "checks"
    shutil.copytree(small, root)
    variant = Variant("DGC", "DG", roles=(("*", "check"),), snooping=False)
    result = run_variant(root, variant)
    assert not result.adjustment.solution.groups
    rms = result.rms_per_strip()
    assert all(e["control"]["n"] == 0 and e["check"]["n"] > 0 for e in rms.values())
    dg = run_variant(root, Variant("DG", "DG", snooping=False))   # the same orientation, its checks a subset
    mine = {(p, s): (a, b) for p, s, a, b in zip(result.checks.point, result.checks.strip, result.checks.line,
                                                 result.checks.pixel)}
    theirs = list(zip(dg.checks.point, dg.checks.strip, dg.checks.line, dg.checks.pixel))
    assert theirs and len(mine) > len(theirs)
    assert all(np.allclose(mine[(p, s)], (a, b), atol=1e-9) for p, s, a, b in theirs)
    folder = write_results(result)
    assert (folder / "report.json").exists() and (folder / "orientation.json").exists()
