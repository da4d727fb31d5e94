"""Benchmark: the break selection's local update from the QR factors of the current design
(``scangeo/adjustment/diagnosis/local_fit.py``) against the same update from the inverse of the normal
equations (the module at git revision ``--baseline``, 6a4e8d5^ by default), side by side in one process.

The pattern data of block24 with ``--strips`` strips (``tests/benchmarks/diagnosis_selection.py``'s, cached
in ``--work``) are scored by ``select_breaks`` and ``break_intervals`` with each module swapped in,
alternating, ``--repeat`` times. Printed: CPU seconds of each (the least of the repeats), whether both give
the same breaks, criterion (to the bit) and intervals, and the OpenBLAS settings of the run (set
``OPENBLAS_NUM_THREADS=1`` to time the arithmetic without OpenBLAS's threads).

Run: python tests/benchmarks/local_fit_routes.py [--strips 24] [--lines 7000] [--repeat 2] [--work DIR]
[--baseline REV]
"""
from __future__ import annotations

import argparse
import importlib.util
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from tests.benchmarks.diagnosis_selection import pattern_data  # noqa: E402


def module_at(revision: str, work: Path):
    """local_fit.py as it was at ``revision``, loaded as a module of its own."""
    source = subprocess.run(["git", "-C", str(ROOT), "show", f"{revision}:scangeo/adjustment/diagnosis/local_fit.py"],
                            check=True, capture_output=True, text=True).stdout
    path = work / "local_fit_baseline.py"
    path.write_text(source, encoding="utf-8")
    spec = importlib.util.spec_from_file_location("local_fit_baseline", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules["local_fit_baseline"] = module
    spec.loader.exec_module(module)
    return module


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--strips", type=int, default=24)
    ap.add_argument("--lines", type=int, default=7000)
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--work", type=Path)
    ap.add_argument("--baseline", default="6a4e8d5^")
    args = ap.parse_args()
    work = args.work or Path(tempfile.mkdtemp(prefix="localfit_"))
    work.mkdir(parents=True, exist_ok=True)
    from scangeo.adjustment.diagnosis import local_fit, patterns

    data = pattern_data(work / f"block{args.strips}", args.lines, args.strips, work)
    routes = {"normal equations (baseline)": module_at(args.baseline, work), "QR factors": local_fit}
    print(f"load {os.getloadavg()[0]:.1f}; OPENBLAS_CORETYPE={os.environ.get('OPENBLAS_CORETYPE')} "
          f"OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS')}; {data.n} rows", flush=True)
    best: dict[str, float] = {}
    results = {}
    for rep in range(args.repeat):
        for name, mod in routes.items():
            patterns.CurrentFit, patterns.StripProbe = mod.CurrentFit, mod.StripProbe
            patterns.BlockIndex = mod.BlockIndex
            t = time.process_time()
            fit = patterns.select_breaks(data)
            intervals = patterns.break_intervals(data, fit)
            cpu = time.process_time() - t
            best[name] = min(best.get(name, cpu), cpu)
            results[name] = (fit.breaks, fit.constant, fit.bic, [(b.strip, b.line, b.low, b.high) for b in intervals])
            print(f"{rep} {name:28s} {cpu:6.2f} CPU s", flush=True)
    patterns.CurrentFit, patterns.StripProbe, patterns.BlockIndex = (local_fit.CurrentFit, local_fit.StripProbe,
                                                                     local_fit.BlockIndex)
    a, b = results.values()
    base, qr = best.values()
    print(f"\nleast of {args.repeat}: baseline {base:.2f} CPU s, QR {qr:.2f} CPU s ({qr / base:.2f}x); "
          f"the same breaks, criterion and intervals: {a == b}")


if __name__ == "__main__":
    main()
