"""Cost of the rectification fingerprint's content hash: SHA-256 of a strip image of
716 pixels x 10000 lines x 11 bands, uint16 (157.5 MB), against reading the file alone, and the
cached second call of the same run.

    python tests/benchmarks/fingerprint.py [--lines 10000] [--repeat 3]

The file is in the page cache after the first pass (as an image just written or read is), so the
figures are CPU cost, not disk.
"""
from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import numpy as np

from scangeo import filecache


def read_only(path: Path) -> None:
    with path.open("rb") as f:
        while f.read(1 << 22):
            pass


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lines", type=int, default=10000)
    ap.add_argument("--pixels", type=int, default=716)
    ap.add_argument("--bands", type=int, default=11)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "image.bin"
        rng = np.random.default_rng(0)
        rng.integers(0, 4096, (args.bands, args.lines, args.pixels), dtype=np.uint16).tofile(path)
        mb = path.stat().st_size / 1e6
        read_only(path)  # into the page cache
        reads, hashes, cached = [], [], []
        for _ in range(args.repeat):
            t = time.perf_counter()
            read_only(path)
            reads.append(time.perf_counter() - t)
            filecache.clear_all()
            t = time.perf_counter()
            filecache.content_hash(path)
            hashes.append(time.perf_counter() - t)
            t = time.perf_counter()
            filecache.content_hash(path)
            cached.append(time.perf_counter() - t)
    print(f"image {args.pixels} x {args.lines} x {args.bands} uint16: {mb:.1f} MB; load {os.getloadavg()[0]:.1f}")
    print(f"read alone      best {min(reads):.3f} s  ({mb / min(reads):.0f} MB/s)")
    print(f"SHA-256         best {min(hashes):.3f} s  ({mb / min(hashes):.0f} MB/s), "
          f"{min(hashes) / min(reads):.1f}x reading")
    print(f"cached (a run)  best {min(cached) * 1e6:.0f} us")


if __name__ == "__main__":
    main()
