"""The recommendation's weighing of the evidence (scangeo.strategy.evidence) on residuals with known answers."""
from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
from scipy import stats

from scangeo.strategy.crossvalidation import aic_of
from scangeo.strategy.evidence import (
    Z95,
    Evidence,
    Residuals,
    TieBreak,
    f_test,
    independent_check,
    paired,
    weigh,
    worse_at_checks,
)


def _rows(prefix: str, n: int, along: np.ndarray, across: np.ndarray, strips=("01", "02")) -> Residuals:
    points = np.array([f"{prefix}{i:03d}" for i in range(n)], dtype=object)
    strip = np.array([strips[i % len(strips)] for i in range(n)], dtype=object)
    return Residuals(points, strip, np.arange(n, dtype=float) * 10.0, np.asarray(along, float),
                     np.asarray(across, float))


def test_paired_comparison_is_the_diebold_mariano_statistic():
    rng = np.random.default_rng(1)
    noise = rng.normal(0.0, 0.3, (2, 80))
    a = _rows("K", 80, noise[0] + 0.3, noise[1])
    b = _rows("K", 80, noise[0], noise[1])
    d = paired(a, b)
    q = a.q - b.q
    # the same points: the difference of squared errors, its standard error over the effective count
    rho = d.rho
    se = np.std(q, ddof=1) / math.sqrt(80 * (1 - rho) / (1 + rho))
    assert d.n == 80 and d.z == pytest.approx(q.mean() / se)
    assert d.rms_a == pytest.approx(a.rms()) and d.rms_b == pytest.approx(b.rms())
    assert d.noise == pytest.approx(Z95 * se / (a.rms() + b.rms()))
    assert d.delta > 0 and d.significant  # a carries a systematic 0.3 px more along track on every point
    # only the measurements both have are compared
    c = _rows("K", 40, noise[0][:40], noise[1][:40])
    assert paired(a, c).n == 40 and paired(a, _rows("X", 40, noise[0][:40], noise[1][:40])) is None


def test_serial_correlation_widens_the_noise():
    # a difference that changes slowly along the strip (one orientation error) counts fewer independent rows
    n = 120
    base = np.full(n, 0.3)
    smooth = 0.2 * np.sin(np.linspace(0.0, 3.0, n))
    a = _rows("K", n, base + smooth, base, strips=("01",))
    b = _rows("K", n, base, base, strips=("01",))
    d = paired(a, b)
    assert d.rho == pytest.approx(0.9)  # clipped
    iid = np.std(a.q - b.q, ddof=1) / math.sqrt(n)
    assert d.noise > 4.0 * Z95 * iid / (a.rms() + b.rms())


def test_f_test_of_the_check_point_mean_squares():
    rng = np.random.default_rng(2)
    a = _rows("K", 60, rng.normal(0, 0.5, 60), rng.normal(0, 0.5, 60))
    b = _rows("K", 50, rng.normal(0, 0.3, 50), rng.normal(0, 0.3, 50))
    f, p = f_test(a, b)
    assert f == pytest.approx(np.mean(a.q) / np.mean(b.q))
    assert p == pytest.approx(stats.f.sf(f, 120, 100)) and p < 0.05
    # no point in common: the F test alone says a is worse
    other = Residuals(np.array([f"L{i:03d}" for i in range(50)], dtype=object), b.strip, b.line, b.along, b.across)
    assert "F = " in worse_at_checks(Evidence(check=a), Evidence(check=other))
    assert worse_at_checks(Evidence(check=other), Evidence(check=a)) is None


def _case(rng, cv_bias: dict, check_bias: dict, n_cv=48, n_check=140) -> dict[str, Evidence]:
    """Per variant: held-out control (E*) and check points (K*) sharing the measurement noise, plus the
    variant's own systematic error (px) at each."""
    cv_noise = rng.normal(0.0, 0.3, (2, n_cv))
    ck_noise = rng.normal(0.0, 0.3, (2, n_check))
    out = {}
    for name in cv_bias:
        out[name] = Evidence(_rows("E", n_cv, cv_noise[0] + cv_bias[name], cv_noise[1]),
                             _rows("K", n_check, ck_noise[0] + check_bias[name] * np.sin(np.arange(n_check)),
                                   ck_noise[1]))
    return out


INFO = TieBreak(aic={"SE": 900.0, "S2": 500.0, "S4": 520.0}, group={"SE": "a", "S2": "b", "S4": "c"},
                control={"SE": 48, "S2": 48, "S4": 72})


def test_the_check_points_overrule_a_cross_validation_that_cannot_see_the_strip_middle():
    # the case: S2 best in cross-validation (the control bands), the worst at the check points
    evidence = _case(np.random.default_rng(3), {"SE": 0.12, "S2": 0.0, "S4": 0.08},
                     {"SE": 0.9, "S2": 2.2, "S4": 0.7})
    d = weigh(["SE", "S2", "S4"], evidence, INFO, folds=4)
    assert d.cv_choice == "S2" and d.check_choice == "S4"
    assert d.recommended == "S4" and not d.contradicts_checks
    assert set(d.rejected_by_checks["S2"]) >= {"SE", "S4"}  # significantly worse than both at the check points
    assert "S2" in d.disagreement and "S4" in d.disagreement and "cannot see" in d.disagreement
    assert d.margin.startswith("S4, ") and "at the check points" in d.margin and "in cross-validation" in d.margin
    # the check points measure S4 independently: chosen without any fold of them
    assert d.independent["same"] == d.independent["folds"] == 4
    assert d.independent["rms_px"] == pytest.approx(evidence["S4"].check.rms())


def test_within_the_noise_the_tie_break_decides_and_says_so():
    evidence = _case(np.random.default_rng(4), {"SE": 0.5, "S2": 0.0, "S4": 0.0}, {"SE": 1.5, "S2": 0.0, "S4": 0.0})
    d = weigh(["SE", "S2", "S4"], evidence, INFO)
    assert d.recommended == "S4"  # S2 and S4 alike: the one resting on more control
    assert "within the noise" in d.margin and "S2 within the noise" in d.reason
    assert d.disagreement is None and "SE" in d.rejected_by_checks


def test_without_check_points_the_cross_validation_decides_with_its_noise():
    rng = np.random.default_rng(5)
    evidence = {n: Evidence(cv=e.cv) for n, e in _case(rng, {"SE": 0.8, "S2": 0.0, "S4": 0.5},
                                                        {"SE": 0, "S2": 0, "S4": 0}).items()}
    d = weigh(["SE", "S2", "S4"], evidence, INFO)
    assert d.recommended == "S2" and d.check_choice is None and d.disagreement is None
    assert "no check points" in d.reason and "in cross-validation" not in d.margin
    assert "beyond the noise" in d.margin and d.independent == {}


def test_independent_check_names_the_choices_when_they_depend_on_the_check_points():
    # S2 and S4 alike in cross-validation, S2 slightly better at the check points on one half only
    rng = np.random.default_rng(6)
    evidence = _case(rng, {"SE": 0.4, "S2": 0.0, "S4": 0.0}, {"SE": 1.0, "S2": 0.0, "S4": 0.0})
    half = evidence["S4"].check
    worse = half.along + np.where(np.arange(half.n) < half.n // 2, 0.45, 0.0)
    evidence["S4"].check = Residuals(half.point, half.strip, half.line, worse, half.across)
    out = independent_check(["SE", "S2", "S4"], evidence, INFO, "S2", folds=2)
    assert out["folds"] == 2 and len(out["chosen"]) == 2 and out["n"] == evidence["S2"].check.n
    if out["same"] == 2:
        assert out["rms_px"] == pytest.approx(evidence["S2"].check.rms()) and "independently" in out["text"]
    else:
        assert "took part in the choice" in out["text"]


def test_no_disagreement_when_the_lower_check_rms_comes_from_other_check_points():
    # S2's check points include the break bands (S4's control), where it happens to fit well: its rms over its
    # own check points is the lowest, but on the check points both predicted S4 is better, as in cross-validation
    rng = np.random.default_rng(7)
    e = _case(rng, {"SE": 0.6, "S2": 0.25, "S4": 0.0}, {"SE": 1.0, "S2": 0.05, "S4": 0.0})
    bands = _rows("B", 60, rng.normal(0, 0.05, 60), rng.normal(0, 0.05, 60))
    e["S2"].check = Residuals.concat([e["S2"].check, bands])
    d = weigh(["SE", "S2", "S4"], e, INFO)
    assert d.cv_choice == "S4" and d.check_choice == "S2" and d.recommended == "S4"
    assert paired(e["S4"].check, e["S2"].check).delta <= 0
    assert d.disagreement is None


def test_the_tie_break_weighs_fit_against_unknowns_for_prediction():
    """AIC = vTPv + 2u from a summary's sigma0 and accounting. vienna2000 seed 105 (4 control points per band):
    P4 and S4 of one attribution on identical observations, S4 12 unknowns richer and 89 lower in vTPv; the
    split model predicts better (its true error 73 % of P4's), which AIC says and BIC (u ln n: 122.6 for 12
    unknowns) would not."""
    def summary(sigma0, unknowns, pseudo):
        return SimpleNamespace(sigma0=sigma0, accounting={"observations": 27247, "pseudo_observations": pseudo,
                                                          "unknowns": unknowns})
    p4, s4 = summary(1.214, 27063, 21), summary(1.020, 27075, 33)
    assert aic_of(s4) == pytest.approx(1.020**2 * 205 + 2 * 27075)
    assert aic_of(p4) - aic_of(s4) == pytest.approx(1.214**2 * 205 - 1.020**2 * 205 - 24)
    bic_difference = (1.214**2 - 1.020**2) * 205 - 12 * math.log(27268)
    assert bic_difference < 0 < aic_of(p4) - aic_of(s4)
    evidence = _case(np.random.default_rng(5), {"P4": 0.0, "S4": 0.0}, {"P4": 0.0, "S4": 0.0})
    info = TieBreak(aic={"P4": aic_of(p4), "S4": aic_of(s4)}, group={"P4": "g", "S4": "g"},
                    control={"P4": 45, "S4": 45})
    assert weigh(["P4", "S4"], evidence, info).recommended == "S4"
    assert aic_of(SimpleNamespace(sigma0=None, accounting={})) is None
