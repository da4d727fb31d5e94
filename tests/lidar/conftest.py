"""Fixtures of the lidar tests: the ``scangeo lidar`` command run in isolation, the leeward sample."""
from __future__ import annotations

import argparse
import contextlib
import io
import json
from pathlib import Path

import pytest

from scangeo.cli import common_options
from scangeo.cli import lidar as lidar_cli

LEEWARD = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "lidar"


def _run(argv: list[str]) -> tuple[int, str]:
    parser = argparse.ArgumentParser(prog="scangeo")
    sub = parser.add_subparsers(dest="command")
    lidar_cli.add_parser(sub, common_options())
    args = parser.parse_args(argv)
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        code = args.func(args)
    return int(code or 0), out.getvalue()


@pytest.fixture
def run_lidar():
    """``run_lidar(["lidar", ...]) -> (exit code, stdout)`` with only the lidar command registered."""
    return _run


@pytest.fixture
def run_lidar_json():
    """``run_lidar_json(["lidar", ...])``: the command with ``--json``, its output parsed."""

    def run(argv: list[str]) -> dict:
        code, text = _run(argv + ["--json"])
        assert code == 0
        return json.loads(text)

    return run


@pytest.fixture
def leeward() -> Path:
    """The folder of the leeward sample (SBET, LAS, config), or skip when absent."""
    for name in ("leeward_sbet.out", "leeward_points.las", "leeward_config.toml"):
        if not (LEEWARD / name).exists():
            pytest.skip(f"shared test data lidar/{name} not available")
    return LEEWARD
