"""The run manifest ``PROJECT/results/run.json``: what a ``scangeo run`` read, did and made.

One JSON object (docs/run.md):

* ``scangeo``: the version; ``project``: the folder; ``started``, ``finished`` (UTC, ISO 8601);
* ``options``: the run's options (``--reference``, ``--from``, ``--until``, ``--match``, the settings);
* ``inputs``: every file a stage read, by its path relative to the project: size and SHA-256;
* ``stages``: per stage its record: ``status`` (``ran``, ``up to date``, ``running``, ``failed``,
  ``not run``), ``fingerprint`` (:mod:`scangeo.pipeline.fingerprints`), the ``files``, ``options`` and
  ``after`` fingerprints it was computed from, ``seconds`` (of the run that made it), ``reason`` (why
  it ran), ``outputs`` (paths relative to the project) and ``summary`` (the stage's figures);
* ``recommended``: the variant the run rectified, why, and its figures.

The manifest is also the run's memory: a stage counts as done when its record says ``ran`` or
``up to date`` with the fingerprint its inputs have now and its outputs exist. A stage's record is
marked ``running`` (written) before it starts and its final record written only after all its
outputs are, each write atomic (:func:`scangeo.atomic.write_text`): a run killed anywhere leaves a
manifest whose completed stages are exactly those whose outputs are complete.
"""
from __future__ import annotations

import json
import logging
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from scangeo.atomic import write_text
from scangeo.version import __version__

log = logging.getLogger(__name__)

MANIFEST = Path("results") / "run.json"
#: Record statuses after which a stage's outputs are complete.
DONE = ("ran", "up to date")


@dataclass
class Manifest:
    """The manifest of a project's runs (module docstring); ``stages`` keeps the records of earlier runs."""

    root: Path
    stages: dict[str, dict[str, Any]] = field(default_factory=dict)
    options: dict[str, Any] = field(default_factory=dict)
    inputs: dict[str, dict] = field(default_factory=dict)
    recommended: dict[str, Any] | None = None
    started: str = ""
    finished: str | None = None

    @property
    def path(self) -> Path:
        return self.root / MANIFEST

    @classmethod
    def load(cls, root: Path) -> Manifest:
        """The project's manifest; a missing or damaged one is an empty one (every stage runs)."""
        path = root / MANIFEST
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
            stages = data["stages"]
            if not isinstance(stages, dict):
                raise ValueError("stages is not an object")
        except FileNotFoundError:
            return cls(root)
        except (OSError, ValueError, KeyError, TypeError) as exc:
            log.warning("%s cannot be read (%s): every stage runs again", path, exc)
            return cls(root)
        return cls(root, {str(k): dict(v) for k, v in stages.items() if isinstance(v, dict)},
                   recommended=data.get("recommended"))

    def completed(self, stage: str) -> dict[str, Any] | None:
        """The record of a stage whose outputs are complete (None: it never finished)."""
        record = self.stages.get(stage)
        return record if record is not None and record.get("status") in DONE else None

    def as_dict(self) -> dict[str, Any]:
        return {"scangeo": __version__, "project": str(self.root.resolve()), "started": self.started,
                "finished": self.finished, "options": self.options, "inputs": self.inputs,
                "stages": self.stages, "recommended": self.recommended}

    def save(self) -> Path:
        """Write the manifest atomically."""
        self.path.parent.mkdir(parents=True, exist_ok=True)
        return write_text(self.path, json.dumps(self.as_dict(), indent=2, default=str) + "\n")


__all__ = ["DONE", "MANIFEST", "Manifest"]
