"""The bad-input matrix of ``scangeo import lcf`` and ``scangeo import parge``, one defect per case.

Each case damages one input in a copy of the sources folder and runs the import into ``{p}/out``: the error
names the file (and the line or key) and what was expected, and nothing is left behind (OUT is not created).
The lcf sources are a small synthetic drone line (tests/importers/sensor_files.py); the PARGE ones the shared
real SWIR status file with a cube of its size, and skip without ../shared.
"""
from __future__ import annotations

import shutil

import numpy as np
import pytest

from tests.badinput.defects import case, chain, lines, remove, replace, truncate, write
from tests.badinput.runner import run_bad
from tests.conftest import SHARED_DATA
from tests.importers.sensor_files import synthetic_line, write_cube

SWIR = SHARED_DATA / "hyspex" / "20200522_Husky_SWIR_boresight_IFSAR.gcs"
VNIR = SHARED_DATA / "hyspex" / "20200522_Husky_VNIR_boresight_IFSAR.gcs"
VNIR_MODEL = SHARED_DATA / "hyspex" / "sensormodel_VNIR_1800_sn0812_FOVexp_180deg_rotated.txt"


@pytest.fixture(scope="module")
def sources(tmp_path_factory):
    """lcf: line.bil (+ .bil.hdr, 60 x 300 x 2 uint16), line.lcf, line.bil.times, look.csv; PARGE (when the shared
    data are there): status.gcs, cube.img + cube.hdr (384 x 2177 x 1 float32), vnir_model.txt, and the VNIR line of
    the same flight, vnir.gcs."""
    root = tmp_path_factory.mktemp("import_sources")
    synthetic_line(root)
    (root / "look.csv").write_text("pixel,along_deg,across_deg\n" + "".join(f"{j},0,{-15 + j * 0.5}\n"
                                                                            for j in range(60)))
    if SWIR.exists():
        shutil.copy(SWIR, root / "status.gcs")
        shutil.copy(VNIR_MODEL, root / "vnir_model.txt")
        shutil.copy(VNIR, root / "vnir.gcs")
        write_cube(root / "cube.img", np.zeros((2177, 384, 1), np.float32), interleave="bsq", header="cube.hdr")
    return root


def _flag(row: int, k: int, value: str):
    def edit(rows: list[str]) -> list[str]:
        fields = rows[row - 1].split()
        fields[k] = value
        rows[row - 1] = "\t".join(fields)
        return rows

    return edit


LCF = "line.lcf"
TIMES = "line.bil.times"
LCF_ARGS = ("{p}/line.bil", "{p}/out", "--fov", "30", "--dtm", "0")
LCF_CASES = [
    # truncated files, and wrong byte counts for the header's size
    case("lcf-cube-truncated", truncate("line.bil", 0.5), "line.bil", "72000 bytes (truncated)"),
    case("lcf-cube-too-long", lambda r: (r / "line.bil").open("ab").write(b"\0" * 10), "line.bil",
         "longer than its header says"),
    case("lcf-header-samples", replace("line.bil.hdr", "samples = 60", "samples = 61"), "line.bil",
         "61 samples x 300 lines"),
    case("lcf-header-no-bands", replace("line.bil.hdr", "bands = 2\n", ""), "line.bil.hdr", "[bands]: missing"),
    case("lcf-header-interleave", replace("line.bil.hdr", "interleave = bil", "interleave = bsx"), "line.bil.hdr",
         "[interleave]", "expected bil, bip or bsq"),
    case("lcf-header-data-type", replace("line.bil.hdr", "data type = 12", "data type = 7"), "line.bil.hdr",
         "[data type]: 7 is not an ENVI data type"),
    case("lcf-header-not-envi", write("line.bil.hdr", "samples = 60\n"), "line.bil.hdr", "not an ENVI header"),
    case("lcf-lcf-truncated", lines(LCF, lambda r: [*r[:-1], r[-1][:20]]), LCF, "fields, expected 11",
         "a truncated record"),
    case("lcf-lcf-empty", write(LCF, ""), LCF, "empty"),
    case("lcf-times-truncated", lines(TIMES, lambda r: r[:150]), TIMES, "150 line times, but the cube has 300 lines"),
    # headers naming a missing file
    case("lcf-cube-data-missing", remove("line.bil"), "line.bil.hdr", "no data file beside the header",
         args=("{p}/line.bil.hdr", "{p}/out", "--fov", "30", "--dtm", "0")),
    case("lcf-cube-header-missing", remove("line.bil.hdr"), "line.bil", "no ENVI header beside the cube"),
    case("lcf-lcf-missing", remove(LCF), "line.bil", "no navigation log beside the cube", "line.lcf"),
    case("lcf-times-missing", remove(TIMES), "line.bil", "no line times beside the cube", "line.bil.times"),
    case("lcf-dtm-missing", lambda r: None, "none.tif", "no such DTM",
         args=("{p}/line.bil", "{p}/out", "--fov", "30", "--dtm", "{p}/none.tif")),
    # NaN navigation, and time gaps
    case("lcf-nan-altitude", lines(LCF, _flag(40, 6, "nan")), LCF, "line 40: altitude is not a finite number"),
    case("lcf-nan-latitude", lines(LCF, _flag(41, 5, "NaN")), LCF, "line 41: latitude is not a finite number"),
    case("lcf-text", lines(LCF, _flag(42, 2, "x0.1")), LCF, "line 42: pitch 'x0.1' is not a number"),
    case("lcf-time-gap", lines(LCF, lambda r: r[:200] + r[500:]), LCF, "line 201: a gap of 1.505 s"),
    case("lcf-time-backwards", lines(LCF, lambda r: [*r[:99], r[100], r[99], *r[101:]]), LCF,
         "line 101: time", "is not after the previous"),
    case("lcf-flag", lines(LCF, _flag(7, 9, "1")), LCF, "line 7: column 10 is 1, expected 5 (use) or 0"),
    case("lcf-all-set-aside", lines(LCF, lambda r: ["\t".join([*x.split()[:9], "0", *x.split()[10:]]) for x in r]),
         LCF, "every record is flagged 0"),
    case("lcf-times-backwards", lines(TIMES, lambda r: [*r[:9], r[10], r[9], *r[11:]]), TIMES,
         "line 11: time", "is not after the previous"),
    case("lcf-times-nan", lines(TIMES, lambda r: [*r[:19], "nan", *r[20:]]), TIMES,
         "line 20: time is not a finite number"),
    # a camera model of another pixel count
    case("lcf-look-angles-pixels", lines("look.csv", lambda r: r[:51]), "look.csv",
         "50 pixels, but the cube line.bil.hdr has 60 samples",
         args=("{p}/line.bil", "{p}/out", "--look-angles", "{p}/look.csv", "--dtm", "0")),
    case("lcf-look-angles-text", lines("look.csv", lambda r: [*r[:5], "4,0,north", *r[6:]]), "look.csv",
         "not a look-angle table", args=("{p}/line.bil", "{p}/out", "--look-angles", "{p}/look.csv", "--dtm", "0")),
    case("lcf-out-not-empty", write("out/mine.txt", "keep"), "out", "exists and is not an empty folder"),
]


@pytest.mark.parametrize("bad", LCF_CASES)
def test_import_lcf(bad, sources, tmp_path, capsys):
    args = LCF_ARGS if not bad.args else ()
    run_bad(["import", "lcf", *args, "--no-progress"], bad, sources, tmp_path, capsys)


STATUS = "status.gcs"
PARGE_ARGS = ("{p}/status.gcs", "{p}/out")
PARGE_CASES = [
    case("parge-status-truncated", truncate(STATUS, 0.4), STATUS, "truncated or damaged"),
    case("parge-status-not-idl", write(STATUS, b"PK\x03\x04" + bytes(100)), STATUS, "not an IDL SAVE file"),
    case("parge-status-missing", remove(STATUS), STATUS, "no such PARGE status file"),
    case("parge-status-no-rollarr", lambda r: _rename(r / STATUS, b"ROLLARR", b"ROLLXRR"), STATUS,
         "missing the array rollarr"),
    case("parge-cube-truncated", truncate("cube.img", 0.5), "cube.img", "(truncated)",
         args=(*PARGE_ARGS, "--cube", "{p}/cube.img")),
    case("parge-cube-lines", replace("cube.hdr", "lines = 2177", "lines = 2176"), "cube.img",
         "384 samples x 2176 lines", args=(*PARGE_ARGS, "--cube", "{p}/cube.img")),
    case("parge-cube-other-line", chain(replace("cube.hdr", "lines = 2177", "lines = 1088"),
                                        truncate("cube.img", 384 * 1088 * 4)), "cube.hdr",
         "384 samples x 1088 lines, but the status file", args=(*PARGE_ARGS, "--cube", "{p}/cube.img")),
    case("parge-cube-header-missing", remove("cube.hdr"), "cube.img", "no ENVI header beside the cube",
         args=(*PARGE_ARGS, "--cube", "{p}/cube.img")),
    case("parge-cube-data-missing", remove("cube.img"), "cube.hdr", "no data file beside the header",
         args=(*PARGE_ARGS, "--cube", "{p}/cube.hdr")),
    case("parge-sensor-model-pixels", lambda r: None, "vnir_model.txt", "1800 pixels, but the image has 384",
         args=(*PARGE_ARGS, "--sensor-model", "{p}/vnir_model.txt")),
    case("parge-dtm-missing", lambda r: None, "none.tif", "no such DTM", args=(*PARGE_ARGS, "--dtm", "{p}/none.tif")),
    case("parge-geoid-missing", lambda r: None, "none.tif", "no such geoid raster",
         args=(*PARGE_ARGS, "--geoid", "{p}/none.tif")),
    case("parge-prior-one-line", lambda r: None, "--relative-mounting swir:vnir:-1.5,-0.5,0.2:0.03",
         "needs several status files", args=(*PARGE_ARGS, "--relative-mounting", "swir:vnir:-1.5,-0.5,0.2:0.03")),
    # several lines: one platform
    case("parge-platform-other-day", lambda r: _rename(r / "vnir.gcs", b"2020-05-22", b"2020-05-23"), "vnir.gcs and",
         "status.gcs are of different flights (other days: 2020-05-23 and 2020-05-22",
         args=("{p}/vnir.gcs", *PARGE_ARGS)),
    case("parge-platform-twice", lambda r: None, "status.gcs: given twice",
         args=("{p}/status.gcs", *PARGE_ARGS)),
    case("parge-platform-prior-without-sigma", lambda r: None, "--relative-mounting swir:vnir:-1.5,-0.5,0.2:",
         "no sigma (a prior needs its sigma)",
         args=("{p}/vnir.gcs", *PARGE_ARGS, "--relative-mounting", "swir:vnir:-1.5,-0.5,0.2:")),
    case("parge-platform-prior-unknown-sensor", lambda r: None, "nir:vnir", "names an unknown sensor 'nir'",
         "the import's sensors: vnir, swir",
         args=("{p}/vnir.gcs", *PARGE_ARGS, "--relative-mounting", "nir:vnir:-1.5,-0.5,0.2:0.03")),
    case("parge-platform-cubes", lambda r: None, "cubes", "1 given for 2 status files",
         args=("{p}/vnir.gcs", *PARGE_ARGS, "--cube", "{p}/cube.img")),
    case("parge-platform-status-truncated", truncate("vnir.gcs", 0.4), "vnir.gcs", "truncated or damaged",
         args=("{p}/vnir.gcs", *PARGE_ARGS)),
]


def _rename(path, old: bytes, new: bytes) -> None:
    data = bytearray(path.read_bytes())
    at = data.find(old)
    data[at:at + len(old)] = new
    path.write_bytes(bytes(data))


@pytest.mark.parametrize("bad", PARGE_CASES)
def test_import_parge(bad, sources, tmp_path, capsys):
    if not (sources / STATUS).exists():
        pytest.skip("shared test data hyspex/ not available")
    args = PARGE_ARGS if not bad.args else ()
    run_bad(["import", "parge", *args, "--no-progress"], bad, sources, tmp_path, capsys)
