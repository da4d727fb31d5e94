"""Which strip drifts, and how sure: the search's moves between strips, the runner-up attribution, ambiguity."""
from __future__ import annotations

import numpy as np
import pytest

from scangeo.adjustment.diagnosis import patterns
from scangeo.adjustment.diagnosis.attribution import (
    ADOPT_BIC,
    AMBIGUOUS_BIC,
    RICHER_BIC,
    Attribution,
    AttributionCheck,
    adopt,
    attribution_checks,
    no_problem_alternatives,
    preferred_by_split_model,
    split_model_difference,
)
from scangeo.adjustment.diagnosis.local_fit import BlockIndex, CurrentFit
from scangeo.adjustment.diagnosis.patterns import (
    Fit,
    PatternData,
    SelectionOptions,
    evaluate,
    line_map,
    neighbours,
    select_breaks,
)

from .test_patterns import N, _three_strips, kinked


def excursion(amp: float, ends: float):
    """Strip 02's height: from -ends up to +amp at line 340, down to -amp at 700, to +ends at the end."""
    def error(s, line):
        if s != 1:
            return 0.0, 0.0
        return float(np.interp(line, [0, 340, 700, N - 1], [-ends, amp, -amp, ends])), 0.0
    return error


def test_neighbours_and_the_line_where_a_neighbour_sees_the_same_ground():
    data = _three_strips(kinked, seed=0)
    assert neighbours(data, 0) == [1] and neighbours(data, 1) == [0, 2]
    a, b = line_map(data, 0, 1)  # strip 02 is flown the other way: line N - 1 - l sees what line l of 01 sees
    assert b == pytest.approx(-1.0) and a == pytest.approx(N - 1.0)
    assert line_map(data, 0, 2) is None  # no tie point in common


def test_the_runner_up_of_a_clear_attribution():
    data = _three_strips(kinked, seed=0)
    fit = select_breaks(data)
    assert [len(b) for b in fit.breaks] == [0, 2, 0]
    [check] = attribution_checks(data, fit)
    r = check.runner_up
    assert check.strip == "02" and r is not None and r.kind in ("moved", "merged", "dropped")
    # its criterion is the alternative model's, under the same serial correlation
    alt = min((a for a in fit.alternatives if a.strip == 1 and a.kind == r.kind and
               (a.kind == "dropped" or data.strips[a.other] == r.other)), key=lambda a: a.fit.bic)
    assert r.delta_bic == pytest.approx(alt.fit.bic - fit.bic)
    assert r.delta_bic == pytest.approx(evaluate(data, alt.fit.breaks, fit.rho or None, 1, alt.fit.constant).bic
                                        - fit.bic)
    # the drift on a neighbour instead, or shared with one, is far worse here
    assert r.delta_bic > AMBIGUOUS_BIC and check.richer.kind == "shared" and check.richer.delta_bic > 0
    assert not check.ambiguous and check.plausible == [] and "clear" in check.sentence()


def test_functions_on_both_neighbours_are_merged_into_the_middle_strip():
    # growing break by break puts pairs of breaks on the edge strips first (each explains one overlap at half
    # the rank of the middle strip's); the merge move gives the drift back to the middle strip
    for seed in (0, 2):
        fit = select_breaks(_three_strips(excursion(10.0, 6.0), seed=seed))
        assert [len(b) for b in fit.breaks] == [0, 2, 0], (seed, fit.breaks)
        assert np.allclose(fit.breaks[1], [340, 700], atol=60)


def test_two_breaks_at_once_where_one_alone_does_not_pay():
    # rising and falling back: a straight line takes the trend, and no single kink pays for itself
    data = _three_strips(excursion(8.0, 0.0), seed=0, noise=2.0)
    index = BlockIndex(data)
    linear = CurrentFit(index, [[], [], []], 1, {0, 2})
    now = evaluate(data, [[], [], []], None, 1, {0, 2}).bic
    singles = patterns._richer(data, linear, SelectionOptions())
    assert min(singles.fit(i).bic for i in range(len(singles.models))) >= now
    pairs = patterns._richer_by_two(data, linear, SelectionOptions(), None)
    best = pairs.best()
    assert pairs.fit(best).bic < now - 10 and pairs.models[best][0] == 1
    assert np.allclose(pairs.breaks(best)[1], [340, 700], atol=60)
    fit = select_breaks(data)
    assert fit.breaks[0] == () and fit.breaks[2] == () and np.allclose(fit.breaks[1], [340, 700], atol=60)


def edge(s, line):
    """Strip 03 (an edge strip, one overlap) drifts; strip 02 could take it over in that overlap."""
    if s != 2:
        return 0.0, 0.0
    z = float(np.interp(line, [0, 300, 700, N - 1], [2.0, 9.0, -9.0, -2.0]))
    return z, 0.2 * z


def thinned(data: PatternData, every: int) -> PatternData:
    """Only every ``every``-th tie row of the overlap 01-02 kept (as if the cleaning had removed the rest)."""
    rows01 = np.unique(data.term_row[data.term_strip == 0])
    keep = np.ones(data.n, bool)
    keep[rows01] = False
    keep[rows01[::every]] = True
    new = np.full(data.n, -1)
    new[keep] = np.arange(int(keep.sum()))
    t = keep[data.term_row]
    return PatternData(data.value[keep], data.channel[keep], new[data.term_row[t]], data.term_strip[t],
                       data.term_component[t], data.term_line[t], data.term_weight[t], data.strips, data.n_lines,
                       data.channels, data.components)


def test_an_edge_strips_drift_is_clear_with_its_neighbours_other_overlap_and_ambiguous_without():
    full = _three_strips(edge, seed=2, noise=1.5)
    fit = select_breaks(full)
    assert [bool(b) for b in fit.breaks] == [False, False, True]
    [check] = attribution_checks(full, fit)
    # the runner-up gives the drift to strip 02, whose other overlap (with 01) says no
    assert check.runner_up.kind == "moved" and check.runner_up.other == "02" and not check.ambiguous
    # with that overlap thinned to a fifteenth, strip 02 can take the drift over nearly as well
    thin = thinned(full, 15)
    fit = select_breaks(thin)
    assert [bool(b) for b in fit.breaks] == [False, False, True]
    [check] = attribution_checks(thin, fit)
    assert check.ambiguous and check.runner_up.delta_bic < AMBIGUOUS_BIC and "AMBIGUOUS" in check.sentence()
    [other] = check.plausible
    assert other.kind == "moved" and list(other.breaks) == ["02"] and len(other.breaks["02"]) == 2


def test_without_a_problem_strip_the_runner_up_is_the_best_model_with_one():
    quiet = lambda s, line: (0.0, 0.0)  # noqa: E731
    data = _three_strips(quiet, seed=1)
    fit = select_breaks(data)
    assert not any(fit.breaks)
    [check] = attribution_checks(data, fit)
    # a richer model casts doubt only when it fits better: in noise the best placed breaks come close
    assert check.strip is None and check.runner_up is None and check.richer.kind == "breaks"
    assert check.richer.delta_bic > RICHER_BIC and not check.ambiguous and "no problem strip" in check.sentence()


def test_without_a_problem_strip_every_strip_that_scores_best_is_an_alternative():
    """A search that missed the drift: the block drifts on strip 02, the model has no breaks. The best model
    with breaks is scored on each of the best three strips (not only the best one: on a thinned vienna2000
    the best was the neighbour of the drifting strip), and every one that beats "none" is plausible."""
    data = _three_strips(kinked, seed=0)
    none = evaluate(data, [[], [], []], None, 1, (0, 1, 2))
    found = no_problem_alternatives(data, none)
    assert sorted(a.strip for a in found) == ["01", "02", "03"] and all(a.kind == "breaks" for a in found)
    assert [a.delta_bic for a in found] == sorted(a.delta_bic for a in found)
    best = found[0]
    assert best.strip == "02" and best.delta_bic < -100 and list(best.breaks) == ["02"] and len(best.breaks["02"]) == 2
    [check] = attribution_checks(data, none)
    assert check.ambiguous and "02" in [a.strip for a in check.plausible]
    assert all(a.delta_bic < RICHER_BIC for a in check.plausible)
    assert {a.strip for a in check.plausible} == {a.strip for a in found if a.delta_bic < RICHER_BIC}


def test_a_model_far_better_than_the_searchs_replaces_it():
    """A search that missed the drift of strip 02 (kinks at lines 300 and 700): its best model with breaks beats
    "none" far beyond the adoption threshold, so it becomes the diagnosis's model, polished as the search's own
    are (its breaks at their best lines), and its attribution is checked again: "none" is now its dropped
    alternative, as far above."""
    data = _three_strips(kinked, seed=0)
    none = evaluate(data, [[], [], []], None, 1, (0, 1, 2))
    checks = attribution_checks(data, none)
    fit, after, adopted = adopt(data, none, checks)
    [a] = adopted
    assert a.kind == "breaks" and a.strip == "02" and a.delta_bic < -ADOPT_BIC
    assert fit.breaks[0] == () and fit.breaks[2] == () and set(fit.constant) == {0, 2}
    assert np.allclose(fit.breaks[1], [300, 700], atol=25), fit.breaks
    # what the search itself finds on this block
    assert np.allclose(fit.breaks[1], select_breaks(data).breaks[1], atol=5)
    [check] = after
    assert check.strip == "02" and not check.ambiguous
    dropped = [x for x in check.alternatives if x.kind == "dropped"]
    assert len(dropped) == 1 and dropped[0].breaks == {} and dropped[0].delta_bic > ADOPT_BIC


def test_the_adoption_threshold_is_a_strict_bound():
    # the same block: adopted when the best model with breaks beats the search's by more than the threshold
    data = _three_strips(kinked, seed=1)
    none = evaluate(data, [[], [], []], None, 1, (0, 1, 2))
    checks = attribution_checks(data, none)
    gain = -min(a.delta_bic for a in checks[0].alternatives)
    assert adopt(data, none, checks, threshold=gain + 0.01)[2] == []
    kept, same, _ = adopt(data, none, checks, threshold=gain + 0.01)
    assert kept is none and same is checks
    assert [a.strip for a in adopt(data, none, checks, threshold=gain - 0.01)[2]] == ["02"]


def test_no_model_is_adopted_on_blocks_without_a_drift():
    quiet = lambda s, line: (0.0, 0.0)  # noqa: E731
    for seed in range(3):
        data = _three_strips(quiet, noise=1.5, seed=seed)
        fit = select_breaks(data)
        checks = attribution_checks(data, fit)
        assert not any(fit.breaks) and adopt(data, fit, checks)[2] == []


def test_the_split_models_opinion_can_make_an_attribution_ambiguous():
    # the adjustment's own criterion at both attributions' lines: -2 ln LR for as many unknowns, + u ln n else
    fits = {("02",): (330.0, 1.1, 60), ("03",): (338.0, 1.12, 60), (): (420.0, 1.3, 48)}

    def cost(breaks):
        return fits[tuple(breaks)]

    chosen = {"02": (2400.0, 4900.0)}
    moved = split_model_difference(cost, chosen, {"03": (2400.0, 4900.0)})
    assert moved == pytest.approx(8.0 / 1.1 ** 2)
    n = 330.0 / 1.1 ** 2 + 60
    assert split_model_difference(cost, chosen, {}) == pytest.approx(90.0 / 1.1 ** 2 - 12 * np.log(n))
    assert split_model_difference(lambda b: (np.inf, np.nan, 0), chosen, {}) is None
    # a competing attribution the BIC puts 14 worse but the split model within 10: ambiguous
    a = Attribution("moved", "02", "03", {"03": (2400.0, 4900.0)}, 214.0, 14.0)
    check = AttributionCheck("02", a, None, [], AMBIGUOUS_BIC, [a])
    check.update()
    assert not check.ambiguous
    a.delta_split = moved
    check.update()
    assert check.ambiguous and check.plausible == [a] and "split model +6.6" in check.sentence()
    # a richer alternative is not judged by it
    r = Attribution("shared", "02", "03", {"02": (2400.0,), "03": (2400.0,)}, 214.0, 14.0, delta_split=-5.0)
    assert not r.doubt


def test_a_competing_attribution_the_split_model_prefers_beyond_the_threshold_is_adopted():
    fit = Fit(((), (), ()), 0.0, 0.0, 0, {}, {})

    def alt(kind, delta_bic, delta_split):
        return Attribution(kind, "01", "02", {"02": (2400.0, 4900.0)}, 200.0 + delta_bic, delta_bic,
                           delta_split=delta_split, fit=fit)

    merged, moved = alt("merged", 89.4, -225.6), alt("moved", 80.3, -116.9)
    check = AttributionCheck("01", merged, None, [], AMBIGUOUS_BIC, [moved, merged])
    assert preferred_by_split_model([check]) is merged
    # within the threshold, or a richer alternative (its extra breaks searched), or none asked: none adopted
    for a in (alt("moved", 12.0, -AMBIGUOUS_BIC), alt("moved", 12.0, None), alt("shared", 12.0, -50.0)):
        assert preferred_by_split_model([AttributionCheck("01", a, None, [], AMBIGUOUS_BIC, [a])]) is None
    assert preferred_by_split_model([check], threshold=300.0) is None


def test_an_adopted_model_is_what_the_diagnosis_and_the_run_summary_name():
    from types import SimpleNamespace

    from scangeo.adjustment.diagnosis.diagnose import Diagnosis, adopted_note
    from scangeo.adjustment.diagnosis.output import summary_lines
    from scangeo.adjustment.diagnosis.patterns import BreakEstimate
    from scangeo.cli.run import summary_lines as run_summary

    none = Fit(((), (), ()), 120.0, 0.0, 6, {}, {}, constant=(0, 1, 2))
    chosen = Fit(((), (2240.0, 4772.0), ()), 39.7, 0.0, 12, {}, {}, constant=(0, 2))
    a = Attribution("breaks", "02", None, {"02": (2240.0, 4772.0)}, 39.7, -80.3, fit=chosen)
    d = Diagnosis("p", ["01", "02", "03"], {"01": 7000, "02": 7000, "03": 7000},
                  [BreakEstimate("02", 2240.0, 2100.0, 2400.0), BreakEstimate("02", 4772.0, 4600.0, 4900.0)],
                  chosen, none, 1.0, adopted=[a], search=none)
    assert d.problem_strips == ["02"] and d.search_problem_strips == []
    adopted = d.as_dict()["adopted"]
    assert adopted["search_problem_strips"] == [] and adopted["threshold"] == ADOPT_BIC
    assert adopted["delta_bic"] == -80.3 and adopted["steps"][0]["breaks"] == {"02": [2240.0, 4772.0]}
    assert Diagnosis("p", ["01"], {"01": 10}, [], none, none, 1.0).as_dict()["adopted"] is None
    assert "PROBLEM STRIP" in summary_lines(d)[2]
    note = adopted_note(none, [a], d.strips)
    assert note.startswith("the search's own model (no problem strip) is replaced by a problem strip 02") and \
        f"more than {ADOPT_BIC:g} below the model it replaces by the BIC" in note and "moved it" not in note
    # the adopted alternative put the drift on strip 03, the search's move step then on strip 02
    on03 = Attribution("breaks", "03", None, {"03": (2380.0, 4900.0)}, 40.0, -38.3, fit=chosen)
    assert "; the search's last steps then moved it to problem strips 02 (" in adopted_note(none, [on03], d.strips,
                                                                                           chosen)
    stage = {"diagnose": {"problem_strips": {"02": [2240, 4772]}, "search_problem_strips": []}}
    result = SimpleNamespace(stages=[], summary_of=lambda name: stage.get(name, {}), manifest="m", seconds=1.0)
    first = [line for line in run_summary(result) if line.startswith("problem strips")]
    assert first == ["problem strips: 02 (breaks at lines 2240, 4772) (the attribution's: the search's own model "
                     "had none)"]
    del stage["diagnose"]["search_problem_strips"]  # the search's model stands
    assert [line for line in run_summary(result) if line.startswith("problem strips")] == \
        ["problem strips: 02 (breaks at lines 2240, 4772)"]
