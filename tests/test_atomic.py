"""scangeo.atomic: outputs appear whole or not at all; and no module renames files by itself."""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

import scangeo
from scangeo.atomic import atomic_directory, atomic_files, atomic_path, write_text

PACKAGE = Path(scangeo.__file__).parent


class Boom(Exception):
    pass


def test_atomic_path_leaves_the_old_file_on_error_and_no_temporary(tmp_path):
    target = write_text(tmp_path / "a.txt", "old")
    with pytest.raises(Boom), atomic_path(target) as tmp:
        tmp.write_text("half")
        raise Boom
    assert target.read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.txt"]


def test_atomic_directory_replaces_a_folder_whole(tmp_path):
    out = tmp_path / "results"
    with atomic_directory(out) as d:
        (d / "one.txt").write_text("1")
        assert not out.exists()  # nothing under the final name while writing
    assert sorted(p.name for p in out.iterdir()) == ["one.txt"]
    with atomic_directory(out) as d:  # an existing folder is replaced, not merged
        (d / "two.txt").write_text("2")
    assert sorted(p.name for p in out.iterdir()) == ["two.txt"]
    with pytest.raises(Boom), atomic_directory(out) as d:
        (d / "three.txt").write_text("3")
        raise Boom
    assert sorted(p.name for p in out.iterdir()) == ["two.txt"]  # untouched by the failed run
    assert sorted(p.name for p in tmp_path.iterdir()) == ["results"]  # no temporary folder left


def test_atomic_files_moves_sidecars_with_their_file(tmp_path):
    target = tmp_path / "img.bsq"
    with atomic_files(target) as staged:
        staged.write_bytes(b"data")
        staged.with_suffix(".hdr").write_text("ENVI")
        assert staged.parent != tmp_path and not target.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["img.bsq", "img.hdr"]
    assert target.read_bytes() == b"data"
    with pytest.raises(Boom), atomic_files(tmp_path / "other.bsq") as staged:
        staged.write_bytes(b"half")
        raise Boom
    assert sorted(p.name for p in tmp_path.iterdir()) == ["img.bsq", "img.hdr"]


def _renames(tree: ast.AST) -> list[tuple[int, str]]:
    """Calls that rename files: os.replace/rename/renames, shutil.move, and Path.rename/replace (one
    positional argument, no keywords: str.replace takes two, dataclasses/options .replace keywords)."""
    found = []
    for node in ast.walk(tree):
        if not (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)):
            continue
        name, owner = node.func.attr, node.func.value
        module = owner.id if isinstance(owner, ast.Name) else None
        if (module, name) in {("os", "replace"), ("os", "rename"), ("os", "renames"), ("shutil", "move")}:
            found.append((node.lineno, f"{module}.{name}"))
        elif name in ("rename", "replace") and len(node.args) == 1 and not node.keywords and module != "os":
            found.append((node.lineno, f".{name}()"))
    return found


def test_the_scan_finds_every_kind_of_rename():
    code = ("import os, shutil\nos.replace(a, b)\nos.rename(a, b)\nshutil.move(a, b)\np.rename(q)\n"
            "p.replace(q)\ns.replace('a', 'b')\ndataclasses.replace(x, y=1)\nopts.replace(resolution=2)\n")
    assert [n for n, _ in _renames(ast.parse(code))] == [2, 3, 4, 5, 6]


def test_no_module_but_atomic_renames_files():
    offenders = [
        f"{path.relative_to(PACKAGE.parent)}:{line} {what}"
        for path in sorted(PACKAGE.rglob("*.py"))
        if path.relative_to(PACKAGE).as_posix() != "atomic.py"
        for line, what in _renames(ast.parse(path.read_text(encoding="utf-8")))
    ]
    assert not offenders, "write through scangeo.atomic instead of renaming by hand:\n" + "\n".join(offenders)
