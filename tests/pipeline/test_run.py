"""``scangeo run`` on a messy project: a textured block with blunders and no tie points (docs/run.md).

One uninterrupted run (``ran``) is made once per module; the other tests copy it. The project carries a
``run.toml`` with ``[compare] folds = 2`` (a cross-validation of 2 folds instead of 4: the same stages at
60 % of the comparison's cost).
"""
from __future__ import annotations

import csv
import hashlib
import json
import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
import rasterio
from pystac.extensions.projection import ProjectionExtension

from scangeo import __version__
from scangeo.pipeline.run import run
from scangeo.reports.stac_validation import validate_items
from scangeo.reports.tables import read_comparison
from tests.rectify.test_cog_properties import check_written_cog
from tests.session_projects import copy_project

SETTINGS = "[compare]\nfolds = 2\n"


def _edit_control(root: Path, dx: float = 0.4) -> str:
    """Move the first control point of ground.csv by ``dx`` metres east; returns its id."""
    path = root / "ground.csv"
    rows = list(csv.reader(path.open(encoding="utf-8")))
    for r in rows[1:]:
        if r[6] == "control":
            r[1] = f"{float(r[1]) + dx:.4f}"
            with path.open("w", newline="", encoding="utf-8") as f:
                csv.writer(f).writerows(rows)
            return r[0]
    raise AssertionError("no control point")


@pytest.fixture(scope="module")
def ran(textured_block, tmp_path_factory):
    """The textured block copied and run once: (root, result, progress calls)."""
    root = copy_project(textured_block, tmp_path_factory.mktemp("run") / "block")
    (root / "run.toml").write_text(SETTINGS, encoding="utf-8")
    calls: list[tuple[float, float, str]] = []
    result = run(root, progress=lambda d, t, m="": calls.append((d, t, m)))
    return root, result, calls


def test_every_stac_item_and_every_cog_of_the_run_is_valid_with_the_network_blocked(ran, no_network):
    """What the demo writes, as every run does: each STAC item valid by the core item schema and its
    extensions' (the schemas from the disk), each COG by rio-cogeo's strict validation."""
    root, result, _ = ran
    items = sorted((root / "results").rglob("*.stac.json"))
    rasters = sorted(p for p in (root / "results").rglob("*.tif"))
    # an item per orthoimage and the mosaic (the layers have none)
    assert items and len(items) == len([p for p in rasters if not p.name.endswith(".layers.tif")])
    assert all(schemas[1:] == [ProjectionExtension.get_schema_uri()] for schemas in validate_items(items).values())
    for path in rasters:
        check_written_cog(path)
    assert no_network == []


def _check_report(root: Path, recommended: str) -> None:
    """report.html holds the run's comparison: the table's rows with every variant, each variant's section,
    the diagnosis (its breaks table when it found breaks), the figures, the recommendation."""
    text = (root / "results" / "report.html").read_text(encoding="utf-8")
    c = read_comparison(root / "results")
    names = [v.name for v in c.variants]
    assert len(names) >= 3 and recommended in names
    table = text[text.index('id="comparison-table"'):]
    table = table[:table.index("</table>")]
    assert table.count("<tr>") > len([v for v in c.variants if v.error is None])
    for v in names:
        assert f"<h3>{v}</h3>" in text and f">{v}</td>" in table, v
    for part in ('id="fig-rms"', 'id="fig-diagnosis"', 'id="crossvalidation-table"', 'id="accounting-table"'):
        assert part in text, part
    breaks = json.loads((root / "results" / "diagnosis.json").read_text(encoding="utf-8"))["breaks"]
    assert ('id="breaks-table"' in text) == bool(breaks)
    assert text.count("data:image/png;base64,") >= len(names) + 2
    assert f"Recommended: {recommended} (" in text


def test_one_run_makes_the_orthoimages_and_the_report(ran):
    root, result, calls = ran
    assert result.ran == ["check", "match", "clean", "diagnose", "compare", "rectify", "report"]
    assert result.outcome("match").reason and "no earlier run" in result.outcome("match").reason
    # match measured the tie points the project lacked
    assert result.summary_of("match")["tie_points"] > 0
    assert result.summary_of("check")["tie_points"] == 0
    name = result.recommended
    assert name is not None
    ortho = root / "results" / name / "ortho"
    for sid in ("01", "02"):
        with rasterio.open(ortho / f"{sid}.tif") as src:
            assert src.tags()["variant"] == name and src.crs is not None
            assert np.count_nonzero(src.read(1)) > 0.3 * src.width * src.height
    assert (ortho / "mosaic.tif").exists()
    for path in sorted(ortho.glob("*.tif")):  # rio-cogeo's strict validation; a first overview is the 2 x 2 mean
        check_written_cog(path)
    _check_report(root, name)
    # one progress display: fractions of one total, never backwards, ending at 1
    fractions = [d / t for d, t, _ in calls if t]
    assert fractions[-1] == 1.0 and min(fractions) >= 0.0
    assert all(b >= a - 1e-9 for a, b in zip(fractions, fractions[1:]))
    assert {m.split(":")[0] for _, _, m in calls} >= {"check", "match", "clean", "diagnose", "compare", "report"}


def test_the_manifest_records_inputs_stages_and_the_recommended_variant(ran):
    root, result, _ = ran
    m = json.loads((root / "results" / "run.json").read_text(encoding="utf-8"))
    assert m["scangeo"] == __version__ and m["finished"] >= m["started"]
    for name in ("project.toml", "dtm.tif", "ground.csv", "points.csv", "images/02.tif", "nav/01.csv"):
        assert m["inputs"][name]["sha256"] == hashlib.sha256((root / name).read_bytes()).hexdigest(), name
    assert m["options"]["folds"] == 2 and m["options"]["rectify_options"]["mosaic"] is True
    for name, record in m["stages"].items():
        assert record["status"] == "ran" and record["seconds"] >= 0, name
        assert len(record["fingerprint"]) == 24
    rec = m["recommended"]
    assert rec["variant"] == result.recommended and rec["why"]
    assert rec["sigma0"] > 0 and rec["check_rms_px"] > 0
    folder = f"results/{rec['variant']}/ortho"
    assert sorted(rec["orthoimages"]) == [f"{folder}/{n}.tif" for n in ("01", "02", "mosaic")]


def test_a_second_run_does_nothing_and_a_rectify_setting_reruns_rectify_and_the_report(ran, tmp_path):
    root = copy_project(ran[0], tmp_path / "block")  # new mtimes and inodes: the files are hashed again
    again = run(root)
    assert again.ran == []
    assert [o.status for o in again.stages] == ["up to date"] * 7
    assert again.recommended == ran[1].recommended
    (root / "run.toml").write_text(SETTINGS + '[rectify]\nresampling = "nearest"\n', encoding="utf-8")
    changed = run(root)
    assert changed.ran == ["rectify", "report"]  # the report's quicklook shows the mosaic
    assert "options changed: resampling" in changed.outcome("rectify").reason
    assert changed.outcome("report").reason == "stage rectify ran"


def test_an_edited_control_point_reruns_from_clean_not_match(ran, tmp_path):
    root = copy_project(ran[0], tmp_path / "block")
    _edit_control(root)
    # up to diagnose only: compare, rectify and report follow clean by rule (they read its results), and
    # running them here would double the test's time
    result = run(root, until="diagnose")
    assert result.ran == ["clean", "diagnose"]
    assert result.outcome("match").status == "up to date"
    assert result.outcome("check").status == "up to date"
    assert "ground.csv changed" in result.outcome("clean").reason
    assert result.outcome("diagnose").reason == "stage clean ran"
    assert [result.outcome(n).status for n in ("compare", "rectify", "report")] == ["not run"] * 3


KILLER = textwrap.dedent("""
    import os, signal, sys, time
    from scangeo.pipeline.run import run

    seen = 0

    def progress(done, total, message=""):
        global seen
        seen += message.startswith(sys.argv[3])
        if seen == int(sys.argv[4]):
            # a file that must be complete first (a strip whose COG the pipeline's background step writes
            # while the next strip is rectified): waited for, at most two minutes
            end = time.monotonic() + 120.0
            while len(sys.argv) > 5 and not os.path.exists(sys.argv[5]) and time.monotonic() < end:
                time.sleep(0.05)
            os.kill(os.getpid(), signal.SIGKILL)

    run(sys.argv[1], from_stage=sys.argv[2], progress=progress)
""")


def _outputs(root: Path, name: str, roots: list[Path]) -> dict:
    """What must not differ between an interrupted and an uninterrupted run (timings, dates, the folders
    ``roots`` the files name aside)."""

    def text(path: Path) -> str:
        t = path.read_text(encoding="utf-8")
        for r in roots:
            t = t.replace(str(r), "ROOT")
        return t

    out: dict = {}
    ortho = root / "results" / name / "ortho"
    for tif in sorted(ortho.glob("*.tif")):
        with rasterio.open(tif) as src:
            out[tif.name] = (src.read(), src.transform, src.tags())
    for item in sorted(ortho.glob("*.stac.json")):
        d = json.loads(item.read_text(encoding="utf-8"))
        for k in ("datetime", "created"):
            d["properties"].pop(k)
        d["id"] = d["id"].split("-", 1)[1]  # the project folder's name differs
        out[item.name] = d
    comparison = json.loads(text(root / "results" / "comparison.json"))
    for v in comparison["variants"]:
        v.pop("seconds")
    out["comparison"] = comparison
    for file in ("points.csv", "variants.toml", "results/diagnosis.json"):
        out[file] = text(root / file)
    for f in sorted((root / "results" / "cleaning").iterdir()):
        out[str(f.relative_to(root))] = text(f)
    return out


def test_a_run_killed_in_every_stage_in_turn_resumes_to_the_same_outputs(ran, tmp_path):
    # One process per stage: ``--from STAGE``, SIGKILLed at the stage's second progress report (rectify: at
    # strip 02's second, once strip 01's COG, written in the background meanwhile, is complete). The next
    # process must first finish the stage the last one was killed in ("stopped in it"), then is killed in its
    # own; a last plain run finishes the report. The outputs are then those of the uninterrupted run, and no
    # partial file is left anywhere.
    name = ran[1].recommended
    root = copy_project(ran[0], tmp_path / "block")
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2])}
    stages = ["check", "match", "clean", "diagnose", "compare", "rectify", "report"]
    killed_in = None
    for stage in stages:
        prefix = "rectify: strip 02: " if stage == "rectify" else stage  # a stage's reports start with its name
        if stage == "rectify":  # orthoimages complete with the current fingerprint would be skipped
            for sid in ("01", "02"):
                (root / "results" / name / "ortho" / f"{sid}.tif").unlink()
        first = [str(root / "results" / name / "ortho" / "01.tif")] if stage == "rectify" else []
        killed = subprocess.run([sys.executable, "-c", KILLER, str(root), stage, prefix, "2", *first], env=env,
                                capture_output=True, text=True, timeout=600)
        assert killed.returncode == -signal.SIGKILL, (stage, killed.stderr[-2000:])
        record = json.loads((root / "results" / "run.json").read_text(encoding="utf-8"))["stages"]
        assert record[stage]["status"] == "running", stage
        if killed_in is not None:  # the stage the last process was killed in was done first
            assert record[killed_in]["status"] == "ran", (stage, killed_in)
            assert record[killed_in]["reason"] == "the last run stopped in it (running)", killed_in
        if stage == "rectify":
            assert (root / "results" / name / "ortho" / "01.tif").exists()
            assert not (root / "results" / name / "ortho" / "02.tif").exists()
        killed_in = stage
    resumed = run(root)
    assert resumed.ran == ["report"]
    assert "stopped in it (running)" in resumed.outcome("report").reason
    record = json.loads((root / "results" / "run.json").read_text(encoding="utf-8"))["stages"]
    assert record["rectify"]["summary"]["strips"] == {"01": "skipped", "02": "done"}
    mine, theirs = _outputs(root, name, [root, ran[0]]), _outputs(ran[0], name, [root, ran[0]])
    assert mine.keys() == theirs.keys()
    for key in mine:
        if key.endswith(".tif"):
            np.testing.assert_array_equal(mine[key][0], theirs[key][0], err_msg=key)
            assert mine[key][1:] == theirs[key][1:], key
        else:
            assert mine[key] == theirs[key], key
    # no partial file under a final name (a kill may leave a hidden .NAME.PID.tmp, which no run reads)
    for folder in ("", "results", f"results/{name}", f"results/{name}/ortho", "results/cleaning"):
        visible = [sorted(p.name for p in (r / folder).iterdir() if not p.name.startswith(".")) for r in (root, ran[0])]
        assert visible[0] == visible[1], folder
