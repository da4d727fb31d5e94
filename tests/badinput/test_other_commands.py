"""The bad-input matrix of compare, report, locate, info, simulate and lidar, one defect per case."""
from __future__ import annotations

import shutil

import numpy as np
import pytest

from tests.badinput.defects import (
    case,
    lines,
    patch,
    random_bytes,
    raster,
    remove,
    replace,
    set_field,
    truncate,
    write,
)
from tests.badinput.runner import run_bad
from tests.badinput.test_project_commands import DTM, POINTS, TOML, TRAJECTORY
from tests.session_projects import TWO_VARIANTS

VARIANTS = "variants.toml"

COMPARE = TOML[:6] + TRAJECTORY[:4] + TRAJECTORY[6:8] + POINTS[:3] + POINTS[13:15] + DTM[:2] + [
    case("compare-variants-unknown-key", replace(VARIANTS, 'strategy = "SE"', 'strategy = "SE"\nsnoop = true'),
         VARIANTS, "snoop"),
    case("compare-variants-syntax", replace(VARIANTS, "[variants.SE]", "[variants.SE"), VARIANTS, "line"),
    case("compare-variants-empty", write(VARIANTS, ""), VARIANTS, "[variants.NAME]"),
    case("compare-variants-bad-role", replace(VARIANTS, 'strategy = "SE"', 'strategy = "SE"\nroles = {"E*" = "boss"}'),
         VARIANTS, "roles", "'boss'"),
    case("compare-only-unknown", lambda r: None, VARIANTS, "'XX'", args=("--only", "XX")),
    case("compare-variants-file-missing", lambda r: None, "none.toml", args=("--variants", "{p}/none.toml")),
]


def _two_variants(root):
    (root / VARIANTS).write_text(TWO_VARIANTS, encoding="utf-8")


@pytest.mark.parametrize("bad", COMPARE)
def test_compare(bad, small_block, tmp_path, capsys):
    run_bad(["compare", "{p}", "--no-report", "--no-progress"], bad, small_block, tmp_path, capsys, setup=_two_variants)


REPORT = TOML[:4] + [
    case("report-not-compared", lambda r: shutil.rmtree(r / "results"), "comparison.json", "scangeo compare"),
    case("report-comparison-not-json", write("results/comparison.json", "{not json"), "comparison.json"),
    case("report-comparison-wrong-json", write("results/comparison.json", '{"variants": 3}'), "comparison.json"),
    case("report-residuals-no-column",
         lines("results/SE/residuals.csv", lambda r: [r[0].replace("residual", "v")] + r[1:]), "residuals.csv",
         "residual"),
    case("report-residuals-missing", remove("results/SE/residuals.csv"), "residuals.csv"),
    case("report-points-unknown-role", lines("ground.csv", set_field(2, 6, "kontrol")), "ground.csv", "line 2"),
]


@pytest.mark.parametrize("bad", REPORT)
def test_report(bad, compared_block, tmp_path, capsys):
    run_bad(["report", "{p}", "--no-progress"], bad, compared_block, tmp_path, capsys)


LOCATE = TOML[:3] + TRAJECTORY[:3] + [
    case("locate-image-missing-column", write("q.csv", "point,row,pixel\nA,10,20\n"), "q.csv", "line 1",
         args=("--image", "{p}/q.csv")),
    case("locate-image-text", write("q.csv", "point,line,pixel\nA,10,20\nB,ten,20\n"), "q.csv", "line 3",
         args=("--image", "{p}/q.csv")),
    case("locate-image-nan", write("q.csv", "point,line,pixel\nA,nan,20\n"), "q.csv", "line 2",
         args=("--image", "{p}/q.csv")),
    case("locate-image-empty", write("q.csv", ""), "q.csv", args=("--image", "{p}/q.csv")),
    case("locate-image-missing-file", lambda r: None, "none.csv", args=("--image", "{p}/none.csv")),
    case("locate-ground-missing-column", write("g.csv", "point,x\nA,10\n"), "g.csv", "line 1",
         args=("--ground", "{p}/g.csv")),
    case("locate-ground-text", write("g.csv", "point,x,y\nA,10,20\nB,1,north\n"), "g.csv", "line 3",
         args=("--ground", "{p}/g.csv")),
    case("locate-unknown-strip", write("q.csv", "point,line,pixel\nA,10,20\n"), "'09'",
         args=("--image", "{p}/q.csv", "--strip", "09")),
    case("locate-unknown-variant", write("q.csv", "point,line,pixel\nA,10,20\n"), "XX",
         args=("--image", "{p}/q.csv", "--variant", "XX")),
]


@pytest.mark.parametrize("bad", LOCATE)
def test_locate(bad, small_block, tmp_path, capsys):
    args = [] if {"--image", "--ground"} & set(bad.args) else ["--image", "{p}/q.csv"]
    setup = (lambda r: (r / "q.csv").write_text("point,line,pixel\nA,10,20\n")) if args else None
    run_bad(["locate", "{p}", "--strip", "02", "--no-progress", *args], bad, small_block, tmp_path, capsys,
            setup=setup)


INFO = [
    case("info-missing-file", lambda r: None, "nothing.csv", args=("{p}/nothing.csv",)),
    case("info-trajectory-nan", lines("nav/02.csv", set_field(300, 1, "nan")), "nav/02.csv", "line 300",
         args=("{p}/nav/02.csv",)),
    case("info-trajectory-backwards", lines("nav/02.csv", lambda r: r[:10] + r[11:12] + r[10:11] + r[12:]),
         "nav/02.csv", "line 12", args=("{p}/nav/02.csv",)),
    case("info-trajectory-binary", random_bytes("nav/02.csv", 3000), "nav/02.csv", args=("{p}/nav/02.csv",)),
    case("info-trajectory-xy-bad-crs", write("t.csv", "time,x,y,z,roll,pitch,heading\n1,0,0,0,0,0,0\n2,1,1,0,0,0,0\n"),
         "EPSG:999999", args=("{p}/t.csv", "--crs", "EPSG:999999")),
    case("info-dtm-truncated", truncate("dtm.tif", 0.3), "dtm.tif", args=("{p}/dtm.tif",)),
    case("info-image-text", write("images/02.tif", "text"), "images/02.tif", args=("{p}/images/02.tif",)),
    case("info-points-text", lines("points.csv", set_field(4, 3, "x12")), "points.csv", "line 4",
         args=("{p}/points.csv",)),
    case("info-ground-role", lines("ground.csv", set_field(2, 6, "kontrol")), "ground.csv", "line 2",
         args=("{p}/ground.csv",)),
    case("info-project-bad-crs", replace("project.toml", "EPSG:32633", "EPSG:999999"), "project.toml", "crs",
         args=("{p}",)),
    case("info-sbet-truncated", write("nav/x.out", bytes(136 * 3 + 20)), "nav/x.out", "truncated",
         args=("{p}/nav/x.out",)),
]


@pytest.mark.parametrize("bad", INFO)
def test_info(bad, small_block, tmp_path, capsys):
    run_bad(["info"], bad, small_block, tmp_path, capsys)


def _preset(edit):
    """A user preset: data/presets/small.toml copied into the case folder, then edited."""

    def apply(root):
        from scangeo.simulate.config import preset_path

        (root / "preset.toml").write_text(edit(preset_path("small").read_text(encoding="utf-8")), encoding="utf-8")

    return apply


SIMULATE_ARGS = ("{p}/out", "--preset", "{p}/preset.toml", "--no-images")
SIMULATE = [
    case("preset-syntax", _preset(lambda t: t.replace("[sensor]", "[sensor")), "preset.toml", "line",
         args=SIMULATE_ARGS),
    case("preset-unknown-key", _preset(lambda t: t.replace("pixels = 716", "pixels = 716\npixel = 3")),
         "preset.toml", "pixel", args=SIMULATE_ARGS),
    case("preset-wrong-type", _preset(lambda t: t.replace("pixels = 716", 'pixels = "716"')), "preset.toml",
         "pixels", args=SIMULATE_ARGS),
    case("preset-bad-crs", _preset(lambda t: t.replace('crs = "EPSG:32633"', 'crs = "EPSG:999999"')),
         "preset.toml", "crs", "EPSG:999999", args=SIMULATE_ARGS),
    case("preset-negative-lines", _preset(lambda t: t.replace("lines = 600", "lines = -5")), "preset.toml",
         "lines", args=SIMULATE_ARGS),
    case("preset-unknown-table", _preset(lambda t: t + "\n[weather]\nrain = 1\n"), "preset.toml", "weather",
         args=SIMULATE_ARGS),
    case("preset-missing", lambda r: None, "none.toml", args=("{p}/out", "--preset", "{p}/none.toml")),
    case("preset-set-unknown-key", _preset(lambda t: t), "flight", "altitude",
         args=(*SIMULATE_ARGS, "--set", "flight.altitude=3")),
    case("preset-dtm-not-dem", _preset(lambda t: t), "images/02.tif",
         args=(*SIMULATE_ARGS, "--dtm", "{p}/images/02.tif")),
]


@pytest.mark.parametrize("bad", SIMULATE)
def test_simulate(bad, small_block, tmp_path, capsys):
    run_bad(["simulate"], bad, small_block, tmp_path, capsys)


# ---------------------------------------------------------------------------------------- lidar
def _lidar_files(root):
    """A tiny SBET, a LAS with GPS times inside it, and a leeward config.toml."""
    import laspy

    from scangeo.trajectory.readers import SBET_RECORD

    n = 200
    rec = np.zeros(n, dtype=SBET_RECORD)
    rec["time"] = 1000.0 + np.arange(n) * 0.01
    rec["lat"], rec["lon"], rec["alt"] = np.radians(48.2), np.radians(16.3) + np.arange(n) * 1e-7, 1500.0
    rec.tofile(root / "nav.out")
    las = laspy.create(point_format=1, file_version="1.2")
    las.header.offsets = [600000.0, 5340000.0, 0.0]
    las.header.scales = [0.01, 0.01, 0.01]
    m = 50
    las.x = 600000.0 + np.arange(m)
    las.y = np.full(m, 5340000.0)
    las.z = np.full(m, 200.0)
    las.gps_time = 1000.5 + np.arange(m) * 0.01
    las.scan_angle_rank = np.linspace(-20, 20, m).astype(np.int8)
    las.write(str(root / "returns.las"))
    (root / "config.toml").write_text("utm_zone = 33\nlever_arm = [0.0, 0.0, 0.0]\n\n[boresight]\nroll = 0.0\n"
                                      "pitch = 0.0\nyaw = 0.0\n", encoding="utf-8")


def _las_without_gps_time(root):
    import laspy

    las = laspy.create(point_format=0, file_version="1.2")
    las.x, las.y, las.z = np.array([600000.0]), np.array([5340000.0]), np.array([200.0])
    las.write(str(root / "returns.las"))


LIDAR_ARGS = ("--sbet", "{p}/nav.out", "--las", "{p}/returns.las", "--system", "{p}/config.toml")
LIDAR = [
    case("las-no-gps-time", _las_without_gps_time, "returns.las", "GPS time"),
    case("las-truncated", truncate("returns.las", 0.6), "returns.las"),
    case("las-random-bytes", random_bytes("returns.las", 2000), "returns.las"),
    case("las-empty", write("returns.las", b""), "returns.las"),
    # LAS 1.2 header fields (docs/formats.md "Checks on input"): legacy point count, VLR count
    case("las-header-point-count", patch("returns.las", 107, b"\xff\xff\xff\xff"), "returns.las",
         "[header.point_count]", "truncated"),
    case("las-header-vlr-count", patch("returns.las", 100, b"\xff\xff\xff\xff"), "returns.las",
         "[header.number_of_vlrs]"),
    case("lidar-sbet-truncated", truncate("nav.out", 136 * 100 + 7), "nav.out", "136"),
    case("lidar-sbet-empty", write("nav.out", b""), "nav.out"),
    case("lidar-config-missing-key", write("config.toml", "utm_zone = 33\n"), "config.toml", "lever_arm"),
    case("lidar-las-outside-sbet", truncate("nav.out", 136 * 20),
         "returns.las", "outside"),
]


@pytest.mark.parametrize("bad", LIDAR)
def test_lidar_check_returns(bad, small_block, tmp_path, capsys):
    run_bad(["lidar", "check-returns", *LIDAR_ARGS], bad, small_block, tmp_path, capsys, setup=_lidar_files)


# the laser analysis tools' options: sigmas and lengths in metres, an error names the flag
BUDGET_ARGS = ("budget", "--points", "10", "--pieces", "1")
LIDAR_OPTIONS = [
    case("lidar-budget-negative-sigma", lambda r: None, "--sigma-noise -0.01: expected a number >= 0 (m)",
         args=(*BUDGET_ARGS, "--strip-count", "1", "--sigma-noise", "-0.01")),
    case("lidar-budget-no-strips", lambda r: None, "--strip-count 0: expected 1 or more",
         args=(*BUDGET_ARGS, "--strip-count", "0")),
    case("lidar-budget-negative-alpha", lambda r: None, "--alpha -0.5: expected a number >= 0",
         args=(*BUDGET_ARGS, "--strip-count", "1", "--alpha", "-0.5")),
    case("lidar-budget-covariance-not-square", write("cov.txt", "1 2 3\n4 5 6\n"), "cov.txt", "square",
         args=(*BUDGET_ARGS, "--strip-count", "1", "--offset-covariance", "{p}/cov.txt")),
    case("lidar-budget-covariance-no-offset-sigma", write("cov.txt", "1e-4 0\n0 1e-4\n"),
         "--sigma-offset 0: expected a number > 0",
         args=(*BUDGET_ARGS, "--strip-count", "1", "--offset-covariance", "{p}/cov.txt", "--sigma-offset", "0")),
    case("lidar-network-negative-sigma", lambda r: None, "--sigma-tie -0.03: expected a number > 0 (m)",
         args=("network", "--sigma-tie", "-0.03")),
    case("lidar-network-overlap", lambda r: None, "--overlap 1: expected a number in [0, 1)",
         args=("network", "--overlap", "1")),
    case("lidar-network-no-strips", lambda r: None, "--strip-count 0: expected an integer >= 1",
         args=("network", "--strip-count", "0")),
    case("lidar-forward-reverse-scan-angle", lambda r: None, "total scan angle", "expected 0 < fov < 180",
         args=("forward-reverse", "--scan-angle", "200")),
]


@pytest.mark.parametrize("bad", LIDAR_OPTIONS)
def test_lidar_tools_options(bad, small_block, tmp_path, capsys):
    run_bad(["lidar"], bad, small_block, tmp_path, capsys)


def test_lidar_check_returns_heading(small_block, tmp_path, capsys):
    bad = case("lidar-sbet-heading", lambda r: None, "--sbet-heading grid: expected one of platform, true",
               args=("--sbet-heading", "grid")).values[0]
    run_bad(["lidar", "check-returns", *LIDAR_ARGS], bad, small_block, tmp_path, capsys, setup=_lidar_files)


# ---------------------------------------------------------------------------------------- match
# The strip images are not among them: on this block match stops with "no strips overlap" before it reads
# an image.
MATCH = TOML[:4] + DTM[:1] + [
    case("match-config-unknown-key", write("m.toml", "[match]\nper_overlapp = 3\n"), "m.toml", "per_overlapp",
         args=("--config", "{p}/m.toml")),
    case("match-config-wrong-type", write("m.toml", '[match]\nper_overlap = "many"\n'), "m.toml", "per_overlap",
         args=("--config", "{p}/m.toml")),
    case("match-reference-missing", lambda r: None, "none.tif", args=("--reference", "{p}/none.tif")),
    case("match-reference-text", write("ref.tif", "not a raster"), "ref.tif", args=("--reference", "{p}/ref.tif")),
    case("match-reference-no-crs", raster("ref.tif", 50, 50, bands=3), "ref.tif", args=("--reference", "{p}/ref.tif")),
    case("match-unknown-variant", lambda r: None, "XX", args=("--variant", "XX")),
]


@pytest.mark.parametrize("bad", MATCH)
def test_match(bad, small_block, tmp_path, capsys):
    run_bad(["match", "{p}", "--no-progress"], bad, small_block, tmp_path, capsys)


# --------------------------------------------------------------------------- scangeo run on a laser project
LAS1 = "strips/1.las"


def known_gap(id, reason, defect, *expect):
    """A case that fails today (a known gap); strict: it turns into an error once fixed."""
    return pytest.param(*case(id, defect, *expect).values, marks=pytest.mark.xfail(reason=reason, strict=True), id=id)


LIDAR_ADJUST = [
    case("laser-toml-unknown-key", replace("project.toml", "fov_deg = 40.0", "fov_deg = 40.0\nfov = 3"),
         "project.toml", "fov"),
    case("laser-toml-wrong-type", replace("project.toml", "range_sigma_m = 0.02", 'range_sigma_m = "small"'),
         "project.toml", "range_sigma_m"),
    case("laser-toml-bad-crs", replace("project.toml", "EPSG:32633", "EPSG:999999"), "project.toml", "crs"),
    case("laser-toml-adjustment-unknown-key", lambda r: (r / "project.toml").open("a").write(
        "\n[adjustment]\npatch_sise = 4.0\n"), "project.toml", "patch_sise"),
    case("laser-las-to-nothing", replace("project.toml", '"strips/1.las"', '"strips/none.las"'), "strips/none.las"),
    case("laser-las-to-directory", replace("project.toml", '"strips/1.las"', '"strips"'), "strips"),
    case("las-no-gps-time", lambda r: _las_without_gps_time_at(r / LAS1), LAS1, "GPS time"),
    case("las-truncated", truncate(LAS1, 0.6), LAS1),
    case("las-random-bytes", random_bytes(LAS1, 5000), LAS1),
    case("las-empty", write(LAS1, b""), LAS1),
    # LAS 1.4 header fields: the 64-bit point count, the offset to the point data
    case("las-header-point-count", patch(LAS1, 247, (1 << 40).to_bytes(8, "little")), LAS1, "[header.point_count]"),
    case("las-header-offset-to-points", patch(LAS1, 96, b"\xff\xff\xff\x7f"), LAS1,
         "[header.offset_to_point_data]"),
    case("laser-trajectory-nan", lines("nav/1.csv", set_field(50, 1, "nan")), "nav/1.csv", "line 50"),
    case("laser-trajectory-short", lines("nav/1.csv", lambda r: r[:200]), "nav/1.csv", "cover"),
    case("laser-ground-unknown-role", lines("ground.csv", set_field(2, 7, "kontrol")), "ground.csv", "line 2"),
    case("laser-ground-sigma-zero", lines("ground.csv", set_field(2, 5, "0")), "ground.csv", "line 2"),
    case("laser-ground-missing-column", lines("ground.csv", lambda r: [r[0].replace("patch", "group")] + r[1:]),
         "ground.csv", "patch"),
]


def _las_without_gps_time_at(path):
    import laspy

    las = laspy.create(point_format=0, file_version="1.2")
    las.x, las.y, las.z = np.array([500000.0]), np.array([5300000.0]), np.array([10.0])
    las.write(str(path))


@pytest.mark.parametrize("bad", LIDAR_ADJUST)
def test_laser_run(bad, laser_block, tmp_path, capsys):
    run_bad(["run", "{p}", "--no-progress"], bad, laser_block, tmp_path, capsys, kept="results/")
