"""Writing matched points into the project's own files, and the match report.

``points.csv`` and ``ground.csv`` (docs/formats.md) keep every row whose id does not carry a
matched prefix, byte for byte; the rows of the kinds measured again (ties always, control and check
when a reference was given) are replaced. Both files are written to a temporary name and renamed.
The match report goes beside them: ``match_report.json`` (everything), ``match_cells.csv``
(one row per cell: where the points are) and ``match_points.csv`` (one row per matched point: its
ground position, kind and number of strips; for GIS).
"""
from __future__ import annotations

import csv
import io
import json
from pathlib import Path

from scangeo.atomic import write_csv, write_text
from scangeo.errors import ProjectFileError
from scangeo.textfile import read_text

POINT_COLUMNS = ["point", "strip", "line", "pixel", "sigma_px"]
GROUND_COLUMNS = ["point", "x", "y", "z", "sigma_xy", "sigma_z", "role"]


def _read_raw(path: Path, required: list[str]) -> tuple[list[str], list[list[str]]]:
    if not path.exists():
        return list(required), []
    text = read_text(path, "a CSV file", ProjectFileError)
    try:
        rows = [r for r in csv.reader(io.StringIO(text, newline="")) if r and any(c.strip() for c in r)]
    except csv.Error as exc:
        raise ProjectFileError(f"{path}: not a CSV file ({exc})") from None
    if not rows:
        return list(required), []
    header = [h.strip().lower() for h in rows[0]]
    if "point" not in header:
        raise ProjectFileError(f"{path} line 1: no column 'point' (found {','.join(header)})")
    return header, rows[1:]


def merge_rows(path: Path, required: list[str], replace_prefixes: tuple[str, ...], new_rows: list[dict]) -> int:
    """Rewrite ``path``: rows whose point id starts with one of ``replace_prefixes`` give way to
    ``new_rows`` (dicts by column); other rows stay as they were. Returns the rows removed."""
    header, rows = _read_raw(path, required)
    for c in required:
        if c not in header:
            header.append(c)
    k = header.index("point")
    kept = [r + [""] * (len(header) - len(r)) for r in rows if not r[k].strip().startswith(replace_prefixes)]
    removed = len(rows) - len(kept)
    body = kept + [[str(row.get(c, "")) for c in header] for row in new_rows]
    write_csv(path, header, body)
    return removed


def write_json(path: Path, data: dict) -> None:
    write_text(path, json.dumps(data, indent=1, default=float) + "\n")
