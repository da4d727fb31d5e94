"""Untrusted text in outputs: point and strip ids with markup and quotes are escaped in the
HTML report and stored as data, unchanged, in the GeoPackage."""
from __future__ import annotations

import csv
import sqlite3

from tests.session_projects import TWO_VARIANTS, copy_project

POINT = '<script>alert("E001")</script>'  # a control point: named in the report's tables
CHECK = '<script>alert("K001")</script>'  # a check point: a residual vector in the GeoPackage
TIE = "T'\"&amp;"
STRIP = '<i>"02\'&'


def _rename(path, column: str, old: str, new: str) -> None:
    with open(path, newline="", encoding="utf-8") as f:
        rows = list(csv.reader(f))
    k = rows[0].index(column)
    for r in rows[1:]:
        if r[k] == old:
            r[k] = new
    with open(path, "w", newline="", encoding="utf-8") as f:
        csv.writer(f).writerows(rows)


def test_ids_with_markup_are_escaped_in_html_and_data_in_geopackage(small_block, tmp_path):
    from scangeo.cli import main

    root = copy_project(small_block, tmp_path / "p")
    tie = next(r.split(",")[0] for r in (root / "points.csv").read_text().splitlines() if r.startswith("T"))
    for name in ("points.csv", "ground.csv"):
        _rename(root / name, "point", "E001", POINT)
        _rename(root / name, "point", "K001", CHECK)
    _rename(root / "points.csv", "point", tie, TIE)
    _rename(root / "points.csv", "strip", "02", STRIP)
    toml = (root / "project.toml").read_text()
    (root / "project.toml").write_text(toml.replace('id = "02"', "id = '" + STRIP.replace("'", "") + "'")
                                       .replace("id = '<i>\"02&'", 'id = "<i>\\"02\'&"'))
    (root / "variants.toml").write_text(TWO_VARIANTS)
    assert main(["compare", str(root), "--only", "SE", "--no-progress"]) == 0
    html = (root / "results" / "report.html").read_text(encoding="utf-8")
    for raw, escaped in ((POINT, "&lt;script&gt;alert(&quot;E001&quot;)&lt;/script&gt;"),
                         (STRIP, "&lt;i&gt;&quot;02&#x27;&amp;")):
        assert raw not in html
        assert escaped in html, f"{escaped} not in the report"
    assert "<script>alert" not in html and '<i>"02' not in html
    with sqlite3.connect(root / "results" / "residuals.gpkg") as db:
        tables = [r[0] for r in db.execute("SELECT table_name FROM gpkg_contents")]
        found = set()
        for t in tables:
            cols = [c[1] for c in db.execute(f'PRAGMA table_info("{t}")')]
            for c in cols:
                found |= {v for (v,) in db.execute(f'SELECT DISTINCT "{c}" FROM "{t}"') if isinstance(v, str)}
    assert CHECK in found and STRIP in found
