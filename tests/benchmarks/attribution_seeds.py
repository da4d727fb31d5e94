"""The attribution and the recommendation over many seeds: vienna2000, full length, 20 blunders (docs/adjustment.md).

Not collected by pytest. For every seed: simulate vienna2000 without images and with ``--blunders`` blunders
(``points.blunders``), then ``scangeo run PROJECT --until compare`` (check, clean, diagnose, compare with the
run's 4-fold cross-validation, as a user would), and print one row: the problem strips found (and the
injected one), the search's own (when the diagnosis adopted an alternative in its place), the runner-up
attribution and its BIC difference, whether the attribution was called ambiguous, the variants built, the
recommended variant (and whether the strips it corrects are the injected ones) and its pooled true error as
a % of the best variant's, the cross-validation's and the check points' own choices, whether the two
disagreed (and the run said so), and whether the recommended variant is significantly worse at the check
points than another adjusted variant (F test of the pooled check-point mean squares as the table prints
them, 5 %) without the run's summary saying so. The last lines sum up.

    python tests/benchmarks/attribution_seeds.py OUT [--seeds 1 2 ... 40] [--blunders 20] [--ties N] [--control N]
        [--rerun STAGE] [--preset NAME] [--strips N] [--drift-free] [--until diagnose]

``--ties`` and ``--control`` thin the tie and control points (harder attributions); ``--rerun diagnose|compare``
runs the seeds already cleaned again from that stage. ``--drift-free`` simulates the block without the
problem strip's GPS/IMU excursions (and the control bands at its breaks), ``--preset`` and ``--strips``
another block, and ``--until diagnose`` scores the diagnosis alone: per seed, how much the best model with
breaks beats the search's own model when that has none (the change-point effect the adoption threshold is
calibrated on, docs/adjustment.md, "Adoption"), summed up as its range, median and 90 % quantile.

Projects already simulated in OUT are reused; a seed whose run already reached compare is only scored, one
already cleaned runs from the diagnosis on (delete OUT/sN/results to run it all again). Truth is read here
only to score: the true error is computed here from the variants' written orientations
(``results/VARIANT/orientation.json``) with :class:`scangeo.truth.true_error.Truth`, so that a seed compared
before a change of the truth's measure is scored with today's; pooled over the strips, along and across in
pixels (the "true error" the table prints) and on the ground in metres.
"""
from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

from scipy import stats

from scangeo.adjustment.summary import Comparison
from scangeo.io.project import Project
from scangeo.orientation.file import load_adjusted_geometry
from scangeo.pipeline.manifest import Manifest
from scangeo.pipeline.run import run
from scangeo.simulate.block import simulate
from scangeo.simulate.config import load_preset
from scangeo.truth.true_error import Truth


def true_errors(root: Path, names: list[str]) -> dict[str, tuple[float, float]]:
    """Pooled true error of each variant (pixels along and across together; ground metres), from its
    written orientation."""
    project = Project.load(root)
    truth = Truth.load(project)
    out = {}
    for name in names:
        px = gm = n = 0.0
        for s in project.strips:
            e = truth.error(s.id, load_adjusted_geometry(project, name, s.id))
            px += e.n * (e.rms_along_px ** 2 + e.rms_across_px ** 2) / 2
            gm += e.n * e.rms_ground_m ** 2
            n += e.n
        out[name] = (math.sqrt(px / n), math.sqrt(gm / n))
    return out


#: the keys that take the problem strip's GPS/IMU excursions (and the control bands at its breaks) away
DRIFT_FREE = {"gpsimu_errors": {"problem_strip": 0, "breaks_lines": [], "strip": []}}


def project(root: Path, seed: int, blunders: int, ties: int | None = None, control: int | None = None,
            preset: str = "vienna2000", drift_free: bool = False, strips: int | None = None) -> None:
    if not (root / "project.toml").exists():
        points: dict = {"blunders": blunders}
        if ties is not None:
            points["tie_per_overlap"] = ties
        if control is not None:
            points["control_per_band_per_strip"] = control
        overrides = {"output": {"images": False, "truth_ortho": False}, "seed": seed, "points": points,
                     **(DRIFT_FREE if drift_free else {}), **({"flight": {"strips": strips}} if strips else {})}
        simulate(root, load_preset(preset, overrides))


def worse_unsaid(c: Comparison, rec: str, said: str) -> list[str]:
    """The adjusted variants the recommended one is significantly worse than at the check points (one-sided F
    test of the pooled check-point mean squares, 2n degrees of freedom each, 5 %) that the summary ``said``
    does not name."""
    v = c.variant(rec)
    out = []
    n_rec = sum(e.get("check", {}).get("n", 0) for e in v.strips.values())
    for o in c.variants:
        if o.name == rec or o.error is not None or o.strategy == "DG" or o.check_pooled_rms() is None:
            continue
        n_o = sum(e.get("check", {}).get("n", 0) for e in o.strips.values())
        f = (v.check_pooled_rms() / o.check_pooled_rms()) ** 2
        if stats.f.sf(f, 2 * n_rec, 2 * n_o) < 0.05 and o.name not in said:
            out.append(o.name)
    return out


def run_seed(root: Path, until: str, rerun: str | None) -> float:
    """``scangeo run ROOT --until UNTIL`` unless it got there already (a cleaning done is kept; ``rerun``: from
    that stage again); the CPU seconds it took."""
    manifest = Manifest.load(root)
    status = {name: (manifest.stages.get(name) or {}).get("status") for name in ("clean", until)}
    cleaned = status["clean"] in ("ran", "up to date")
    t0 = time.process_time()
    if status[until] not in ("ran", "up to date") or (rerun and cleaned):
        # a cleaning already done is kept (--rerun: from that stage on; the cleaning is not what is measured)
        run(root, until=until, from_stage=(rerun or "diagnose") if cleaned else None)
    return time.process_time() - t0


def alternatives_text(d: dict) -> str:
    """The runner-up, the richer alternative and the other plausible ones of a diagnosis.json, each once."""
    runner = [a[k] for a in d.get("attribution", []) for k in ("runner_up", "richer") if a.get(k)]
    runner += [p for a in d.get("attribution", []) for p in a.get("plausible", []) if p not in runner]
    return "; ".join(dict.fromkeys(  # an alternative two problem strips share is listed once
        f"{r['kind']} {'-'.join(r['breaks']) or 'none'} {r['delta_bic']:+.1f}"
        + (f" (split {r['delta_split']:+.1f})" if r.get("delta_split") is not None else "") for r in runner)) or "–"


def search_verdict(d: dict) -> tuple[list[str], float | None]:
    """The problem strips of the search's own model (before an adopted alternative replaced it), and how much
    the best model with breaks beat it when it had none (-dBIC; None: it had problem strips)."""
    adopted = d.get("adopted")
    if adopted:
        return list(adopted["search_problem_strips"]), (-adopted["delta_bic"] if not adopted["search_problem_strips"]
                                                        else None)
    if d["problem_strips"]:
        return list(d["problem_strips"]), None
    richer = [a["richer"] for a in d.get("attribution", []) if a.get("richer")]
    return [], (-min(r["delta_bic"] for r in richer) if richer else None)


def recommended_strips(name: str, found: list[str]) -> list[str]:
    """The problem strips a recommended variant corrects: its suffix's (``S4-02-03``), the diagnosis's (``S4``),
    or none (DG, BE, SE, SE_DTM)."""
    base, _, suffix = name.partition("-")
    if base[:1] not in ("P", "S") or base.startswith("SE"):
        return []
    return suffix.split("-") if suffix else list(found)


def diagnosis_row(root: Path, seed: int, totals: dict, cpu: float) -> str:
    """A row of the diagnosis alone (``--until diagnose``, e.g. drift-free blocks)."""
    truth = json.loads((root / "truth" / "errors.json").read_text())
    problem = truth["problem_strip"]
    d = json.loads((root / "results" / "diagnosis.json").read_text())
    found = d["problem_strips"]
    search, gain = search_verdict(d)
    right = found == ([str(problem)] if problem else [])
    totals["seeds"] += 1
    totals["right"] += right
    totals["wrong"] += not right
    totals["ambiguous"] += bool(d.get("ambiguous"))
    totals["cpu"] += cpu
    if gain is not None:
        totals["gains"].append(gain)
    return (f"| {seed} | {', '.join(found) or '–'} ({problem or 'none'}){'' if right else ' WRONG'} | "
            f"{', '.join(search) or '–'} | {'–' if gain is None else f'{gain:.1f}'} | {alternatives_text(d)} | "
            f"{'yes' if d.get('ambiguous') else 'no'} | {cpu:.0f} s |")


def seed_row(root: Path, seed: int, totals: dict, cpu: float) -> str:
    truth = json.loads((root / "truth" / "errors.json").read_text())
    problem = truth["problem_strip"]
    injected = [str(problem)] if problem else []
    manifest = Manifest.load(root)
    d = json.loads((root / "results" / "diagnosis.json").read_text())
    c = Comparison.from_dict(json.loads((root / "results" / "comparison.json").read_text()))
    compare = manifest.stages["compare"]["summary"]
    found = d["problem_strips"]
    search, _ = search_verdict(d)
    right = found == injected
    ambiguous = bool(d.get("ambiguous"))
    adjusted = [v for v in c.variants if v.strategy != "DG" and v.error is None]
    rec = compare["recommended"]
    attribution_right = recommended_strips(rec, found) == injected
    true = true_errors(root, [v.name for v in adjusted])
    best = min(adjusted, key=lambda v: true[v.name][0])
    ratio = true[rec][0] / true[best.name][0]
    best_ground = min(true.values(), key=lambda e: e[1])[1]
    ratio_ground = true[rec][1] / best_ground
    unsaid = worse_unsaid(c, rec, " ".join([str(compare.get("disagreement") or ""),
                                            " ".join(compare.get("contradicts_checks") or {})]))
    cv_choice, check_choice = compare.get("cv_choice"), compare.get("check_choice")
    disagree = "yes" if compare.get("disagreement") else "no"
    totals["seeds"] += 1
    totals["right"] += right
    totals["wrong_called"] += (not right) and ambiguous
    totals["wrong"] += not right
    totals["ambiguous"] += ambiguous
    totals["attribution_right"] += attribution_right
    totals["summary_wrong"] += attribution_right and not right
    totals["adopted"] += bool(d.get("adopted"))
    totals["within15"] += ratio <= 1.15
    totals["unsaid"] += bool(unsaid)
    totals["disagree"] += disagree == "yes"
    totals["worst"] = max(totals["worst"], ratio)
    totals["within15_ground"] += ratio_ground <= 1.15
    totals["worst_ground"] = max(totals["worst_ground"], ratio_ground)
    totals["cpu"] += cpu
    return (f"| {seed} | {', '.join(found) or '–'} ({', '.join(injected) or 'none'}){'' if right else ' WRONG'} | "
            f"{', '.join(search) or '–'}{'' if search == found else ' (adopted)'} | {alternatives_text(d)} | "
            f"{'yes' if ambiguous else 'no'} | {len(adjusted)} | {rec} ({'right' if attribution_right else 'WRONG'}) | "
            f"{100 * ratio:.0f} % of {best.name} ({100 * ratio_ground:.0f} % on the ground) | "
            f"{cv_choice} / {check_choice} | {disagree} | {', '.join(unsaid) or '–'} | {cpu:.0f} s |")


def quantile(values: list[float], q: float) -> float:
    """The q-quantile of ``values`` (linear between order statistics)."""
    v = sorted(values)
    x = q * (len(v) - 1)
    i = int(x)
    return v[i] if i + 1 >= len(v) else v[i] + (x - i) * (v[i + 1] - v[i])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("--seeds", type=int, nargs="+", default=list(range(1, 41)))
    ap.add_argument("--blunders", type=int, default=20)
    ap.add_argument("--ties", type=int, default=None, help="tie points per overlap (default: the preset's, 60)")
    ap.add_argument("--rerun", choices=("diagnose", "compare"), default=None,
                    help="run again from this stage where the cleaning is done (a change of the diagnosis or the "
                         "comparison)")
    ap.add_argument("--control", type=int, default=None,
                    help="control points per band and strip (default: the preset's, 8)")
    ap.add_argument("--preset", default="vienna2000", help="the simulation preset (default vienna2000)")
    ap.add_argument("--strips", type=int, default=None, help="strips of the block (default: the preset's)")
    ap.add_argument("--drift-free", action="store_true",
                    help="without the problem strip's GPS/IMU excursions (and the control bands at its breaks)")
    ap.add_argument("--until", choices=("diagnose", "compare"), default="compare",
                    help="diagnose: score the diagnosis alone (no comparison, no recommendation)")
    a = ap.parse_args()
    extra = "".join(f", {v} {k}" for k, v in (("strips", a.strips), ("tie points per overlap", a.ties),
                                              ("control points per band and strip", a.control)) if v is not None)
    print(f"{a.preset}{' at full length' if a.preset == 'vienna2000' else ''}{', drift-free' if a.drift_free else ''}, "
          f"{a.blunders} blunders{extra}, "
          f"`scangeo run PROJECT --until {a.until}`:\n")
    if a.until == "diagnose":
        print("| seed | problem strips found (injected) | the search's own | best model with breaks: BIC below the "
              "search's | runner-up, richer alternative, other plausible ones | ambiguous | CPU |")
        print("|---|---|---|---|---|---|---|")
    else:
        print("| seed | problem strips found (injected) | the search's own | runner-up, richer alternative, other "
              "plausible ones: kind, strips, BIC difference | ambiguous | variants adjusted | "
              "recommended (its strips) | its true error | choice of the cross-validation / the check points | "
              "disagreement said | worse at check points, unsaid | CPU |")
        print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    totals: dict = dict.fromkeys(("seeds", "right", "wrong", "wrong_called", "ambiguous", "within15", "unsaid",
                                  "disagree", "worst", "within15_ground", "worst_ground", "cpu", "attribution_right",
                                  "summary_wrong", "adopted"), 0)
    totals["gains"] = []
    for seed in a.seeds:
        root = a.out / f"s{seed}"
        try:
            project(root, seed, a.blunders, a.ties, a.control, a.preset, a.drift_free, a.strips)
            cpu = run_seed(root, a.until, a.rerun)
            row = diagnosis_row if a.until == "diagnose" else seed_row
            print(row(root, seed, totals, cpu), flush=True)
        except Exception as exc:  # noqa: BLE001 (a benchmark row, not a library: say so and go on)
            print(f"| {seed} | failed: {type(exc).__name__}: {exc} |", flush=True)
    t = totals
    if a.until == "diagnose":
        g = t["gains"]
        spread = (f"over the {len(g)} where the search found none, the best model with breaks beat it by "
                  f"{min(g):.1f} to {max(g):.1f} (median {quantile(g, 0.5):.1f}, 90 % quantile "
                  f"{quantile(g, 0.9):.1f}; below 0 on {sum(x <= 0 for x in g)})") if g else "none without one"
        print(f"\nseeds {t['seeds']}: the problem strips right on {t['right']}, wrong on {t['wrong']}; ambiguous on "
              f"{t['ambiguous']}; {spread}; CPU {t['cpu']:.0f} s")
        return
    print(f"\nseeds {t['seeds']}: problem strip found alone on {t['right']}; wrong on {t['wrong']}, of which called "
          f"ambiguous {t['wrong_called']}; ambiguous on {t['ambiguous']}; an alternative adopted on {t['adopted']}; "
          f"the recommendation's strips right on {t['attribution_right']}, of which the summary's problem strips "
          f"wrong on {t['summary_wrong']}; recommended within 15 % of the best "
          f"variant's true error on {t['within15']} (worst {100 * t['worst']:.0f} %; on the ground on "
          f"{t['within15_ground']}, worst {100 * t['worst_ground']:.0f} %); the evidence disagreed (and "
          f"said so) on {t['disagree']}; recommended significantly worse at the check points without saying so on "
          f"{t['unsaid']}; CPU {t['cpu']:.0f} s")


if __name__ == "__main__":
    main()
