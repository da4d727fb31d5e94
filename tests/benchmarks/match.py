"""Speed and memory of ``scangeo match`` on the vienna2000 block (targets: under 60 s, under 2 GB).

Simulates vienna2000 (3 strips x 7,000 lines x 716 pixels, with images and the truth orthoimage)
into FOLDER unless it is there, then measures ties and control (the truth orthoimage as the
reference) with 1 and 2 worker processes, and prints the time, the peak resident memory of this
process and of the workers, the point counts and the true tie error (scangeo.truth.matches).

Run: ``python tests/benchmarks/match.py FOLDER [--workers 2]``
"""
from __future__ import annotations

import argparse
import resource
import time
from pathlib import Path

from scangeo.match import match_project
from scangeo.truth.matches import match_errors


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("folder", type=Path)
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--preset", default="vienna2000")
    args = parser.parse_args()
    root = args.folder / args.preset
    if not (root / "project.toml").exists():
        from scangeo.simulate.block import simulate
        from scangeo.simulate.config import load_preset

        t = time.perf_counter()
        simulate(root, load_preset(args.preset))
        print(f"simulated {args.preset} in {time.perf_counter() - t:.0f} s")
    reference = root / "truth" / "ortho.tif"
    for workers in args.workers:
        t = time.perf_counter()
        result = match_project(root, references=[reference], workers=workers)
        dt = time.perf_counter() - t
        s = result.report["summary"]
        per = {k: o["points"] for k, o in result.report["overlaps"].items()}
        print(f"workers {workers}: {dt:.1f} s; {s['tie_points']} tie {per}, {s['control_points']} control, "
              f"{s['check_points']} check; rejected {100 * s['rejected_share']:.0f} %")
    me = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    children = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
    print(f"peak resident memory: this process {me:.0f} MB, largest worker {children:.0f} MB")
    e = match_errors(root)
    print(f"true tie error: rms {e.tie_rms():.3f} px over {len(e.tie_errors_px)} measurements, "
          f"{100 * e.share_within(1.0):.1f} % within 1 px")


if __name__ == "__main__":
    main()
