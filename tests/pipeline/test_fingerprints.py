"""Stage fingerprints, what changed in words, settings and variants.toml ownership (docs/run.md)."""
from __future__ import annotations

import hashlib
import re

import pytest

from scangeo.errors import ScangeoError
from scangeo.match.options import MatchOptions
from scangeo.pipeline.fingerprints import changes, file_stamps, stage_fingerprint
from scangeo.pipeline.settings import Settings, read_settings
from scangeo.pipeline.stages import VARIANTS_MARKER, _variants_are_ours


def test_stamps_are_content_hashes_relative_to_the_project(tmp_path):
    (tmp_path / "a.csv").write_text("x\n1\n", encoding="utf-8")
    outside = tmp_path.parent / f"{tmp_path.name}-outside.tif"
    outside.write_bytes(b"raster")
    stamps = file_stamps([tmp_path / "a.csv", outside, tmp_path / "missing.csv"], tmp_path)
    assert stamps["a.csv"] == {"size": 4, "sha256": hashlib.sha256(b"x\n1\n").hexdigest()}
    assert stamps[outside.name]["sha256"] == hashlib.sha256(b"raster").hexdigest()
    assert stamps["missing.csv"] == {"size": None, "sha256": None}


def test_the_fingerprint_follows_files_options_and_earlier_stages():
    files = {"ground.csv": {"size": 4, "sha256": "aa"}}
    fp = stage_fingerprint("clean", {"k": 1}, files, {"match": "f1"})
    assert fp == stage_fingerprint("clean", {"k": 1}, dict(files), {"match": "f1"})
    assert len({fp, stage_fingerprint("diagnose", {"k": 1}, files, {"match": "f1"}),
                stage_fingerprint("clean", {"k": 2}, files, {"match": "f1"}),
                stage_fingerprint("clean", {"k": 1}, {"ground.csv": {"size": 4, "sha256": "ab"}}, {"match": "f1"}),
                stage_fingerprint("clean", {"k": 1}, files, {"match": "f2"})}) == 5


def test_changes_name_what_differs():
    from scangeo import __version__

    old = {"version": __version__, "files": {"ground.csv": {"sha256": "a"}, "old.csv": {"sha256": "b"}},
           "options": {"resampling": "bilinear", "mosaic": True}, "after": {"compare": "x"}}
    new_files = {"ground.csv": {"sha256": "c"}, "points.csv": {"sha256": "d"}}
    assert changes(old, {"resampling": "nearest", "mosaic": True}, new_files, {"compare": "y"}) == [
        "ground.csv changed", "points.csv new", "old.csv no longer read", "options changed: resampling",
        "stage compare changed"]
    assert changes(old, old["options"], old["files"], old["after"]) == []
    assert changes(None, {}, {}, {}) == ["no earlier run"]


def test_settings_are_checked(tmp_path):
    path = tmp_path / "run.toml"
    path.write_text('[rectify]\nresampling = "nearest"\n[compare]\nfolds = 0\n[clean]\npiece_lines = 500\n',
                    encoding="utf-8")
    s = read_settings(tmp_path)  # PROJECT/run.toml
    assert s.rectify.resampling == "nearest" and s.rectify.mosaic is True and s.compare.folds == 0
    assert s.clean.piece_lines == 500.0 and s.match == MatchOptions()
    assert read_settings(tmp_path, path) == s
    assert read_settings(tmp_path / "elsewhere") == Settings() and Settings().compare.folds == 4
    for text, message in (("[orthophoto]\n", "run.toml: unknown table [orthophoto] (expected one of clean, compare, "
                                              "match, rectify)"),
                          ("[compare]\nfolds = 1\n", "[compare.folds]: expected 0 (none) or 2 or more, found 1"),
                          ("[compare]\nfold = 3\n", "unknown key 'fold'"),
                          ("[clean]\npiece_lines = 0\n", "run.toml [clean.piece_lines]: expected a number > 0 (line)"),
                          ('[rectify]\nresampling = "lanczos"\n', "lanczos")):
        path.write_text(text, encoding="utf-8")
        with pytest.raises(ScangeoError, match=re.escape(message)):
            read_settings(tmp_path)


def test_variants_toml_is_the_runs_only_while_nobody_edited_it(tmp_path):
    path = tmp_path / "variants.toml"
    assert _variants_are_ours(path, None)  # absent
    path.write_text(VARIANTS_MARKER + "[variants.SE]\n", encoding="utf-8")
    sha = hashlib.sha256(path.read_bytes()).hexdigest()
    assert _variants_are_ours(path, None)  # ours, from a run that stopped before its record
    assert _variants_are_ours(path, {"summary": {"variants_sha256": sha}})
    path.write_text(VARIANTS_MARKER + "[variants.SE]\nsnooping = false\n", encoding="utf-8")
    assert not _variants_are_ours(path, {"summary": {"variants_sha256": sha}})  # edited since
    path.write_text("[variants.SE]\n", encoding="utf-8")
    assert not _variants_are_ours(path, None)  # the user's own
