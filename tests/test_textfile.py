"""The one reader of a user's text file: UTF-8 with or without a byte-order mark, other encodings refused."""
from __future__ import annotations

import codecs

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from scangeo.errors import InputFileError, ProjectFileError, TrajectoryError
from scangeo.textfile import read_text

TEXT = "point,x,y,z\nBrücke,1.5,2.5,3.0\r\nE002,4,5,6\n"


@settings(max_examples=60, deadline=None)
@given(st.text(st.characters(blacklist_categories=("Cs",), blacklist_characters="\x00")), st.booleans())
def test_any_utf8_text_reads_back_with_or_without_its_mark(tmp_path_factory, text, mark):
    path = tmp_path_factory.mktemp("t") / "a.txt"
    path.write_bytes((codecs.BOM_UTF8 if mark else b"") + text.encode("utf-8"))
    assert read_text(path, "a file") == text


def test_latin1_is_named_by_file_line_and_column(tmp_path):
    path = tmp_path / "ground.csv"
    path.write_bytes(TEXT.encode("latin-1"))
    with pytest.raises(ProjectFileError) as info:
        read_text(path, "a CSV file", ProjectFileError)
    message = str(info.value)
    assert message.startswith(f"{path} line 2 column 3: byte 0xFC is not UTF-8")
    assert "expected a CSV file saved as UTF-8" in message


@pytest.mark.parametrize("encoding, name", [("utf-16", "UTF-16 text ("), ("utf-16-le", "UTF-16 text without"),
                                            ("utf-16-be", "UTF-16 text without"), ("utf-32", "UTF-32 text ("),
                                            ("utf-32-le", "UTF-32 text without")])
def test_wide_encodings_are_named_with_or_without_their_mark(tmp_path, encoding, name):
    path = tmp_path / "nav.csv"
    path.write_bytes(TEXT.encode(encoding))
    with pytest.raises(TrajectoryError) as info:
        read_text(path, "a trajectory CSV", TrajectoryError)
    assert str(info.value).startswith(f"{path}: {name}")
    assert str(info.value).endswith("(expected a trajectory CSV saved as UTF-8)")


def test_binary_and_unreadable_files(tmp_path):
    path = tmp_path / "project.toml"
    path.write_bytes(bytes(range(256)) * 4)
    with pytest.raises(InputFileError, match="a binary file"):
        read_text(path, "a TOML file")
    with pytest.raises(InputFileError, match="cannot read"):
        read_text(tmp_path / "missing.toml", "a TOML file")
    with pytest.raises(InputFileError, match="cannot read"):
        read_text(tmp_path, "a TOML file")  # a folder
