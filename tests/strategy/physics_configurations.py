"""Measure the reference case (DESIGN section 7) under several comparison set-ups and seeds (docs/reports.md).

Not collected by pytest. Simulates vienna2000 (half the strip length by default, as ``test_physics.py``;
``--full`` for the preset as it is) for every ``--seeds`` into OUT, runs the diagnosis and
``compare_project`` with the default variants changed as each named set-up says, and prints one
Markdown table per seed and set-up, then the diagnosis and recommendation figures over the seeds:

    python tests/strategy/physics_configurations.py /tmp/phys [--full] [--seeds 1 2 3] [SETUP ...]

Set-ups: ``default`` the variants ``compare`` writes (problem strips and breaks from the diagnosis);
``truth`` the same template filled in with the simulation's problem strip and breaks (what the diagnosis
costs; truth is read here, never by ``compare``); ``rotation`` the default with a rigid rotation of
every degree-0 strip model; ``noprior`` the default without the coefficient prior (``coefficient_sigma_m
= inf``); ``snoop`` the default with data snooping in every variant.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from test_physics import reduced_overrides  # noqa: E402

from scangeo.simulate.block import simulate  # noqa: E402
from scangeo.simulate.config import load_preset  # noqa: E402
from scangeo.strategy.comparison import compare_project  # noqa: E402
from scangeo.strategy.default_variants import ProblemStrip, ensure_variants_file, render_default_variants  # noqa: E402


def _fmt(x, spec=".2f") -> str:
    """A figure, or "–" when it is missing (a failed variant has no sigma0)."""
    return "–" if x is None or (isinstance(x, float) and not math.isfinite(x)) else format(x, spec)


def truth_problem(root: Path) -> ProblemStrip:
    info = json.loads((root / "truth" / "errors.json").read_text())
    return ProblemStrip(str(info["problem_strip"]), tuple(info["breaks_lines"]), "truth/errors.json")


def variants_text(root: Path, setup: str) -> str:
    default = ensure_variants_file(root).read_text()
    if setup == "default":
        return default
    if setup == "truth":
        return render_default_variants([truth_problem(root)])
    out = []
    for line in default.splitlines(keepends=True):
        out.append(line)
        if line.startswith("[variants."):
            name = line.strip()[len("[variants."):-1]
            if setup == "rotation" and name in ("BE", "SE", "SE_DTM", "P2", "P4", "S2", "S4"):
                out.append("rotation = true\n")
            if setup == "noprior" and name in ("P2", "P4", "S2", "S4"):
                out.append("coefficient_sigma_m = inf\n")
            if setup == "snoop" and name != "DG":
                out.append("snooping = true\n")
    return "".join(out).replace("snooping = false\n", "") if setup == "snoop" else "".join(out)


def pooled_true(v) -> float | None:
    """rms of the true error over every strip, along and across together (pixels)."""
    tot = n = 0.0
    for e in v.strips.values():
        t = e.get("true")
        if t and t.get("n"):
            tot += t["n"] * (t["rms_along_px"] ** 2 + t["rms_across_px"] ** 2)
            n += 2 * t["n"]
    return math.sqrt(tot / n) if n else None


def table(root: Path, setup: str):
    path = root / f"variants_{setup}.toml"
    path.write_text(variants_text(root, setup))
    c = compare_project(root, path)
    problem = truth_problem(root).strip
    head = (["variant", "control", "sigma0 (% SE, % SE_DTM)", "rejected"]
            + [f"{s} {k}" for s in c.strips for k in ("along", "across")] + [f"true {problem} across", "true pooled"])
    out = [f"{root.name} {setup}:", "", "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    dtm = next((v for v in c.variants if v.name == "SE_DTM" and v.error is None), None)
    for v in c.variants:
        if v.error:
            out.append(f"| {v.name} | failed: {v.error} |")
            continue
        ident = 100 * v.sigma0 / dtm.sigma0 if dtm and v.sigma0 and dtm.sigma0 else None
        row = [v.name, v.control_label, f"{_fmt(v.sigma0, '.3f')} ({_fmt(c.sigma0_percent(v), '.0f')}, "
               f"{_fmt(ident, '.0f')})", str(v.rejected)]
        row += [f"{_fmt(v.strips[s]['check'][f'rms_{k}_px'])} ({_fmt(c.check_percent(v, s, k), '.0f')})"
                for s in c.strips for k in ("along", "across")]
        row += [_fmt(v.strips[problem].get("true", {}).get("rms_across_px")), _fmt(pooled_true(v))]
        out.append("| " + " | ".join(row) + " |")
    return "\n".join(out) + "\n", c


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("--full", action="store_true")
    ap.add_argument("--seeds", type=int, nargs="+", default=[2000])
    ap.add_argument("setups", nargs="*", default=["default", "truth"])
    a = ap.parse_intermixed_args()
    for seed in a.seeds:
        root = a.out / (("full" if a.full else "half") + f"_s{seed}")
        if not (root / "project.toml").exists():
            over = {"output": {"images": False, "truth_ortho": False}, "seed": seed}
            if not a.full:
                over.update(reduced_overrides("vienna2000", 0.5))
            simulate(root, load_preset("vienna2000", over))
        for setup in a.setups:
            text, c = table(root, setup)
            print(text, flush=True)
            diag = root / "results" / "diagnosis.md"
            if setup == "default" and diag.exists():
                print(diag.read_text(), flush=True)


if __name__ == "__main__":
    main()
