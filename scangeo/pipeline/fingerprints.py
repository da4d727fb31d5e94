"""Fingerprints of a stage's inputs: the files it reads (by content), its options and the stages before it.

A file is stamped by its path relative to the project (outside the project: its name), its size and
the SHA-256 of its bytes (:func:`scangeo.filecache.content_hash`: hashed once and then cached
in ``PROJECT/results/.content-hashes.json`` while size, mtime and inode stay, so a rerun does not
read the strip images again). A stage's fingerprint is the SHA-256 of its name, the scangeo
version, its options, the stamps of its files and the fingerprints of the stages whose results it
reads: equal fingerprints mean equal inputs, so the stage's earlier outputs stand.
"""
from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Any

from scangeo.filecache import content_stamp, relative_name
from scangeo.version import __version__


def file_stamps(paths: list[Path], root: Path) -> dict[str, dict[str, Any]]:
    """Per file (by its name relative to the project): size and SHA-256 (:func:`scangeo.filecache.content_stamp`);
    a missing file is ``None``."""
    out: dict[str, dict[str, Any]] = {}
    for path in paths:
        name, size, sha = content_stamp(path, root)
        out[name] = {"size": size, "sha256": sha}
    return out


def digest(data: Any) -> str:
    """SHA-256 of a JSON-able value (keys sorted; paths and other objects by ``str``), 24 hex digits."""
    text = json.dumps(data, sort_keys=True, default=str)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()[:24]


def stage_fingerprint(stage: str, options: dict, files: dict[str, dict], after: dict[str, str]) -> str:
    """The fingerprint of one stage's inputs (module docstring)."""
    return digest({"stage": stage, "version": __version__, "options": options, "files": files, "after": after})


def changes(old: dict | None, options: dict, files: dict[str, dict], after: dict[str, str]) -> list[str]:
    """What differs from an earlier record's inputs, in words (``ground.csv changed``, ``options``)."""
    if not old:
        return ["no earlier run"]
    out = []
    if old.get("version") != __version__:
        out.append(f"scangeo {old.get('version')} -> {__version__}")
    before = old.get("files", {})
    for name, stamp in files.items():
        if name not in before:
            out.append(f"{name} new")
        elif before[name] != stamp:
            out.append(f"{name} changed")
    out += [f"{name} no longer read" for name in before if name not in files]
    if digest(old.get("options", {})) != digest(options):
        keys = sorted({*old.get("options", {}), *options})
        diff = [k for k in keys if digest(old.get("options", {}).get(k)) != digest(options.get(k))]
        out.append("options changed: " + ", ".join(diff))
    out += [f"stage {name} changed" for name, fp in after.items() if old.get("after", {}).get(name) != fp]
    return out


__all__ = ["changes", "digest", "file_stamps", "relative_name", "stage_fingerprint"]
