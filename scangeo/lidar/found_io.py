"""What the patch search found in every strip, written to one ``.npz`` file and read back.

The ``patches`` stage of ``scangeo run`` searches the strips once (the costly part: every return is
read twice) and writes :class:`~scangeo.lidar.search.StripFound` of every strip to
``results/patches/found.npz``; the stages after it set up their adjustments on what it read back,
without reading a return. Arrays are stored as they are (no pickling): a field ``F`` of strip ``S``
under the name ``S/F`` (a nested dataclass's ``S/F/G``), scalars as 0-d arrays, ``None`` as absence;
the strip ids in order under ``strips``.
"""
from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import numpy as np

from scangeo.atomic import atomic_path
from scangeo.errors import InputFileError
from scangeo.lidar.patches import StripPatches
from scangeo.lidar.planes import Planes
from scangeo.lidar.rowbuffer import Candidates
from scangeo.lidar.search import StripFound

#: The dataclass of each nested field of :class:`StripFound`.
_NESTED: dict[str, type] = {"patches": StripPatches, "cells": StripPatches, "given": Planes,
                            "candidates": Candidates, "planes": Planes}
#: Format version of the file (a file of another version is searched again).
VERSION = 1


def _flatten(prefix: str, obj: Any, out: dict[str, np.ndarray]) -> None:
    for f in dataclasses.fields(obj):
        value = getattr(obj, f.name)
        if value is None:
            continue
        name = f"{prefix}/{f.name}"
        if dataclasses.is_dataclass(value):
            _flatten(name, value, out)
        else:
            out[name] = np.asarray(value)


def _build(cls: type, prefix: str, data: dict[str, np.ndarray]) -> Any:
    values = {}
    for f in dataclasses.fields(cls):
        name = f"{prefix}/{f.name}"
        if f.name in _NESTED and any(k.startswith(name + "/") for k in data):
            values[f.name] = _build(_NESTED[f.name], name, data)
        elif name in data:
            a = data[name]
            values[f.name] = a.item() if a.ndim == 0 else (tuple(a.tolist()) if f.name == "bounds" else a)
        else:
            values[f.name] = None
    return cls(**values)


def write_found(path: Path, found: dict[str, StripFound]) -> Path:
    """Write every strip's :class:`StripFound` to ``path`` (atomically)."""
    arrays: dict[str, np.ndarray] = {"version": np.asarray(VERSION), "strips": np.asarray(list(found), dtype=str)}
    for sid, f in found.items():
        _flatten(sid, f, arrays)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp, open(tmp, "wb") as fh:
        np.savez(fh, **arrays)  # type: ignore[arg-type]
    return path


def read_found(path: Path) -> dict[str, StripFound]:
    """The strips' :class:`StripFound` written by :func:`write_found`, in their order."""
    try:
        with np.load(path, allow_pickle=False) as npz:
            data = {k: npz[k] for k in npz.files}
    except (OSError, ValueError) as exc:
        raise InputFileError(f"{path}: cannot read the patches found ({exc}); run the patches stage again") from exc
    if int(data.get("version", np.asarray(-1))) != VERSION:
        raise InputFileError(f"{path}: patches of another format version; run the patches stage again")
    return {str(sid): _build(StripFound, str(sid), data) for sid in data["strips"]}


__all__ = ["VERSION", "read_found", "write_found"]
