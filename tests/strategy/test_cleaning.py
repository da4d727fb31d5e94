"""Clean first: injected blunders are found and set aside for every later adjustment; sigma0 far above 1 warns."""
from __future__ import annotations

import csv
import json
import shutil
from collections import Counter

import pytest

from scangeo.adjustment.diagnosis.diagnose import diagnose
from scangeo.adjustment.plausibility import sigma0_warning
from scangeo.adjustment.results import read_measurements
from scangeo.io.point_checks import check_points
from scangeo.io.project import Project
from scangeo.io.rejected import read_rejected, rejected_path
from scangeo.strategy.cleaning import CleaningOptions, clean, restore

#: Pieces of 200 lines: the problem strip of ``problem_small`` drifts by 40 m in 200 lines (vienna2000's
#: drift is ten times slower: there the default, 700 lines, follows it).
OPTIONS = CleaningOptions(piece_lines=200.0)


def _rows(path):
    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


@pytest.fixture(scope="module")
def blundered(problem_small, tmp_path_factory):
    """``problem_small`` with 20 px blunders in six measurements: two control and two check points seen in
    two strips (separable: the other ray and the coordinates agree) and two tie points seen in two strips
    (not separable: either ray may hold it)."""
    root = tmp_path_factory.mktemp("cleaning") / "small"
    shutil.copytree(problem_small, root)
    rows = _rows(root / "points.csv")
    seen = Counter(r["point"] for r in rows)
    role = {r["point"]: r["role"] for r in _rows(root / "ground.csv")}
    picks = {}
    for kind in ("control", "check", "tie"):
        for p in [p for p in sorted(seen) if role.get(p, "tie") == kind and seen[p] == 2][:2]:
            picks[(p, next(r["strip"] for r in rows if r["point"] == p))] = kind
    for i, r in enumerate(rows):
        if (r["point"], r["strip"]) in picks:
            r["pixel"] = f"{float(r['pixel']) + (20.0 if i % 2 else -20.0):.4f}"
    with open(root / "points.csv", "w", newline="", encoding="utf-8") as f:
        writer = csv.DictWriter(f, list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    return root, picks


@pytest.fixture(scope="module")
def cleaned(blundered):
    """The blundered project cleaned (read-only: tests copy it)."""
    root, picks = blundered
    return root, picks, clean(root, OPTIONS)


def test_blunders_are_set_aside_and_the_good_measurements_kept(cleaned):
    root, picks, c = cleaned
    image = {r.key: r for r in c.rejected if r.kind == "image"}
    for key, kind in picks.items():
        assert key in image, f"blunder {key} ({kind}) not rejected"
        assert image[key].separable == (kind != "tie"), (key, image[key].reason)
        assert image[key].mdb < 25.0 and abs(image[key].w) > 4.0
    # a good measurement rejected on its own must be an outlier of the simulated noise (|error| > 3 sigma)
    error = {(r["point"], r["strip"]): max(abs(float(r["line"]) - float(r["line_true"])),
                                           abs(float(r["pixel"]) - float(r["pixel_true"])))
             for r in _rows(root / "truth" / "measurements.csv")}
    for key, r in image.items():
        if key not in picks and r.separable:
            assert error[key] > 3 * 0.3, (key, error[key], r.w)
    others = {r.point for r in c.rejected if not r.separable} - {p for p, _ in picks}
    assert len(others) <= 2, others       # a tie point whose DTM height is off (the DTM's own error)
    assert c.sigma0_before > 4.0 and c.sigma0_after < 1.2
    # the file: what every later adjustment leaves out, read back as written
    assert {r.key for r in read_rejected(rejected_path(root))} == c.rejected_keys
    saved = json.loads((root / "results" / "cleaning" / "cleaning.json").read_text())
    assert saved["rejected"]["image"] == len(image)
    points, _ = read_measurements(Project.load(root))
    kept = set(zip(points.point.astype(str), points.strip.astype(str)))
    assert not kept & set(image) and len(kept) + len(image) == len(_rows(root / "points.csv"))


def test_restore_and_a_corrected_measurement_bring_them_back(cleaned, tmp_path):
    root = shutil.copytree(cleaned[0], tmp_path / "p")
    key = next(iter(cleaned[1]))
    tie = next(k for k, kind in cleaned[1].items() if kind == "tie")   # its partner stays set aside
    truth = {(r["point"], r["strip"]): r for r in _rows(root / "truth" / "measurements.csv")}
    points = _rows(root / "points.csv")
    for r in points:
        if (r["point"], r["strip"]) in (key, tie):
            r["pixel"] = truth[(r["point"], r["strip"])]["pixel"]       # the user fixes the typos
    with open(root / "points.csv", "w", newline="", encoding="utf-8") as f:
        writer = csv.DictWriter(f, list(points[0]))
        writer.writeheader()
        writer.writerows(points)
    project = Project.load(root)
    back, ground = read_measurements(project)
    kept = set(zip(back.point.astype(str), back.strip.astype(str)))
    assert key in kept and len(kept) == len(points) - len([r for r in cleaned[2].rejected if r.kind == "image"]) + 1
    assert tie not in kept       # a tie point with one measurement left cannot be used: set aside, no error
    check_points(project, back, ground)
    assert restore(root) and not restore(root)
    back, _ = read_measurements(Project.load(root))
    assert len(back) == len(points)     # restored: every measurement is used again


def test_sigma0_warning_fires_on_the_blundered_block_and_not_after_cleaning(cleaned, tmp_path):
    root = shutil.copytree(cleaned[0], tmp_path / "p", ignore=shutil.ignore_patterns("results"))
    before = diagnose(root, refine=None)
    assert before.sigma0 > 4.0
    assert "far above 1" in before.notes[0] and "not cleaned" in before.notes[0]
    shutil.copytree(cleaned[0] / "results", root / "results")
    after = diagnose(root, refine=None)
    assert after.sigma0 < 2.0 and not any("far above 1" in n for n in after.notes)
    assert after.problem_strips == ["02"]     # the drift the blunders hid is found again


def test_sigma0_warning_names_the_causes(tmp_path):
    assert sigma0_warning(1.9, "x") is None and sigma0_warning(float("nan"), "x") is None
    text = sigma0_warning(5.0, "the diagnosis's SE adjustment", tmp_path)
    assert text is not None and "sigma0 5.00" in text
    for cause in ("not cleaned", "sigmas", "too stiff", "DTM", "calibration"):
        assert cause in text
    rejected_path(tmp_path).parent.mkdir(parents=True)
    rejected_path(tmp_path).write_text("kind,point\n", encoding="utf-8")
    assert "rejected.csv" in (sigma0_warning(5.0, "x", tmp_path) or "")


def test_clean_command_restores_and_checks_its_options(cleaned, tmp_path, capsys):
    from scangeo.cli import main

    root = shutil.copytree(cleaned[0], tmp_path / "p")
    assert main(["clean", str(root), "--piece-lines", "0", "--no-progress"]) == 1
    assert "--piece-lines 0: expected a number > 0 (line), found 0.0" in capsys.readouterr().err
    assert rejected_path(root).exists()
    assert main(["clean", str(root), "--restore"]) == 0
    assert "used again" in capsys.readouterr().out and not rejected_path(root).parent.exists()
