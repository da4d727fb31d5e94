"""Errors fit Python's habits: each class is also the built-in that fits (as in rasterio)."""
from __future__ import annotations

import re
from pathlib import Path

import pytest

import scangeo
from scangeo import errors
from scangeo.adjustment.variants import find_variant
from scangeo.io.project import Project
from scangeo.rectify.geotiff import GeoTiffProfile
from scangeo.rectify.options import RectifyOptions
from scangeo.simulate.config import load_preset


@pytest.mark.parametrize("cls, builtins", [
    (errors.InputFileError, (OSError,)),
    (errors.MissingFileError, (FileNotFoundError, OSError)),
    (errors.ProjectFileError, (ValueError, OSError)),
    (errors.TrajectoryError, (ValueError, OSError)),
    (errors.OrientationFileError, (ValueError, OSError)),
    (errors.CRSError, (ValueError,)),
    (errors.DTMError, (ValueError, OSError)),
    (errors.SensorError, (ValueError,)),
    (errors.OptionsError, (ValueError,)),
    (errors.RectifyOptionsError, (ValueError,)),
    (errors.GeometryError, (ValueError,)),
    (errors.MissingDependencyError, (ImportError,)),
])
def test_hierarchy(cls, builtins):
    err = cls("some.file [key]: expected x, found y")
    assert isinstance(err, errors.ScangeoError)
    for b in builtins:
        assert isinstance(err, b)
    assert str(err) == "some.file [key]: expected x, found y"  # one argument: OSError does not reformat it


def test_missing_files_are_file_not_found(tmp_path):
    with pytest.raises(FileNotFoundError, match="no such project file"):
        Project.load(tmp_path / "nothing")
    with pytest.raises(FileNotFoundError, match="no such variants file"):
        find_variant(tmp_path, "SE", tmp_path / "variants.toml")
    with pytest.raises(FileNotFoundError, match="preset file not found"):
        load_preset(tmp_path / "mine.toml")


def test_bad_values_are_value_errors():
    with pytest.raises(ValueError, match="resolution"):
        RectifyOptions(resolution=-1.0)
    with pytest.raises(errors.RectifyOptionsError, match="blocksize"):
        GeoTiffProfile(blocksize=100)
    with pytest.raises(errors.RectifyOptionsError, match=r"\[rectify.igm\]: expected true or false, found 'false'"):
        RectifyOptions.from_dict({"igm": "false"}, "r.toml")


def test_the_root_class_is_never_raised():
    package = Path(scangeo.__file__).parent
    bare = [f"{p.relative_to(package)}:{i + 1}" for p in sorted(package.rglob("*.py"))
            for i, line in enumerate(p.read_text(encoding="utf-8").splitlines())
            if re.search(r"raise ScangeoError\b", line)]
    assert bare == []
