"""Outputs that are whole or absent: write under a temporary name, then rename; one writer per project.

* :func:`atomic_path` yields a temporary path next to the final one (same folder, so the rename is
  atomic on every POSIX file system); on success it is renamed over the final name, on any error it
  is removed, so nothing partial ever sits under a final name (a kill leaves at most a hidden
  ``.NAME.PID.tmp`` that the next successful run does not read).
* :func:`atomic_directory` does the same for a whole folder (an existing one is moved aside, then
  removed), :func:`atomic_files` for writers that add sidecar files (ENVI's ``.hdr``, GDAL's
  ``.aux.xml``): they write into a hidden staging folder whose files are moved beside the final name,
  the named file last.
* :func:`commit` is the one rename: a finished temporary file over its final name, for writers that
  must choose their own temporary names (resumable partials that a later run cleans up).
* :class:`OutputLock` takes ``PROJECT/.scangeo.lock`` with ``flock`` for the duration of a command that
  writes into the project; a second run is refused with :class:`~scangeo.errors.OutputLockedError`
  naming the holder. The kernel drops the lock when its process dies (even by SIGKILL), so a killed
  run never blocks the next one.
"""
from __future__ import annotations

import csv
import os
import shutil
import time
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path

from scangeo.errors import OutputLockedError

LOCK_NAME = ".scangeo.lock"


def temporary_name(path: Path) -> Path:
    """The hidden temporary name :func:`atomic_path` writes ``path`` under (keeps the suffix for GDAL)."""
    return path.with_name(f".{path.stem}.{os.getpid()}.tmp{path.suffix}")


def commit(tmp, path) -> Path:
    """Rename the finished file (or folder) ``tmp`` over ``path`` (same folder: atomic); returns ``path``."""
    os.replace(tmp, path)
    return Path(path)


@contextmanager
def atomic_path(path) -> Iterator[Path]:
    """Yield a temporary path to write; rename it to ``path`` when the block ends without error."""
    path = Path(path)
    tmp = temporary_name(path)
    try:
        yield tmp
        commit(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


@contextmanager
def atomic_directory(path) -> Iterator[Path]:
    """Yield a new empty hidden folder beside ``path``; it becomes ``path`` when the block ends without error.

    An existing ``path`` is replaced: moved aside under a hidden name, the new folder renamed into
    place, the old one removed. On any error the new folder is removed and ``path`` stays as it was.
    The hidden names carry no process id, so the next run removes what a killed one left (one writer
    per folder: :class:`OutputLock`).
    """
    path = Path(path)
    tmp = path.with_name(f".{path.name}.tmp")
    shutil.rmtree(tmp, ignore_errors=True)
    tmp.mkdir(parents=True)
    try:
        yield tmp
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    if path.exists():
        old = path.with_name(f".{path.name}.old")
        shutil.rmtree(old, ignore_errors=True)
        commit(path, old)
        commit(tmp, path)
        shutil.rmtree(old, ignore_errors=True)
    else:
        commit(tmp, path)


@contextmanager
def atomic_files(path) -> Iterator[Path]:
    """Yield ``STAGING/NAME`` for a writer that adds sidecar files beside ``path`` (ENVI's ``.hdr``).

    ``STAGING`` is a hidden folder beside ``path``. When the block ends without error every file
    written there is renamed into ``path``'s folder, the sidecars first and ``path`` itself last (so
    the named file appears only complete, with its sidecars); on any error the folder is removed, and
    one a killed run left is removed by the next.
    """
    path = Path(path)
    staging = path.with_name(f".{path.name}.staging")
    shutil.rmtree(staging, ignore_errors=True)
    staging.mkdir(parents=True)
    try:
        yield staging / path.name
        written = sorted(staging.iterdir(), key=lambda p: p.name == path.name)
        for item in written:
            commit(item, path.with_name(item.name))
    finally:
        shutil.rmtree(staging, ignore_errors=True)


def write_bytes(path, data: bytes) -> Path:
    """Write a binary file atomically; returns ``path``."""
    path = Path(path)
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
    return path


def write_text(path, text: str) -> Path:
    """Write a UTF-8 text file atomically; returns ``path``."""
    path = Path(path)
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return path


def write_csv(path, header: list[str], rows: Iterable) -> Path:
    """Write a CSV file (header, then rows) atomically; returns ``path``."""
    path = Path(path)
    with atomic_path(path) as tmp, open(tmp, "w", newline="", encoding="utf-8") as f:
        writer = csv.writer(f)
        writer.writerow(header)
        for row in rows:
            writer.writerow(list(row))
    return path


class OutputLock:
    """``with OutputLock(folder, "scangeo adjust"):`` -- the folder is written by this run only.

    Raises OutputLockedError when another process holds the lock (non-blocking: it never waits).
    """

    def __init__(self, folder, command: str = "scangeo") -> None:
        self.path = Path(folder) / LOCK_NAME
        self.command = command
        self._fd: int | None = None

    def __enter__(self) -> OutputLock:
        import fcntl

        if not self.path.parent.is_dir():
            return self  # nothing to protect yet (the command reports the missing folder itself)
        while True:
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                holder = os.read(fd, 400).decode("utf-8", "replace").strip() or "another process"
                os.close(fd)
                raise OutputLockedError(
                    f"{self.path.parent}: another scangeo run is writing this project ({holder}; lock file "
                    f"{self.path}); wait for it to finish"
                ) from None
            try:  # the file may have been unlinked by the previous holder between our open and flock
                same = os.stat(self.path).st_ino == os.fstat(fd).st_ino
            except FileNotFoundError:
                same = False
            if same:
                break
            os.close(fd)
        os.ftruncate(fd, 0)
        os.write(fd, f"{self.command}, pid {os.getpid()}, since {time.strftime('%Y-%m-%d %H:%M:%S')}".encode())
        self._fd = fd
        return self

    def __exit__(self, *exc) -> None:
        if self._fd is not None:
            self.path.unlink(missing_ok=True)  # while still holding the lock: see __enter__
            os.close(self._fd)
            self._fd = None
