"""The break selection's local update (local_fit) against refitting the whole block (patterns.evaluate)."""
from __future__ import annotations

import numpy as np
import pytest

from scangeo.adjustment.diagnosis.diagnose import _ray_weights
from scangeo.adjustment.diagnosis.local_fit import MARGIN, BlockIndex, CurrentFit, StripProbe
from scangeo.adjustment.diagnosis.patterns import PatternData, break_intervals, evaluate, select_breaks

N = 2000  # lines per strip

# two numerical routes compared: run under a second BLAS kernel too (.ci/run)
pytestmark = pytest.mark.numerics


def _block(n_strips=7, problem=3, seed=0, per_overlap=70, control_every=2) -> PatternData:
    """Parallel strips 500 m apart, flown to and fro at 1000 m; tie points in every overlap see their two
    strips' across-track and vertical errors with the weights of a real ray intersection (whose common
    across-track shift is nearly, not exactly, unobservable: the strips' headings differ a little);
    control rows (a second channel) on every other strip. Strip ``problem`` has a kinked height error."""
    rng = np.random.default_rng(seed)
    heading = rng.normal(0.0, 0.003, n_strips)
    across = np.column_stack([np.cos(heading), np.sin(heading), np.zeros(n_strips)])
    value, channel, trow, tstrip, tcomp, tline, tw = [], [], [], [], [], [], []

    def error(s, line):
        if s != problem:
            return np.array([0.3 * s, 0.1])
        z = np.interp(line, [0, 600, 1300, N - 1], [2.0, 12.0, -10.0, -3.0])
        return np.array([0.2 * z, z])

    for a in range(n_strips - 1):
        b = a + 1
        for _ in range(per_overlap):
            la = rng.uniform(0, N - 1)
            lines = {a: la, b: N - 1 - la}
            point = np.array([500.0 * a + 250.0 + rng.normal(0, 60), 0.0, rng.normal(0, 40)])
            centres = np.array([[500.0 * s, rng.normal(0, 20), 1000.0 + rng.normal(0, 5)] for s in (a, b)])
            g = _ray_weights(centres, point)
            r = len(value)
            y = rng.normal(0, 0.3)
            for s, gs in zip((a, b), g):
                w = (-float(gs @ across[s]), -float(gs[2]))
                e = error(s, lines[s])
                y += w[0] * e[0] + w[1] * e[1]
                for k in (0, 1):
                    trow.append(r)
                    tstrip.append(s)
                    tcomp.append(k)
                    tline.append(lines[s])
                    tw.append(w[k])
            value.append(y)
            channel.append(0)
    for s in range(0, n_strips, control_every):
        for line in rng.uniform(0, N - 1, 12):
            w = rng.normal(0, 1, 2)
            r = len(value)
            value.append(float(w @ error(s, line)) + rng.normal(0, 0.2))
            channel.append(1)
            for k in (0, 1):
                trow.append(r)
                tstrip.append(s)
                tcomp.append(k)
                tline.append(line)
                tw.append(w[k])
    return PatternData(np.array(value), np.array(channel), np.array(trow), np.array(tstrip), np.array(tcomp),
                       np.array(tline), np.array(tw), tuple(f"{s + 1:02d}" for s in range(n_strips)),
                       (N,) * n_strips, ("misclosure_m", "control_px"), ("across_m", "vertical_m"))


@pytest.fixture(scope="module")
def block():
    return _block()


def _tolerance(fit: CurrentFit, ref) -> float:
    """What rounding may move a candidate's criterion by, on any BLAS kernel: per channel, a change of
    ``eps cond(A) |y|^2`` of its residual sum of squares (both routes are backward stable: the update's QR
    factors and ``lstsq``'s SVD are exact for a change of the design of ``eps`` of itself, which moves the
    residual by ``eps cond(A)`` of ``y``), 16 for the sums' lengths, through ``neff log(RSS)``."""
    eps = np.finfo(float).eps
    out = 0.0
    for c, name in enumerate(ref.rss):
        sv = np.linalg.svd(fit.channels[c].R, compute_uv=False)
        y = fit.index.data.value[fit.index.rows[c]]
        out += ref.n_eff[name] * 16.0 * eps * (sv[0] / sv[-1]) * float(y @ y) / ref.rss[name]
    return out


@pytest.mark.parametrize("degree, most_untrusted", [(1, 4), (2, 16)])
def test_a_candidates_criterion_is_the_refitted_ones(block, degree, most_untrusted):
    ns = len(block.strips)
    rng = np.random.default_rng(1)
    index = BlockIndex(block)
    rho = {"misclosure_m": 0.3}
    bases = [([[] for _ in range(ns)], set(range(ns))), ([[], [], [], [700.0, 1250.0], [], [], []], {0, 1, 2, 4, 6})]
    checked, untrusted = 0, []
    for breaks, constant in bases:
        fit = CurrentFit(index, breaks, degree, constant)
        exact = evaluate(block, breaks, rho, degree, constant)
        assert fit.bic(rho, sum(map(len, breaks))) == pytest.approx(exact.bic, abs=_tolerance(fit, exact))
        for s in range(ns):
            probe = StripProbe(fit, s)
            for trial in ([], [1000.0], sorted(rng.uniform(200, N - 200, 2))):
                for const in ((True, False) if not trial else (False,)):
                    nb = sum(len(b) for i, b in enumerate(breaks) if i != s) + len(trial)
                    approx = probe.bic(trial, const, rho, nb)
                    model = [list(b) for b in breaks]
                    model[s] = list(trial)
                    ref = evaluate(block, model, rho, degree, (constant - {s}) | ({s} if const else set()))
                    checked += 1
                    if approx is None:  # a function the data hardly see: left to the refit
                        untrusted.append((s, tuple(trial), const))
                        continue
                    # the criterion and deviance to rounding (far within the margin the selection refits in)
                    tol = _tolerance(fit, ref)
                    assert tol < MARGIN / 100
                    assert approx[0] == pytest.approx(ref.bic, abs=tol), (s, trial, const)
                    assert approx[1] == pytest.approx(ref.deviance, abs=tol)
    assert checked == 2 * 7 * 4
    assert len(untrusted) <= most_untrusted, untrusted
    # and the rank the refit counts: a made-linear strip adds 2 columns per channel it is seen in (degree 2:
    # and a bubble per component)
    fit = CurrentFit(index, bases[0][0], degree, bases[0][1])
    linear = StripProbe(fit, 0).rss_rank([], False)
    assert linear is not None
    assert [rank for _, rank in linear] == [2 * ns + 2 * degree, 2 * 4 + 2 * degree]


def test_the_selection_is_the_one_refitting_every_candidate(block, monkeypatch):
    calls = {"n": 0}
    real = evaluate

    def counted(*args, **kwargs):
        calls["n"] += 1
        return real(*args, **kwargs)

    monkeypatch.setattr("scangeo.adjustment.diagnosis.patterns.evaluate", counted)
    fast = select_breaks(block)
    fast_intervals = break_intervals(block, fast)
    fast_calls = calls["n"]
    assert fast.breaks[3] and all(not b for s, b in enumerate(fast.breaks) if s != 3)
    assert np.allclose(fast.breaks[3], [600, 1300], atol=40)
    # no candidate trusted: every one refitted, as the selection did before the local update
    monkeypatch.setattr(StripProbe, "rss_rank", lambda self, breaks_s, constant_s: None)
    monkeypatch.setattr(CurrentFit, "bic", lambda self, rho, n_breaks: None)
    calls["n"] = 0
    slow = select_breaks(block)
    slow_intervals = break_intervals(block, slow)
    assert fast_calls < 0.1 * calls["n"], (fast_calls, calls["n"])
    assert slow.breaks == fast.breaks and slow.constant == fast.constant and slow.bic == fast.bic
    assert [(b.strip, b.line, b.low, b.high) for b in slow_intervals] == \
        [(b.strip, b.line, b.low, b.high) for b in fast_intervals]


def _shift_observed(delta: float) -> PatternData:
    """The test block whose ties see the strips' common across-track shift only through their weights'
    relative differences of about ``delta`` (0: equal and opposite weights, not observed at all)."""
    data = _block()
    tie = data.channel[data.term_row] == 0
    across = tie & (data.term_component == 0)
    first = np.r_[True, data.term_row[1:] != data.term_row[:-1]]
    wiggle = 1.0 + delta * np.random.default_rng(5).normal(size=int(across.sum()))
    data.term_weight[across] = np.where(first[across], 0.8, -0.8) * wiggle
    return data


def test_an_unobservable_common_shift_is_left_to_the_refit():
    # equal and opposite across-track weights in every tie: the normal equations are singular, no update
    # is trusted
    data = _shift_observed(0.0)
    ns = len(data.strips)
    fit = CurrentFit(BlockIndex(data), [[] for _ in range(ns)], 1, set(range(ns)))
    assert not fit.channels[0].good and fit.bic(None, 0) is None
    assert StripProbe(fit, 2).bic([], False, None, 0) is None


def test_the_update_is_trusted_only_where_the_refits_rank_is_certain():
    # the common shift observed less and less: the design's smallest singular value ratio falls about as
    # delta / 2. The update is trusted down to local_fit.CONDITION (1e-6) and then agrees with the refit;
    # lstsq lowers the rank only near its 1e-9, inside the band left to the refit
    ns = len(_block().strips)
    trusted, ranks = {}, {}
    for delta in (1e-1, 1e-3, 1e-5, 1e-7, 1e-9):
        data = _shift_observed(delta)
        fit = CurrentFit(BlockIndex(data), [[] for _ in range(ns)], 1, set(range(ns)))
        ranks[delta] = evaluate(data, [[] for _ in range(ns)], None, 1, set(range(ns))).k
        probes = []
        for s in range(ns):
            approx = StripProbe(fit, s).bic([], False, None, 0)
            probes.append(approx is not None)
            if approx is not None:
                ref = evaluate(data, [[] for _ in range(ns)], None, 1, set(range(ns)) - {s})
                assert approx[0] == pytest.approx(ref.bic, abs=_tolerance(fit, ref)), (delta, s)
        assert len(set(probes)) == 1
        trusted[delta] = probes[0]
    assert trusted == {1e-1: True, 1e-3: True, 1e-5: True, 1e-7: False, 1e-9: False}
    full = 2 * ns + 8  # two constants per strip in the ties, per controlled strip in the control rows
    assert ranks == {1e-1: full, 1e-3: full, 1e-5: full, 1e-7: full, 1e-9: full - 2}
