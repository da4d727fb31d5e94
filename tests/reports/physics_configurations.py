"""Measure the reference case (DESIGN section 7) under several comparison set-ups (docs/reports.md).

Not collected by pytest. Simulates vienna2000 (half the strip length by default, as
``test_physics.py``; ``--full`` for the preset as it is) into OUT and runs ``compare_project`` with
the default variants changed as each named set-up says, printing one Markdown table per set-up:

    python tests/reports/physics_configurations.py /tmp/phys [--full] [SETUP ...]

Set-ups, combined with ``+`` (``old`` is the default file before the fair comparison):
``old`` DTM heights only in P/S, snooping on; ``dtm`` also BE/SE carry them; ``nosnoop`` no automatic
rejection in any variant; ``bprob`` the 4-band variants' break-band control only for the B* points
measured in the problem strip. ``default`` is scangeo/data/variants.toml as it is.
"""
from __future__ import annotations

import argparse
import csv
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from test_physics import reduced_overrides  # noqa: E402

from scangeo.reports.comparison import compare_project  # noqa: E402
from scangeo.reports.default_variants import problem_strip_from_truth, render_default_variants  # noqa: E402
from scangeo.simulate.block import simulate  # noqa: E402
from scangeo.simulate.config import load_preset  # noqa: E402

ADJUSTED = ("BE", "SE", "P2", "P4", "S2", "S4")


def old_default(text: str) -> str:
    """The default variants before the fair comparison: DTM heights in P/S only, snooping on."""
    for name in ADJUSTED:
        head = f"[variants.{name}]\n"
        a = text.index(head)
        b = text.find("\n[", a + len(head))
        block = text[a:b if b > 0 else len(text)]
        new = block.replace("snooping = false\n", "")
        if name in ("BE", "SE"):
            new = new.replace('dtm_heights = true\ndtm_height_points = ["*"]\n', "")
        text = text.replace(block, new)
    return text


def variants_text(root: Path, setup: str) -> str:
    text = render_default_variants(problem_strip_from_truth(root))
    if setup == "default":
        return text
    opts = set(setup.split("+"))
    text = old_default(text)
    for name in ADJUSTED:
        head = f"[variants.{name}]\n"
        extra = ""
        if "dtm" in opts and name in ("BE", "SE"):
            extra += 'dtm_heights = true\ndtm_height_points = ["*"]\n'
        if "nosnoop" in opts:
            extra += "snooping = false\n"
        text = text.replace(head, head + extra, 1)
    if "bprob" in opts:
        problem = problem_strip_from_truth(root).strip
        rows = csv.DictReader(open(root / "points.csv"))
        ids = sorted({r["point"] for r in rows if r["point"].startswith("B") and r["strip"] == problem})
        roles = "{ " + ", ".join(f'"{i}" = "control"' for i in ids) + " }"
        text = text.replace('roles = { "B*" = "control" }', f"roles = {roles}")
    return text


def table(root: Path, setup: str) -> str:
    path = root / f"variants_{setup}.toml"
    path.write_text(variants_text(root, setup))
    c = compare_project(root, path)
    problem = problem_strip_from_truth(root).strip
    head = (["variant", "control", "sigma0 (%)", "rejected", "observations"]
            + [f"{s} {k}" for s in c.strips for k in ("along", "across")] + [f"true across {problem}"])
    out = [f"{setup}:", "", "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for v in c.variants:
        row = [v.name, v.control_label, f"{v.sigma0:.3f} ({c.sigma0_percent(v):.0f})", str(v.rejected),
               str(v.accounting.get("observations", ""))]
        row += [f"{v.strips[s]['check'][f'rms_{k}_px']:.2f} ({c.check_percent(v, s, k):.0f})"
                for s in c.strips for k in ("along", "across")]
        row.append(f"{v.strips[problem]['true']['rms_across_px']:.2f}")
        out.append("| " + " | ".join(row) + " |")
    return "\n".join(out) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("--full", action="store_true")
    ap.add_argument("setups", nargs="*", default=["old", "dtm", "nosnoop", "bprob", "default"])
    a = ap.parse_intermixed_args()
    root = a.out / ("full" if a.full else "half")
    if not (root / "project.toml").exists():
        over = {"output": {"images": False, "truth_ortho": False}}
        if not a.full:
            over.update(reduced_overrides("vienna2000", 0.5))
        simulate(root, load_preset("vienna2000", over))
    for setup in a.setups:
        print(table(root, setup), flush=True)


if __name__ == "__main__":
    main()
