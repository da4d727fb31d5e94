"""The one memory of file reads: the stamp rule, bounded caches keyed by stamps, content hashes, and the
caches of the layers that use it (projects, orientations, trajectories)."""
from __future__ import annotations

import hashlib
import os

import numpy as np
import pytest

from scangeo import filecache
from scangeo.atomic import write_text
from scangeo.filecache import SMALL_FILE, FileCache, content_hash, content_stamp, stamp


def _counting(cache: FileCache, path):
    reads: list[str] = []

    def read():
        reads.append(path.read_text())
        return reads[-1]

    return reads, lambda: cache.get(str(path), [path], read)


def test_a_small_file_rewritten_in_place_with_the_same_size_is_read_again(tmp_path):
    path = tmp_path / "project.toml"
    path.write_text("a = 1\n")
    cache: FileCache[str] = FileCache("test", 4)
    reads, get = _counting(cache, path)
    assert get() == "a = 1\n" and get() == "a = 1\n"
    assert len(reads) == 1
    st = path.stat()
    with path.open("r+") as f:  # in place: same inode, same size
        f.write("a = 2\n")
    os.utime(path, ns=(st.st_atime_ns, st.st_mtime_ns))  # and the same modification time
    assert path.stat().st_ino == st.st_ino and path.stat().st_size == st.st_size
    assert get() == "a = 2\n"        # the digest of a small file tells
    assert len(reads) == 2 and get() == "a = 2\n" and len(reads) == 2


def test_a_large_file_is_stamped_by_size_time_and_inode(tmp_path):
    path = tmp_path / "image.bin"
    path.write_bytes(b"\0" * (SMALL_FILE + 1))
    s0 = stamp(path)
    assert s0 is not None and len(s0) == 4  # no digest of a large file
    st = path.stat()
    os.utime(path, ns=(st.st_atime_ns, st.st_mtime_ns + 10**6))
    assert stamp(path) != s0
    write_text(path, "x" * (SMALL_FILE + 1))  # a new file renamed over it: a new inode, same size
    assert stamp(path)[3] != s0[3]
    assert stamp(tmp_path / "missing") is None


def test_an_atomic_rewrite_invalidates_and_a_missing_file_is_a_stamp_too(tmp_path):
    path = tmp_path / "orientation.json"
    cache: FileCache[str] = FileCache("test", 4)
    reads: list[int] = []

    def read():
        reads.append(1)
        return path.read_text() if path.exists() else "none"

    assert cache.get("k", [path], read) == "none"
    write_text(path, "{}")
    assert cache.get("k", [path], read) == "{}"
    write_text(path, "[]")
    assert cache.get("k", [path], read) == "[]"
    assert cache.get("k", [path], read) == "[]"
    assert len(reads) == 3


def test_the_bound_is_kept_least_recently_used_first(tmp_path):
    cache: FileCache[int] = FileCache("test", 3)
    files = []
    for k in range(5):
        files.append(tmp_path / f"{k}.txt")
        files[-1].write_text(str(k))
    computed: list[int] = []

    def get(k):
        return cache.get(k, [files[k]], lambda: computed.append(k) or int(files[k].read_text()))

    assert [get(k) for k in (0, 1, 2)] == [0, 1, 2]
    assert get(0) == 0                  # 0 is now the most recent
    assert get(3) == 3 and len(cache) == 3
    assert computed == [0, 1, 2, 3]
    get(0)
    get(2)
    assert computed == [0, 1, 2, 3]     # 1 went, the least recently used
    get(1)
    assert computed == [0, 1, 2, 3, 1] and len(cache) == 3
    with pytest.raises(ValueError, match="maxsize"):
        FileCache("bad", 0)


def test_derived_files_are_stamped_after_the_value_names_them(tmp_path):
    index, data = tmp_path / "index.txt", tmp_path / "data.txt"
    index.write_text("data.txt")
    data.write_text("1")
    cache: FileCache[str] = FileCache("test", 2)
    calls: list[int] = []

    def read():
        calls.append(1)
        return (tmp_path / index.read_text()).read_text()

    def get():
        return cache.get("k", [index], read, derived=lambda v: [data])

    assert get() == "1" and get() == "1" and len(calls) == 1
    data.write_text("2")
    assert get() == "2" and len(calls) == 2


def test_content_hash_is_the_sha256_computed_once_per_stamp(tmp_path, monkeypatch):
    root = tmp_path / "project"
    root.mkdir()
    path = root / "ground.csv"
    path.write_text("P1,1,2,3\n")
    assert content_hash(path, root) == hashlib.sha256(path.read_bytes()).hexdigest()
    calls: list[int] = []
    real = filecache._sha256
    monkeypatch.setattr(filecache, "_sha256", lambda p: calls.append(1) or real(p))
    filecache.clear_all()
    assert content_hash(path, root) == hashlib.sha256(path.read_bytes()).hexdigest()
    assert calls == []                            # from results/.content-hashes.json
    path.write_text("P1,1,2,4\n")                 # same size, other content
    assert content_hash(path, root) == hashlib.sha256(b"P1,1,2,4\n").hexdigest()
    assert content_hash(path, root) == hashlib.sha256(b"P1,1,2,4\n").hexdigest()
    assert calls == [1]
    assert content_stamp(path, root) == ("ground.csv", 9, hashlib.sha256(b"P1,1,2,4\n").hexdigest())
    assert content_stamp(tmp_path / "elsewhere.txt", root) == ("elsewhere.txt", None, None)
    with pytest.raises(FileNotFoundError):
        content_hash(root / "missing.csv", root)


def test_clear_all_forgets_every_cache(tmp_path):
    path = tmp_path / "a.txt"
    path.write_text("a")
    cache: FileCache[str] = FileCache("test", 2)
    cache.get("k", [path], path.read_text)
    assert cache in filecache.caches() and len(cache) == 1
    filecache.clear_all()
    assert len(cache) == 0


def test_projects_and_trajectories_are_read_again_when_their_files_change(tiny_project):
    """The layers' caches on a real project: the same objects and numbers while nothing changes, a new
    read when project.toml or a trajectory changes."""
    from scangeo.adjustment.block import _TRAJECTORIES, strip_data, strips_read_once
    from scangeo.orientation import reuse

    reuse.clear()
    first = reuse.project_of(tiny_project.root)
    assert reuse.project_of(tiny_project.root) is first
    toml = tiny_project.root / "project.toml"
    toml.write_text(toml.read_text() + "\n")
    second = reuse.project_of(tiny_project.root)
    assert second is not first and second.strips == first.strips
    dg = reuse.orientation_of(second, "DG")
    assert reuse.orientation_of(second, "DG") is dg
    with strips_read_once():
        a = strip_data(second, "1")
        assert len(_TRAJECTORIES) == 1
        b = strip_data(second, "1")
        assert np.array_equal(a.spline.coef, b.spline.coef)
        nav = tiny_project.root / "nav" / "1.csv"
        lines = nav.read_text().splitlines(keepends=True)
        write_text(nav, "".join(lines[:-1]))       # one sample fewer
        c = strip_data(second, "1")
        assert c.trajectory.time.size == a.trajectory.time.size - 1
    assert len(_TRAJECTORIES) == 0                   # forgotten when the outermost `with` ends
