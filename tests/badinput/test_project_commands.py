"""The bad-input matrix of the commands that read a project: one defect per case.

Every case copies the session's small simulated project, applies one defect and runs the command
in-process. It must exit non-zero with a message naming the file and the line or key (no traceback:
an exception other than scangeo's own would fail the test), and leave no new file under a final name.
"""
from __future__ import annotations

import numpy as np
import pytest

from tests.badinput.defects import (
    case,
    chain,
    dtm_edit,
    lines,
    random_bytes,
    raster,
    remove,
    replace,
    sbet_edit,
    sbet_of,
    set_field,
    truncate,
    write,
)
from tests.badinput.runner import run_bad
from tests.session_projects import SMALL_BLOCK

PT = "project.toml"
NAV = "nav/02.csv"
LINES, PIXELS = SMALL_BLOCK["flight"]["lines"], SMALL_BLOCK["sensor"]["pixels"]


def _swap_times(rows):
    a, b = rows[500].split(","), rows[501].split(",")
    a[0], b[0] = b[0], a[0]
    rows[500], rows[501] = ",".join(a), ",".join(b)
    return rows


def _repeat_time(rows):
    fields = rows[501].split(",")
    fields[0] = rows[500].split(",")[0]
    rows[501] = ",".join(fields)
    return rows


def _radians_in_file(rows):
    out = [rows[0]]
    for row in rows[1:]:
        f = row.split(",")
        f[4:7] = [f"{np.radians(float(v)):.9f}" for v in f[4:7]]
        out.append(",".join(f))
    return out


#: Defects of project.toml (TOML: missing/unknown key, wrong type, bad CRS, paths), read by every command.
TOML = [
    case("toml-syntax", replace(PT, 'kind = "whiskbroom"', 'kind = "whiskbroom'), "project.toml", "line"),
    case("toml-missing-crs", replace(PT, 'crs = "EPSG:32633"\n', ""), "project.toml", "crs", "missing"),
    case("toml-unknown-key", replace(PT, "dtm_sigma_m = 1.5", "dtm_sigma_m = 1.5\ncolour = 3"), "project.toml",
         "colour"),
    case("toml-unknown-table", lambda r: (r / PT).open("a").write("\n[extra]\na = 1\n"), "project.toml", "[extra]"),
    case("toml-wrong-type", replace(PT, "pixels = 100", 'pixels = "many"'), "project.toml", "pixels", "int"),
    case("toml-bool-for-float", replace(PT, "fov_deg = 42.9", "fov_deg = true"), "project.toml", "fov_deg"),
    case("toml-bad-crs", replace(PT, "EPSG:32633", "EPSG:999999"), "project.toml", "[project.crs]", "EPSG:999999"),
    case("toml-bad-kind", replace(PT, '"whiskbroom"', '"frame"'), "project.toml", "kind", "frame"),
    case("toml-short-vector", replace(PT, "lever_arm_m = [0.35, 0.1, -0.8]", "lever_arm_m = [0.35, 0.1]"),
         "project.toml", "lever_arm_m"),
    case("toml-dtm-to-nothing", replace(PT, '"dtm.tif"', '"nothing.tif"'), "nothing.tif"),
    case("toml-dtm-to-directory", replace(PT, '"dtm.tif"', '"nav"'), "nav"),
    case("toml-trajectory-to-nothing", replace(PT, '"nav/02.csv"', '"nav/none.csv"'), "nav/none.csv"),
    case("toml-trajectory-to-directory", replace(PT, '"nav/02.csv"', '"nav"'), "nav", "directory"),
    case("toml-path-outside-project", replace(PT, '"nav/02.csv"', '"../elsewhere/02.csv"'), "elsewhere/02.csv"),
    case("toml-no-strips", lambda r: (r / PT).write_text((r / PT).read_text().split("[[strips]]")[0]),
         "project.toml", "[[strips]]"),
    case("toml-duplicate-strip", replace(PT, 'id = "02"', 'id = "01"'), "project.toml", "'01'"),
    case("toml-two-timings",
         replace(PT, "first_line_time = 300000.0", 'first_line_time = 300000.0\nline_times = "t.csv"'), "project.toml",
         "first_line_time", "line_times"),
    case("toml-strip-missing-trajectory", replace(PT, 'trajectory = "nav/02.csv"\n', ""), "project.toml",
         "trajectory", "missing"),
]

#: Defects of a CSV trajectory (strip 02) and of an SBET.
TRAJECTORY = [
    case("traj-nan", lines(NAV, set_field(300, 1, "nan")), NAV, "line 300", "lat"),
    case("traj-inf", lines(NAV, set_field(300, 3, "inf")), NAV, "line 300", "h"),
    case("traj-text", lines(NAV, set_field(300, 6, "north")), NAV, "line 300", "heading", "'north'"),
    case("traj-backwards-time", lines(NAV, _swap_times), NAV, "line 502", "before"),
    case("traj-repeated-time", lines(NAV, _repeat_time), NAV, "line 502", "repeats"),
    case("traj-truncated-record", lines(NAV, lambda r: r[:-1] + [",".join(r[-1].split(",")[:3])]), NAV,
         f"line {1001}", "fields"),
    case("traj-gap", lines(NAV, lambda r: r[:401] + r[901:]), NAV, "gap of 10.0 s", "strip 02"),
    case("traj-short", lines(NAV, lambda r: r[:500]), NAV, "does not cover lines", "of strip 02"),
    case("traj-late-start", lines(NAV, lambda r: r[:1] + r[400:]), NAV, "does not cover lines 0-", "of strip 02"),
    case("traj-one-record", lines(NAV, lambda r: r[:2]), NAV, "at least 2 records"),
    case("traj-empty", write(NAV, ""), NAV, "empty"),
    case("traj-header-only", lines(NAV, lambda r: r[:1]), NAV, "no records"),
    case("traj-missing-column", lines(NAV, lambda r: [r[0].replace("heading", "course")] + r[1:]), NAV, "line 1",
         "heading"),
    case("traj-duplicate-column", lines(NAV, lambda r: [r[0].replace("heading", "lat")] + r[1:]), NAV, "line 1",
         "twice"),
    case("traj-blank-line", lines(NAV, lambda r: r[:300] + [""] + r[300:]), NAV, "line 301", "empty line"),
    case("traj-binary", random_bytes(NAV, 4000), NAV, "UTF-8"),
    case("sbet-truncated", chain(sbet_of("02"), truncate("nav/02.out", -50 % 136 + 136 * 900)), "nav/02.out",
         "record 901", "truncated"),
    case("sbet-empty", chain(sbet_of("02"), write("nav/02.out", b"")), "nav/02.out", "no SBET records"),
    case("sbet-random-bytes", chain(sbet_of("02"), random_bytes("nav/02.out", 136 * 50)), "nav/02.out", "record"),
    case("sbet-nan", chain(sbet_of("02"), sbet_edit("02", lambda rec: rec["alt"].__setitem__(77, np.nan))),
         "nav/02.out", "record 78", "alt"),
    case("sbet-backwards", chain(sbet_of("02"), sbet_edit("02", lambda rec: rec["time"].__setitem__(600, 0.0))),
         "nav/02.out", "record 601"),
]

#: Defects of points.csv (image measurements) and ground.csv.
POINTS = [
    case("points-unknown-strip", lines("points.csv", set_field(2, 1, "07")), "points.csv", "line 2", "'07'"),
    case("points-out-of-image", lines("points.csv", set_field(2, 2, "5000")), "points.csv", "line 2", "5000"),
    case("points-negative-pixel", lines("points.csv", set_field(3, 3, "-40")), "points.csv", "line 3", "pixel"),
    case("points-nan", lines("points.csv", set_field(2, 2, "nan")), "points.csv", "line 2", "line"),
    case("points-text", lines("points.csv", set_field(4, 3, "x12")), "points.csv", "line 4", "'x12'"),
    case("points-duplicate", lines("points.csv", lambda r: r + [r[1]]), "points.csv", "already measured"),
    case("points-sigma-zero", lines("points.csv", set_field(2, 4, "0")), "points.csv", "line 2", "sigma_px"),
    case("points-sigma-negative", lines("points.csv", set_field(5, 4, "-0.3")), "points.csv", "line 5", "sigma_px"),
    case("points-missing-column", lines("points.csv", lambda r: [r[0].replace("pixel", "px")] + r[1:]),
         "points.csv", "line 1", "pixel"),
    case("points-short-row", lines("points.csv", lambda r: r[:3] + [",".join(r[3].split(",")[:3])] + r[4:]),
         "points.csv", "line 4", "fields"),
    case("points-empty", write("points.csv", ""), "points.csv", "empty"),
    case("points-missing-file", remove("points.csv"), "points.csv"),
    case("points-unknown-point", lines("points.csv", lambda r: r + ["Z999,01,100.0,50.0,0.3"]), "points.csv",
         "Z999"),
    case("ground-unknown-role", lines("ground.csv", set_field(2, 6, "kontrol")), "ground.csv", "line 2", "'kontrol'"),
    case("ground-sigma-zero", lines("ground.csv", set_field(3, 4, "0")), "ground.csv", "line 3", "sigma_xy"),
    case("ground-sigma-negative", lines("ground.csv", set_field(3, 5, "-0.1")), "ground.csv", "line 3", "sigma_z"),
    case("ground-nan", lines("ground.csv", set_field(4, 3, "nan")), "ground.csv", "line 4", "z"),
    case("ground-text", lines("ground.csv", set_field(4, 1, "east")), "ground.csv", "line 4", "'east'"),
    case("ground-duplicate", lines("ground.csv", lambda r: r + [r[1]]), "ground.csv", "E001"),
    case("ground-missing-column", lines("ground.csv", lambda r: [r[0].replace("role", "kind")] + r[1:]),
         "ground.csv", "line 1", "role"),
    case("ground-empty", write("ground.csv", ""), "ground.csv", "empty"),
    case("ground-far-away", lines("ground.csv", set_field(2, 1, "100000.0")), "ground.csv", "E001"),
]

#: Defects of the DTM.
DTM = [
    case("dtm-missing", remove("dtm.tif"), "dtm.tif"),
    case("dtm-no-crs", dtm_edit(lambda a, t, p: None, drop_crs=True), "dtm.tif", "CRS"),
    case("dtm-nodata-under-swath", dtm_edit(lambda a, t, p: a.fill(p["nodata"] if p["nodata"] is not None else -9999)),
         "dtm.tif"),
    case("dtm-text", write("dtm.tif", "not a raster\n"), "dtm.tif"),
    case("dtm-truncated", truncate("dtm.tif", 0.5), "dtm.tif"),
]

ADJUST_ONLY = [
    case("variants-unknown-key", write("variants.toml", '[variants.X]\nstrategy = "SE"\ndegre = 1\n'),
         "variants.toml", "degre", args=("--variant", "X")),
    case("variants-wrong-type", write("variants.toml", '[variants.X]\nstrategy = "SE"\nposition_degree = "one"\n'),
         "variants.toml", "position_degree", args=("--variant", "X")),
    case("variants-unknown-name", write("variants.toml", '[variants.X]\nstrategy = "SE"\n'), "variants.toml", "'Y'",
         args=("--variant", "Y")),
    case("variants-bad-strategy", write("variants.toml", '[variants.X]\nstrategy = "ZZ"\n'), "variants.toml",
         "strategy", args=("--variant", "X")),
]


@pytest.mark.parametrize("bad", TOML + TRAJECTORY + POINTS + DTM + ADJUST_ONLY)
def test_adjust(bad, small_block, tmp_path, capsys):
    run_bad(["adjust", "{p}", "--no-progress"], bad, small_block, tmp_path, capsys)


#: Defects of a platform's project.toml (``platform_block``: sensors a and b, flight lines L01 and L02).
PLATFORM = [
    case("platform-unknown-sensor",
         replace(PT, 'sensor = "b"\nflight_line = "L01"', 'sensor = "c"\nflight_line = "L01"'),
         PT, "[strips[1]]", "sensor 'c' is not a sensor of the project"),
    case("platform-unknown-flight-line", replace(PT, 'flight_line = "L02"', 'flight_line = "L9"'), PT,
         "flight_line 'L9' is not a [[flight_lines]] id"),
    case("platform-strip-without-sensor", replace(PT, 'sensor = "b"\nflight_line = "L01"', 'flight_line = "L01"'),
         PT, "[strips[1]]", "missing sensor"),
    case("platform-prior-without-sigma", lambda r: (r / PT).write_text(
        (r / PT).read_text() + '[[relative_mountings]]\nsensor = "b"\nreference = "a"\nboresight_deg = [0, 0, 0]\n'),
         PT, "[relative_mountings[0].boresight_sigma_deg]", "missing"),
    case("platform-prior-to-itself", lambda r: (r / PT).write_text(
        (r / PT).read_text() + '[[relative_mountings]]\nsensor = "b"\nreference = "b"\nboresight_deg = [0, 0, 0]\n'
        'boresight_sigma_deg = [0.1, 0.1, 0.1]\n'), PT, "[relative_mountings[0].reference]"),
    case("platform-flight-line-without-strips", lambda r: (r / PT).write_text(
        (r / PT).read_text().replace("[[strips]]", '[[flight_lines]]\nid = "L7"\ntrajectory = "nav/01.csv"\n\n'
                                                   "[[strips]]", 1)), PT, "flight line 'L7' has no strip"),
    case("platform-strips-apart-in-time",
         replace(PT, 'id = "b01"\nimage = "images/01.tif"\nfirst_line_time = 300000.0',
                 'id = "b01"\nimage = "images/01.tif"\nfirst_line_time = 303600.0'), PT,
         "strip 01", "strip b01", "do not overlap in time"),
    case("platform-sensor-and-sensors", lambda r: (r / PT).write_text(
        (r / PT).read_text().replace("[[sensors]]", '[sensor]\nkind = "whiskbroom"\n\n[[sensors]]', 1)), PT,
         "expected one [sensor] table or [[sensors]] entries, not both"),
]


@pytest.mark.parametrize("bad", PLATFORM)
def test_adjust_a_platform(bad, platform_block, tmp_path, capsys):
    run_bad(["adjust", "{p}", "--variant", "SE", "--no-progress"], bad, platform_block, tmp_path, capsys)


#: Defects of the strip images, read by rectify.
IMAGES = [
    case("image-wrong-width", raster("images/02.tif", PIXELS - 10, LINES), "images/02.tif", "width"),
    case("image-too-few-lines", raster("images/02.tif", PIXELS, LINES // 2), "images/02.tif", "lines"),
    case("image-truncated", truncate("images/02.tif", 0.4), "images/02.tif"),
    case("image-text", write("images/02.tif", "an image\n"), "images/02.tif"),
    case("image-missing", remove("images/02.tif"), "images/02.tif"),
    case("image-float-dtype-text", write("images/02.tif", b"II*\x00" + bytes(200)), "images/02.tif"),
    case("rectify-config-unknown-key", write("r.toml", "[rectify]\nresolutoin = 2.0\n"), "r.toml", "resolutoin",
         args=("--config", "{p}/r.toml")),
    case("rectify-unknown-strip", lambda r: None, "'09'", args=("--strips", "09")),
    case("rectify-unknown-variant", lambda r: None, "XX", args=("--variant", "XX")),
]


@pytest.mark.parametrize("bad", TOML[:8] + TRAJECTORY[:8] + DTM[:3] + IMAGES)
def test_rectify(bad, small_block, tmp_path, capsys):
    variant = [] if "--variant" in bad.args else ["--variant", "DG"]
    run_bad(["rectify", "{p}", *variant, "--strips", "02", "--resolution", "20", "--no-progress"], bad, small_block,
            tmp_path, capsys)
