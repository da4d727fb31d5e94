"""Progress reporting: library code calls a callback, the CLI turns it into a bar.

A progress callback is ``callback(done, total, message)``; ``total`` may be 0 when unknown.
"""
from __future__ import annotations

import sys
import time
from collections.abc import Callable
from typing import Protocol


class ProgressCallback(Protocol):
    def __call__(self, done: float, total: float, message: str = "") -> None: ...


def no_progress(done: float, total: float, message: str = "") -> None:
    """A callback that ignores everything (the library default)."""


class TextProgress:
    """A simple progress bar on stderr, redrawn at most 10 times per second."""

    def __init__(self, stream=None, width: int = 30, enabled: bool = True) -> None:
        self.stream = stream if stream is not None else sys.stderr
        self.width = width
        self.enabled = enabled
        self._last = 0.0
        self._message = ""

    def __call__(self, done: float, total: float, message: str = "") -> None:
        if not self.enabled:
            return
        now = time.monotonic()
        finished = total > 0 and done >= total
        if message != self._message or finished or now - self._last > 0.1:
            self._last = now
            if total > 0:
                frac = min(max(done / total, 0.0), 1.0)
                filled = int(round(frac * self.width))
                bar = "#" * filled + "-" * (self.width - filled)
                text = f"\r{message[:40]:40s} [{bar}] {100 * frac:5.1f}%"
            else:
                text = f"\r{message[:40]:40s} {done:g}"
            if message != self._message and self._message:
                self.stream.write("\n")
            self._message = message
            self.stream.write(text)
            if finished:
                self.stream.write("\n")
                self._message = ""
            self.stream.flush()


def scaled(callback: Callable[..., None], start: float, stop: float, total: float = 1.0):
    """A callback mapping a sub-task's [0, 1] progress into [start, stop] of ``total``."""

    def inner(done: float, sub_total: float, message: str = "") -> None:
        frac = done / sub_total if sub_total else 0.0
        callback(start + (stop - start) * frac, total, message)

    return inner
