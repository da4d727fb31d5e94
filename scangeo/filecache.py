"""One memory of file reads: the file-stamp rule, bounded per-run caches keyed by stamps, content hashes.

**The stamp rule** (:func:`stamp`): a file is the same file as when it was read while its resolved
path, size, modification time (ns) and inode are unchanged, and, for a file of at most
:data:`SMALL_FILE` bytes, the BLAKE2b digest of its bytes too. Why:

- one ``stat`` is cheap beside any read the caches save (a DTM, a trajectory, a strip image);
- the inode catches every rewrite through :mod:`scangeo.atomic` (a new file renamed over the old one),
  even when size and time stay;
- the modification time comes from the kernel's file-system clock, which on some systems ticks only
  every few milliseconds: a same-size rewrite in place within one tick would keep size, time and inode.
  The small files that people and scripts edit (``project.toml``, ``variants.toml``, ``ground.csv``,
  ``orientation.json``) are therefore also stamped by their bytes (reading 256 KiB costs ~0.1 ms); the
  large ones (images, LAS, DTMs, trajectories) are written once or replaced whole;
- a content hash (SHA-256) is what a *fingerprint* needs (:func:`content_hash`): it must stay the same
  when a project is copied or moved (new times and inodes) and it is written into the results; it is
  computed once per stamp, in this process and across runs (``results/.content-hashes.json``).

**Caches** (:class:`FileCache`): a named, bounded memory (least recently used entry evicted) of values
computed from files. Each entry is keyed by the caller's key and holds the stamps of every file its
value depends on; an entry whose files' stamps changed is computed again. Every cache is registered:
:func:`clear_all` forgets them all at the start of a run (the stages of a run share them; a worker
process starts with empty ones).
"""
from __future__ import annotations

import hashlib
import json
import os
import threading
from collections import OrderedDict
from collections.abc import Callable, Hashable, Iterable, Sequence
from pathlib import Path
from typing import Generic, TypeVar

from scangeo.atomic import write_text

#: Files up to this size (bytes) are stamped by their bytes too (see the module docstring).
SMALL_FILE = 256 * 1024
#: Beside the results: the content hashes of earlier runs, by path relative to the project, size,
#: modification time and inode (a rerun does not read every strip image again; a copied project,
#: with new times and inodes, is hashed again and gets the same fingerprints).
HASH_CACHE = Path("results") / ".content-hashes.json"
_CHUNK = 1 << 22

Stamp = tuple | None
V = TypeVar("V")


def stamp(path: str | os.PathLike) -> Stamp:
    """The stamp of a file (module docstring): ``(path, size, mtime_ns, inode[, digest])``, None when it
    does not exist or cannot be read."""
    p = Path(path)
    try:
        st = p.stat()
        key: tuple = (str(p.resolve()), st.st_size, st.st_mtime_ns, st.st_ino)
        if st.st_size <= SMALL_FILE and p.is_file():
            key += (hashlib.blake2b(p.read_bytes(), digest_size=16).hexdigest(),)
    except OSError:
        return None
    return key


def stamps(paths: Iterable[str | os.PathLike | None]) -> tuple[Stamp, ...]:
    """The stamps of several files (None entries stay None)."""
    return tuple(None if p is None else stamp(p) for p in paths)


_ALL: list[FileCache] = []


class FileCache(Generic[V]):
    """A bounded memory of values computed from files (module docstring).

    Parameters
    ----------
    name : what it holds, for messages and :func:`caches`.
    maxsize : entries kept at most (the least recently used goes first).
    """

    def __init__(self, name: str, maxsize: int) -> None:
        if maxsize < 1:
            raise ValueError(f"cache {name}: maxsize must be >= 1, not {maxsize}")
        self.name = name
        self.maxsize = maxsize
        self._entries: OrderedDict[Hashable, tuple[tuple[tuple[str, Stamp], ...], V]] = OrderedDict()
        self._lock = threading.Lock()
        self.hits = self.misses = 0
        _ALL.append(self)

    def __len__(self) -> int:
        return len(self._entries)

    def clear(self) -> None:
        with self._lock:
            self._entries.clear()

    def get(self, key: Hashable, files: Sequence[str | os.PathLike | None], compute: Callable[[], V],
            derived: Callable[[V], Iterable[str | os.PathLike | None]] | None = None) -> V:
        """The value under ``key``, computed by ``compute()`` unless kept with unchanged file stamps.

        ``files``: the files the value is read from (stamped before ``compute`` runs, so a file changed
        while it reads is read again next time); ``derived(value)``: files known only from the value
        (e.g. the DTM a project file names), stamped after.
        """
        with self._lock:
            entry = self._entries.get(key)
            if entry is not None and all(stamp(p) == s for p, s in entry[0]):
                self._entries.move_to_end(key)
                self.hits += 1
                return entry[1]
        before = tuple((str(p), stamp(p)) for p in files if p is not None)
        value = compute()
        after = tuple((str(p), stamp(p)) for p in (derived(value) if derived is not None else ()) if p is not None)
        with self._lock:
            self.misses += 1
            self._entries[key] = (before + after, value)
            self._entries.move_to_end(key)
            while len(self._entries) > self.maxsize:
                self._entries.popitem(last=False)
        return value


def caches() -> list[FileCache]:
    """Every cache of this process."""
    return list(_ALL)


def clear_all() -> None:
    """Forget every cache's entries (a run's start: files may have changed since an earlier run)."""
    for cache in _ALL:
        cache.clear()


def _relative(path: Path, root: Path) -> str | None:
    """``path`` relative to the project folder ``root`` (posix), None if it lies outside."""
    try:
        return path.resolve().relative_to(root.resolve()).as_posix()
    except ValueError:
        return None


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with path.open("rb") as f:
        while block := f.read(_CHUNK):
            h.update(block)
    return h.hexdigest()


def _load_hashes(root: Path) -> dict[str, list]:
    try:
        data = json.loads((root / HASH_CACHE).read_text(encoding="utf-8"))
        return data if isinstance(data, dict) else {}
    except (OSError, ValueError):
        return {}  # none yet, unreadable or damaged: hashed again


def _save_hashes(root: Path, table: dict[str, list]) -> None:
    target = root / HASH_CACHE
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        write_text(target, json.dumps(table, sort_keys=True))
    except OSError:  # a read-only project: the table only saves time
        pass


#: SHA-256 of files by stamp (a DTM and project.toml are hashed once a run, not once a strip)
_HASHES: FileCache[str] = FileCache("content hashes", 4096)


def content_hash(path: str | os.PathLike, root: str | os.PathLike | None = None) -> str:
    """SHA-256 (hex) of a file's bytes (read in 4 MiB chunks), computed once per stamp: in this process,
    and with ``root`` (the project) across runs in ``root/results/.content-hashes.json``.
    Raises ``FileNotFoundError`` for a missing file."""
    path = Path(path)
    path.stat()  # a missing file raises here, not inside the cache

    def compute() -> str:
        st = path.stat()
        rel = None if root is None else _relative(path, Path(root))
        if rel is None:  # no project to keep it in
            return _sha256(path)
        assert root is not None
        key = [st.st_size, st.st_mtime_ns, st.st_ino]
        table = _load_hashes(Path(root))
        hit = table.get(rel)
        if isinstance(hit, list) and len(hit) == 4 and hit[:3] == key:
            return str(hit[3])
        digest = _sha256(path)
        table[rel] = [*key, digest]
        _save_hashes(Path(root), table)
        return digest

    return _HASHES.get(str(path.resolve()), [path], compute)


def relative_name(path: str | os.PathLike, root: str | os.PathLike) -> str:
    """``path`` relative to the project folder ``root`` (posix), or its name when it lies outside."""
    return _relative(Path(path), Path(root)) or Path(path).name


def content_stamp(path: str | os.PathLike, root: str | os.PathLike) -> tuple[str, int | None, str | None]:
    """What a fingerprint records of a file: where it lies relative to the project ``root`` (outside it:
    its name, :func:`relative_name`), its size and its SHA-256; ``(name, None, None)`` for a missing or
    unreadable file."""
    p = Path(path)
    where = relative_name(p, root)
    try:
        return where, p.stat().st_size, content_hash(p, root)
    except OSError:
        return where, None, None


__all__ = ["HASH_CACHE", "SMALL_FILE", "FileCache", "caches", "clear_all", "content_hash", "content_stamp",
           "relative_name", "stamp", "stamps"]
