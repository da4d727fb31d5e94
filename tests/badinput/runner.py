"""Run one bad-input case of a command in-process and check what a user would see."""
from __future__ import annotations

import logging
from pathlib import Path

from tests.badinput.defects import Case
from tests.session_projects import copy_project


def final_files(root: Path) -> set[str]:
    """Files under ``root`` by relative path, hidden ones (temporary names, the lock) left out."""
    return {str(p.relative_to(root)) for p in root.rglob("*")
            if p.is_file() and not any(part.startswith(".") for part in p.relative_to(root).parts)}


def run_bad(argv: list[str], bad: Case, source: Path, tmp_path: Path, capsys, setup=None, kept: str | None = None
            ) -> str:
    """Copy ``source``, apply the defect, run ``scangeo ARGV`` and check the failure; returns stderr.

    ``setup(root)`` prepares the copy before the defect (e.g. a variants file the command needs).
    ``kept``: a folder (relative) where new files may stay: ``scangeo run``'s manifest, which records the
    failed stage, and the complete outputs of the stages before it.
    """
    from scangeo.cli import main

    root = copy_project(source, tmp_path / "p")
    if setup is not None:
        setup(root)
    bad.defect(root)
    before = final_files(root)
    args = [a.replace("{p}", str(root)) for a in [*argv, *bad.args]]
    logging.getLogger().handlers.clear()  # main() configures logging for each run
    code = main(args)
    err = capsys.readouterr().err
    assert code != 0, f"exit code 0 for {bad.id}; stderr:\n{err}"
    assert "Traceback" not in err
    message = [line for line in err.splitlines() if ": error: " in line]
    assert message, f"no error message in:\n{err}"
    for text in bad.expect:
        assert text in message[-1], f"{text!r} not named in: {message[-1]}"
    new = {f for f in final_files(root) - before if kept is None or not f.startswith(kept)}
    assert not new and before <= final_files(root), f"new files: {sorted(new)}"
    return message[-1]
