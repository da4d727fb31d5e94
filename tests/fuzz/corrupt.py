"""Random corruptions of a valid file's bytes, drawn by hypothesis."""
from __future__ import annotations

from hypothesis import strategies as st

#: Text a corrupted field may become.
NASTY = ["", "nan", "inf", "-inf", "1e999", "abc", "\x00", '"', ",", ",,", "1,2", "\ufeff", "é", "0x10", "--1",
         "1e-400", "\t", "9" * 40, "[", "]", "=", "[[", "\n"]


@st.composite
def corrupted(draw, original: bytes) -> bytes:
    """``original`` with 1-4 random edits: truncation, deleted/inserted/replaced bytes, swapped or repeated
    lines, a nasty token in place of a field."""
    data = bytearray(original)
    for _ in range(draw(st.integers(1, 4))):
        kind = draw(st.sampled_from(["truncate", "delete", "insert", "replace", "swap", "repeat", "token"]))
        n = len(data)
        if n == 0:
            data = bytearray(draw(st.binary(max_size=64)))
            continue
        i = draw(st.integers(0, n - 1))
        if kind == "truncate":
            del data[i:]
        elif kind == "delete":
            del data[i:i + draw(st.integers(1, 16))]
        elif kind == "insert":
            data[i:i] = draw(st.binary(min_size=1, max_size=16))
        elif kind == "replace":
            data[i] = draw(st.integers(0, 255))
        else:
            lines = bytes(data).split(b"\n")
            a = draw(st.integers(0, len(lines) - 1))
            b = draw(st.integers(0, len(lines) - 1))
            if kind == "swap":
                lines[a], lines[b] = lines[b], lines[a]
            elif kind == "repeat":
                lines.insert(b, lines[a])
            else:
                sep = b"," if b"," in lines[a] else b"="
                fields = lines[a].split(sep)
                k = draw(st.integers(0, len(fields) - 1))
                fields[k] = draw(st.sampled_from(NASTY)).encode("utf-8")
                lines[a] = sep.join(fields)
            data = bytearray(b"\n".join(lines))
    return bytes(data)
