"""The cost of the configuration schema: scangeo's own ``scangeo/io/schema.py`` against pydantic v2.

Each figure is the median over fresh interpreters (a module is imported once per process), measured
side by side in the same run:

* ``import``: CPU seconds (``time.process_time``) of importing the schema machinery alone: scangeo's
  ``io/schema.py`` (it needs only ``scangeo.errors`` and the standard library; the package's
  ``__init__`` is left out), or
  ``pydantic`` with ``BaseModel``, ``Field`` and ``ConfigDict``; and what ``python -X importtime``
  reports for the same import (cumulative microseconds of the top module);
* ``define``: CPU seconds of defining the settings of ``[rectify]`` (14 keys and the 8 keys of
  ``[rectify.geotiff]``, with their types, ranges and allowed values) as a class: a frozen dataclass of
  :func:`scangeo.io.schema.setting` s, or a pydantic model (which builds its validator then);
* ``check``: CPU microseconds of reading one ``[rectify]`` table of 6 keys (a nested table among
  them) into the class, every key checked.

    python tests/benchmarks/schema_import.py [--runs 15]
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

#: ``scangeo.io`` as a bare namespace: importing ``scangeo.io.schema`` then runs no ``scangeo/io/__init__.py``
#: (which loads the project reader, the DTM and numba), only the schema and what it imports.
BARE_IO = ("import sys, types; io = types.ModuleType('scangeo.io'); io.__path__ = [r'{root}/scangeo/io']; "
           "sys.modules['scangeo.io'] = io")

OWN = BARE_IO + r'''
import time
t0 = time.process_time()
import scangeo.io.schema as schema
t1 = time.process_time()
from dataclasses import dataclass
from typing import ClassVar
setting, Rule, check, read = schema.setting, schema.Rule, schema.check, schema.read
import math
@dataclass(frozen=True)
class GeoTiff:
    blocksize: int = setting(512, ge=16, multiple_of=16, unit="px")
    compress: str = setting("deflate", choices=("deflate", "zstd", "lzw", "none"))
    level: int | None = setting(None, ge=1, le=22, unit="1")
    predictor: bool = setting(True)
    overviews: bool | str = setting("auto", choices=("auto",))
    cog: bool = setting(True)
    threads: str | int = setting("ALL_CPUS", rule=Rule(lambda v: str(v) == "ALL_CPUS" or str(v).isdigit(), "n"))
    writer: str = setting("scangeo", choices=("scangeo", "gdal"))
    def __post_init__(self): check(self)
@dataclass(frozen=True)
class Rectify:
    resolution: float | None = setting(None, gt=0, rule=Rule(math.isfinite, "finite"))
    bounds: tuple[float, float, float, float] | None = setting(None)
    resampling: str = setting("bilinear", choices=("nearest", "bilinear", "cubic"))
    max_error_px: float = setting(0.05, gt=0)
    memory_budget_mb: float = setting(1024.0, ge=16)
    tile_size: int | None = setting(None, ge=16, multiple_of=16)
    nodata: float | None = setting(None, allow_nan=True)
    occlusion: bool = setting(True)
    layers: tuple[str, ...] = setting((), choices=("scan_angle", "view_zenith", "time", "ground_pixel"))
    igm: bool = setting(False)
    glt: bool = setting(False)
    mosaic: bool = setting(True)
    geotiff: GeoTiff = setting(GeoTiff())
    def __post_init__(self): check(self)
Rectify()
t2 = time.process_time()
table = {{"resolution": 2, "resampling": "cubic", "layers": ["time"], "max_error_px": 0.1, "igm": True,
         "geotiff": {{"level": 3, "blocksize": 256}}}}
n = 2000
t3 = time.process_time()
for _ in range(n):
    read(Rectify, table, "run.toml", "rectify")
t4 = time.process_time()
print({{"import": t1 - t0, "define": t2 - t1, "check_us": (t4 - t3) / n * 1e6}})
'''

PYDANTIC = r'''
import sys, time
t0 = time.process_time()
from pydantic import BaseModel, ConfigDict, Field, field_validator
t1 = time.process_time()
import math
from typing import Literal
class GeoTiff(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid", strict=True)
    blocksize: int = Field(512, ge=16, multiple_of=16)
    compress: Literal["deflate", "zstd", "lzw", "none"] = "deflate"
    level: int | None = Field(None, ge=1, le=22)
    predictor: bool = True
    overviews: bool | Literal["auto"] = "auto"
    cog: bool = True
    threads: str | int = "ALL_CPUS"
    writer: Literal["scangeo", "gdal"] = "scangeo"
    @field_validator("threads")
    @classmethod
    def _threads(cls, v):
        if not (str(v) == "ALL_CPUS" or str(v).isdigit()):
            raise ValueError("n")
        return v
class Rectify(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid", strict=True)
    resolution: float | None = Field(None, gt=0, allow_inf_nan=False)
    bounds: tuple[float, float, float, float] | None = None
    resampling: Literal["nearest", "bilinear", "cubic"] = "bilinear"
    max_error_px: float = Field(0.05, gt=0)
    memory_budget_mb: float = Field(1024.0, ge=16)
    tile_size: int | None = Field(None, ge=16, multiple_of=16)
    nodata: float | None = None
    occlusion: bool = True
    layers: tuple[Literal["scan_angle", "view_zenith", "time", "ground_pixel"], ...] = ()
    igm: bool = False
    glt: bool = False
    mosaic: bool = True
    geotiff: GeoTiff = GeoTiff()
Rectify()
t2 = time.process_time()
table = {{"resolution": 2.0, "resampling": "cubic", "layers": ["time"], "max_error_px": 0.1, "igm": True,
         "geotiff": {{"level": 3, "blocksize": 256}}}}
n = 2000
t3 = time.process_time()
for _ in range(n):
    Rectify.model_validate(table, strict=False)
t4 = time.process_time()
print({{"import": t1 - t0, "define": t2 - t1, "check_us": (t4 - t3) / n * 1e6}})
'''


def once(code: str) -> dict:
    out = subprocess.run([sys.executable, "-c", code.format(root=ROOT)], capture_output=True, text=True, check=True,
                         env={**os.environ, "PYTHONPATH": str(ROOT)})
    return eval(out.stdout.strip())  # noqa: S307 (our own child's dict)


def importtime(statement: str, top: str) -> int:
    """``python -X importtime``'s cumulative microseconds of module ``top``."""
    out = subprocess.run([sys.executable, "-X", "importtime", "-c", statement], capture_output=True, text=True,
                         check=True, env={**os.environ, "PYTHONPATH": str(ROOT)})
    for line in out.stderr.splitlines():
        parts = [p.strip() for p in line.split("|")]
        if len(parts) == 3 and parts[2] == top:
            return int(parts[1])
    raise SystemExit(f"{top} not in the importtime report")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=15)
    args = ap.parse_args()
    print(f"load: {os.getloadavg()[0]:.1f}")
    results: dict[str, list[dict]] = {"scangeo io/schema.py": [], "pydantic v2": []}
    for _ in range(args.runs):  # interleaved: both see the same load
        results["scangeo io/schema.py"].append(once(OWN))
        results["pydantic v2"].append(once(PYDANTIC))
    own_it = statistics.median(importtime(BARE_IO.format(root=ROOT) + "; import scangeo.io.schema",
                                          "scangeo.io.schema") for _ in range(5))
    pyd_it = statistics.median(importtime("from pydantic import BaseModel, ConfigDict, Field", "pydantic")
                               for _ in range(5))
    pyd_main = statistics.median(importtime("import pydantic.main", "pydantic.main") for _ in range(5))
    table = {}
    for name, rows in results.items():
        table[name] = {k: statistics.median(r[k] for r in rows) for k in rows[0]}
    print(f"{'':22s} {'import CPU s':>13s} {'define CPU s':>13s} {'check us':>9s}")
    for name, r in table.items():
        print(f"{name:22s} {r['import']:13.4f} {r['define']:13.4f} {r['check_us']:9.1f}")
    own, pyd = table["scangeo io/schema.py"], table["pydantic v2"]
    print(f"ratio pydantic/own: import {pyd['import'] / max(own['import'], 1e-6):.0f}x, "
          f"define {pyd['define'] / max(own['define'], 1e-6):.1f}x, check {pyd['check_us'] / own['check_us']:.2f}x")
    print(f"-X importtime (cumulative us): scangeo.io.schema {own_it}; "
          f"pydantic {pyd_it}, pydantic.main (BaseModel) {pyd_main}")
    print(json.dumps({"runs": args.runs, **table}))


if __name__ == "__main__":
    main()
