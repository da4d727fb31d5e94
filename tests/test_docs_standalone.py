"""The package, its shipped data and docs/ stand alone: nothing points at the development folder."""
from __future__ import annotations

from pathlib import Path

import scangeo

ROOT = Path(scangeo.__file__).resolve().parents[1]


def test_nothing_points_at_the_shared_folder():
    files = [ROOT / "README.md", *(ROOT / "docs").rglob("*.md"),
             *(p for p in (ROOT / "scangeo").rglob("*") if p.suffix in (".py", ".toml", ".md", ".txt"))]
    hits = [f"{p.relative_to(ROOT)}:{i + 1}" for p in files
            for i, line in enumerate(p.read_text(encoding="utf-8").splitlines())
            if "shared/" in line or "DESIGN.md" in line or "DESIGN section" in line]
    assert hits == []


def test_readme_keeps_its_two_set_up_commands_and_the_own_data_walk_through():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    assert "    bash .ci/install && scangeo demo\n" in text
    assert "    bash .ci/install && python3 -m pytest -q\n" in text
    assert text.count("bash .ci/install") == 2
    walk = text[text.index("## From your own data"):text.index("## Documentation")]
    for name in ("project.toml", "ground.csv", "points.csv", "scangeo info", "scangeo compare", "scangeo rectify"):
        assert name in walk
    for example in ("data/example/project.toml", "data/example/variants.toml"):
        assert example in walk and (ROOT / example).is_file()


def test_history_stays_in_the_commit_messages():
    """No code, test or page says which issue asked for it ("issue" and a number): each says what it does."""
    import re

    mention = re.compile(r"\bissues? #?\d", re.IGNORECASE)
    files = [ROOT / "README.md", *(p for folder in ("scangeo", "docs", "tests") for p in (ROOT / folder).rglob("*")
                                   if p.suffix in (".py", ".md", ".toml", ".txt"))]
    hits = [f"{p.relative_to(ROOT)}:{i + 1}" for p in files
            for i, line in enumerate(p.read_text(encoding="utf-8").splitlines()) if mention.search(line)]
    assert hits == []
