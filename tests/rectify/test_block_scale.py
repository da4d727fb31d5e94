"""A block end to end as a user runs it: simulate with images, ``scangeo adjust``,
``scangeo rectify --mosaic`` of every strip, each command in its own process.

Asserted: every command succeeds; every strip's orthoimage and the mosaic are complete (nothing
partial left beside them); each process stays under 4 GiB peak; the mosaic holds, at every valid
cell, the value of one of the strips' orthoimages there (it is assembled, not resampled again) and
covers every cell any strip covers. Speed is measured in tests/benchmarks/block.py, not here.

CI runs the reduced size (``small`` preset, 3 strips x 300 lines); ``SCANGEO_SCALE=full`` runs the
``block24`` preset at its full size (24 strips x 7,000 lines x 716 px x 11 bands; about half an
hour on 2 cores).
"""
from __future__ import annotations

import os
import subprocess
import sys
import warnings

import numpy as np
import pytest
import rasterio
from rasterio.windows import from_bounds

FULL = os.environ.get("SCANGEO_SCALE", "").lower() == "full"
LIMIT_MIB = 4096

STAGE = r"""
import resource, sys
from scangeo.cli import main
try:
    code = main(sys.argv[2:])
finally:
    peak = max(resource.getrusage(w).ru_maxrss for w in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN))
    open(sys.argv[1], "w").write(str(peak / 1024.0))
sys.exit(code or 0)
"""


def run(tmp_path, *args) -> float:
    """``scangeo ARGS`` in its own process; its peak resident memory in MiB."""
    rss = tmp_path / "peak.rss"
    proc = subprocess.run([sys.executable, "-c", STAGE, str(rss), *args], capture_output=True, text=True)
    assert proc.returncode == 0, (args, proc.stdout[-2000:], proc.stderr[-3000:])
    return float(rss.read_text())


@pytest.mark.scale
def test_a_block_from_simulation_to_mosaic(tmp_path):
    from scangeo.simulate.block import simulate
    from scangeo.simulate.config import load_preset

    root = tmp_path / "block"
    if FULL:
        config = load_preset("block24", {"output": {"truth_ortho": False}})
    else:
        config = load_preset("small", {"flight": {"strips": 3, "lines": 300}, "output": {"truth_ortho": False}})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        simulate(root, config)
    peaks = {"adjust": run(tmp_path, "adjust", str(root), "--variant", "SE", "--no-progress")}
    peaks["rectify"] = run(tmp_path, "rectify", str(root), "--variant", "SE", "--mosaic", "--no-progress")
    assert max(peaks.values()) < LIMIT_MIB, peaks

    ortho = root / "results" / "SE" / "ortho"
    strips = sorted(p for p in (root / "images").glob("*.tif"))
    finals = sorted(p.name for p in ortho.iterdir())
    assert not [n for n in finals if n.startswith(".")], finals  # nothing partial left
    mosaics = [p for p in ortho.glob("*.tif") if "mosaic" in p.name]
    assert len(mosaics) == 1, finals
    orthos = [ortho / f"{p.stem}.tif" for p in strips]
    assert all(p.exists() for p in orthos), finals

    with rasterio.open(mosaics[0]) as m:
        mosaic = m.read(1)
        nodata = m.nodata
        matched = np.zeros(mosaic.shape, dtype=bool)
        covered = np.zeros(mosaic.shape, dtype=bool)
        for path in orthos:
            with rasterio.open(path) as s:
                assert s.res == m.res and s.nodata == nodata
                win = from_bounds(*s.bounds, transform=m.transform).round_offsets().round_lengths()
                rs = slice(win.row_off, win.row_off + win.height)
                cs = slice(win.col_off, win.col_off + win.width)
                band = s.read(1)
                valid = band != nodata
                covered[rs, cs] |= valid
                matched[rs, cs] |= valid & (band == mosaic[rs, cs])
    valid = mosaic != nodata
    assert valid.sum() > 0.5 * covered.sum()
    assert np.array_equal(valid, covered)  # every cell a strip covers, and no other
    assert matched[valid].all()  # each a strip's value
