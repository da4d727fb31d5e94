"""Line <-> time: ``t0 + line / line_rate`` or a per-line time table (linear between entries).

A line's time is the time of its centre pixel (docs/conventions.md). Lines are 0-based, fractional
lines are allowed; times outside the table are extrapolated with the first/last line interval.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from scangeo.errors import ProjectFileError
from scangeo.textfile import read_text


@dataclass(frozen=True)
class LineTiming:
    """Line timing of a strip.

    Parameters
    ----------
    first_line_time : time of line 0, seconds.
    line_rate : lines per second (ignored when ``table`` is given).
    table : optional (n_lines,) strictly increasing times of lines 0..n-1.
    """

    first_line_time: float
    line_rate: float
    table: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.table is None and not self.line_rate > 0:
            raise ProjectFileError(f"line rate must be positive, got {self.line_rate}")
        if self.table is not None and (len(self.table) < 2 or np.any(np.diff(self.table) <= 0)):
            raise ProjectFileError("a line time table needs at least 2 strictly increasing times")

    @classmethod
    def from_table_file(cls, path) -> LineTiming:
        """Read ``line,time`` (or a single ``time`` column) CSV with a header line."""
        path = Path(path)
        lines = read_text(path, "a line time table (CSV)", ProjectFileError).splitlines()
        try:
            data = np.loadtxt(lines, delimiter=",", skiprows=1, ndmin=2)
        except (OSError, ValueError) as exc:
            raise ProjectFileError(f"{path}: cannot read the line time table ({exc})") from exc
        if data.shape[0] < 2 or not np.isfinite(data).all():
            raise ProjectFileError(f"{path}: expected a header line and 2 or more lines of finite times")
        times = data[:, -1]
        if data.shape[1] > 1 and not np.array_equal(data[:, 0], np.arange(len(times))):
            raise ProjectFileError(f"{path}: lines must be 0, 1, 2, ... in order")
        steps = np.flatnonzero(np.diff(times) <= 0)
        if steps.size:
            raise ProjectFileError(
                f"{path} line {steps[0] + 3}: time {times[steps[0] + 1]} is not after the previous "
                f"{times[steps[0]]} (times must increase)"
            )
        return cls(float(times[0]), float(1.0 / np.median(np.diff(times))), times)

    @property
    def mean_rate(self) -> float:
        return self.line_rate if self.table is None else float((len(self.table) - 1) / (self.table[-1] - self.table[0]))

    def time_of_line(self, line: np.ndarray) -> np.ndarray:
        """Time (s) of (fractional) lines."""
        line = np.asarray(line, dtype=float)
        if self.table is None:
            return self.first_line_time + line / self.line_rate
        tab = self.table
        n = len(tab)
        inside = np.interp(line, np.arange(n), tab)
        before = tab[0] + line * (tab[1] - tab[0])
        after = tab[-1] + (line - (n - 1)) * (tab[-1] - tab[-2])
        return np.where(line < 0, before, np.where(line > n - 1, after, inside))

    def line_of_time(self, t: np.ndarray) -> np.ndarray:
        """(Fractional) line of times t (s)."""
        t = np.asarray(t, dtype=float)
        if self.table is None:
            return (t - self.first_line_time) * self.line_rate
        tab = self.table
        n = len(tab)
        inside = np.interp(t, tab, np.arange(n, dtype=float))
        before = (t - tab[0]) / (tab[1] - tab[0])
        after = (n - 1) + (t - tab[-1]) / (tab[-1] - tab[-2])
        return np.where(t < tab[0], before, np.where(t > tab[-1], after, inside))

    def as_table(self, n_lines: int) -> np.ndarray:
        """Times of lines 0..n_lines-1."""
        return self.time_of_line(np.arange(n_lines))
