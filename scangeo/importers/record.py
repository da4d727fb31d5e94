"""What an import decided, with the figures it decided on: the record written to ``OUT/import.json``.

Every importer keeps one :class:`ImportRecord`. A convention found from the data is a
:class:`Decision` (the topic, what was taken, why, and the figures of the choice and of its
alternatives); something the user must know is a warning (logged, printed by the command, and kept
in the record); anything else worth saying is a note. The record is written into the project last,
inside the same atomic folder as the rest (:func:`scangeo.importers.writer.write_project`).
"""
from __future__ import annotations

import dataclasses
import json
import logging
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Decision:
    """One convention or choice of an import.

    Parameters
    ----------
    topic : what it is about (``"roll"``, ``"altitude"``, ``"time_base"``, ...).
    choice : what was taken, in a few words.
    reason : the sentence saying why.
    figures : the figures it was decided on (numbers in the units their names say).
    alternatives : per alternative, its figures (the same names), when alternatives were weighed.
    """

    topic: str
    choice: str
    reason: str
    figures: dict[str, Any] = field(default_factory=dict)
    alternatives: dict[str, dict[str, Any]] = field(default_factory=dict)

    def as_dict(self) -> dict[str, Any]:
        return {"topic": self.topic, "choice": self.choice, "reason": self.reason, "figures": self.figures,
                "alternatives": self.alternatives}


@dataclass
class ImportRecord:
    """The decisions, warnings and notes of one import, and the sources it read."""

    tool: str
    sources: dict[str, str] = field(default_factory=dict)
    decisions: list[Decision] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    extra: dict[str, Any] = field(default_factory=dict)

    def source(self, role: str, path) -> None:
        """Name a file read (``role``: ``"status"``, ``"cube"``, ``"lcf"``, ...)."""
        self.sources[role] = str(Path(path).resolve())

    def decide(self, topic: str, choice: str, reason: str, figures: dict[str, Any] | None = None,
               alternatives: dict[str, dict[str, Any]] | None = None) -> Decision:
        d = Decision(topic, choice, reason, dict(figures or {}), dict(alternatives or {}))
        self.decisions.append(d)
        return d

    def decision(self, topic: str) -> Decision:
        """The (last) decision about ``topic``."""
        for d in reversed(self.decisions):
            if d.topic == topic:
                return d
        raise KeyError(topic)

    def warn(self, message: str) -> None:
        """A warning: kept in the record and printed by the command (logged at INFO, so that it is said once)."""
        log.info("warning: %s", message)
        self.warnings.append(message)

    def note(self, message: str) -> None:
        self.notes.append(message)

    def as_dict(self) -> dict[str, Any]:
        return {"tool": self.tool, "sources": self.sources,
                "decisions": [d.as_dict() for d in self.decisions],
                "warnings": list(self.warnings), "notes": list(self.notes), **self.extra}

    def to_json(self) -> str:
        return json.dumps(self.as_dict(), indent=1, default=json_default) + "\n"


def json_default(value):
    """numpy values, arrays and paths as JSON."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, Path):
        return str(value)
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return dataclasses.asdict(value)
    raise TypeError(type(value).__name__)


def rounded(value: float, digits: int = 4) -> float:
    """A figure for the record: a float rounded to ``digits`` decimals."""
    return round(float(value), digits)


def ranges(numbers) -> str:
    """``3-7, 12`` of sorted integers."""
    values = [int(v) for v in numbers]
    if not values:
        return ""
    parts, start, prev = [], values[0], values[0]
    for v in [*values[1:], None]:
        if v is not None and v == prev + 1:
            prev = v
            continue
        parts.append(f"{start}-{prev}" if prev > start else f"{start}")
        if v is not None:
            start = prev = v
    return ", ".join(parts)


__all__ = ["Decision", "ImportRecord", "json_default", "ranges", "rounded"]
