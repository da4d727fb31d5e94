"""Cost of the file-stamp rule (``scangeo.filecache.stamp``) and of a cache hit, in CPU microseconds.

A hit re-stamps every file its entry depends on: one ``stat`` per file, and for a file of at most
``SMALL_FILE`` bytes the BLAKE2b digest of its bytes (read from the page cache). Printed: a stamp of
a 1 KiB, a 64 KiB and a 256 KiB file, of a 10 MB file (stat only), and a hit of an entry over the six
files of a matching strip (project.toml, DTM, image, trajectory, line times, orientation.json).

    python tests/benchmarks/filecache.py
"""
from __future__ import annotations

import os
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from scangeo.filecache import FileCache, stamp  # noqa: E402


def per_call(fn, n: int = 2000) -> float:
    t = time.process_time()
    for _ in range(n):
        fn()
    return (time.process_time() - t) / n * 1e6


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        sizes = {"project.toml": 1024, "64k.bin": 65536, "orientation.json": 256 * 1024, "dtm.tif": 10_000_000,
                 "image.tif": 10_000_000, "nav.csv": 2_000_000, "times.csv": 200_000}
        for name, size in sizes.items():
            (root / name).write_bytes(os.urandom(size))
        print(f"load {os.getloadavg()[0]:.1f}")
        for name in ("project.toml", "64k.bin", "orientation.json", "dtm.tif"):
            path = root / name
            us = per_call(lambda p=path: stamp(p))
            print(f"stamp of {name:18s} ({sizes[name] / 1024:8.0f} KiB): {us:7.1f} us")
        files = [root / n for n in ("project.toml", "dtm.tif", "image.tif", "nav.csv", "times.csv", "orientation.json")]
        cache: FileCache[int] = FileCache("bench", 4)
        cache.get("k", files, lambda: 1)
        print(f"hit over the 6 files of a matching strip: {per_call(lambda: cache.get('k', files, lambda: 1)):7.1f} us")


if __name__ == "__main__":
    main()
