"""``scangeo simulate`` and ``scangeo info`` on its output."""
from __future__ import annotations

import importlib

from scangeo.cli import COMMANDS, main

#: Commands the docs and the README promise: removing one fails here (it does not skip).
DOCUMENTED = ("simulate", "match", "adjust", "compare", "report", "rectify", "info", "locate", "lidar", "run", "demo")


def test_every_command_is_registered_and_imports():
    assert set(DOCUMENTED) <= set(COMMANDS)
    for name in COMMANDS:
        importlib.import_module(f"scangeo.cli.{name}")  # a missing module is an error, not a skip


def test_simulate_command(tmp_path, capsys):
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
    assert main(["info", str(out)]) == 0
    info = capsys.readouterr().out
    assert "01" in info and "02" in info
