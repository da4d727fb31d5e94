"""``scangeo simulate`` and ``scangeo info`` on its output."""
from __future__ import annotations

import importlib

import pytest

from scangeo.cli import COMMANDS, main


def _cli_ready():
    for name in COMMANDS:
        try:
            importlib.import_module(f"scangeo.cli.{name}")
        except ModuleNotFoundError:
            pytest.skip(f"command module scangeo.cli.{name} is not there yet")


def test_simulate_command(tmp_path, capsys):
    _cli_ready()
    out = tmp_path / "block"
    code = main(["simulate", str(out), "--preset", "small", "--seed", "3", "--no-images",
                 "--set", "flight.lines=150", "--set", "points.blunders=2"])
    assert code == 0
    text = capsys.readouterr().out
    assert "2 blunders" in text and "EPSG:32633" in text
    assert (out / "project.toml").exists() and not (out / "images" / "01.tif").exists()
    # refuses to overwrite, names the folder
    assert main(["simulate", str(out), "--preset", "small", "--no-images"]) == 1
    assert str(out) in capsys.readouterr().err
    # an unknown key is named
    assert main(["simulate", str(tmp_path / "x"), "--set", "flight.lnes=3"]) == 1
    assert "lnes" in capsys.readouterr().err
    if "info" in COMMANDS:
        assert main(["info", str(out)]) == 0
        info = capsys.readouterr().out
        assert "01" in info and "02" in info
