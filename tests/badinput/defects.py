"""Single defects applied to a copy of a project folder, and the case type of the bad-input matrix."""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

Defect = Callable[[Path], None]


@dataclass(frozen=True)
class Case:
    """One defect and what the error message must name (the file, and the line or key).

    ``args`` are extra command-line arguments; ``{p}`` in them is replaced by the project folder.
    """

    id: str
    defect: Defect
    expect: tuple[str, ...]
    args: tuple[str, ...] = ()


def case(id: str, defect: Defect, *expect: str, args: tuple[str, ...] = ()):
    """A pytest param of a Case, with the case id as the test id."""
    import pytest

    return pytest.param(Case(id, defect, expect, args), id=id)


# ------------------------------------------------------------------------------- file edits
def replace(name: str, old: str, new: str, count: int = 1) -> Defect:
    """Replace text in a project file (the text must be there)."""

    def apply(root: Path) -> None:
        path = root / name
        text = path.read_text(encoding="utf-8")
        assert old in text, f"{old!r} not in {name}"
        path.write_text(text.replace(old, new, count), encoding="utf-8")

    return apply


def write(name: str, content: str | bytes) -> Defect:
    """Write (or overwrite) a project file."""

    def apply(root: Path) -> None:
        path = root / name
        path.parent.mkdir(parents=True, exist_ok=True)
        if isinstance(content, bytes):
            path.write_bytes(content)
        else:
            path.write_text(content, encoding="utf-8")

    return apply


def remove(name: str) -> Defect:
    def apply(root: Path) -> None:
        (root / name).unlink()

    return apply


def lines(name: str, edit: Callable[[list[str]], list[str]]) -> Defect:
    """Edit a text file as a list of lines (line 1 is index 0)."""

    def apply(root: Path) -> None:
        path = root / name
        path.write_text("\n".join(edit(path.read_text(encoding="utf-8").splitlines())) + "\n", encoding="utf-8")

    return apply


def set_field(line: int, column: int, value: str) -> Callable[[list[str]], list[str]]:
    """Set field ``column`` of file line ``line`` (1-based) of a comma-separated file."""

    def edit(rows: list[str]) -> list[str]:
        fields = rows[line - 1].split(",")
        fields[column] = value
        rows[line - 1] = ",".join(fields)
        return rows

    return edit


def truncate(name: str, keep: int | float) -> Defect:
    """Keep the first ``keep`` bytes (or that fraction) of a file."""

    def apply(root: Path) -> None:
        path = root / name
        data = path.read_bytes()
        n = int(len(data) * keep) if isinstance(keep, float) else keep
        path.write_bytes(data[:n])

    return apply


def patch(name: str, offset: int, data: bytes) -> Defect:
    """Overwrite bytes of a binary file at ``offset`` (a header field)."""

    def apply(root: Path) -> None:
        path = root / name
        raw = bytearray(path.read_bytes())
        raw[offset:offset + len(data)] = data
        path.write_bytes(bytes(raw))

    return apply


def chain(*defects: Defect) -> Defect:
    def apply(root: Path) -> None:
        for d in defects:
            d(root)

    return apply


def random_bytes(name: str, size: int, seed: int = 13) -> Defect:
    return write(name, np.random.default_rng(seed).integers(0, 256, size, dtype=np.uint8).tobytes())


def sbet_of(strip: str) -> Defect:
    """Convert the strip's CSV trajectory into an Applanix SBET ``nav/STRIP.out`` and point project.toml at it."""

    def apply(root: Path) -> None:
        from scangeo.trajectory.readers import SBET_RECORD, read_trajectory_csv

        s = read_trajectory_csv(root / "nav" / f"{strip}.csv")
        rec = np.zeros(len(s), dtype=SBET_RECORD)
        for name, values in (("time", s.time), ("lat", s.lat), ("lon", s.lon), ("alt", s.h), ("roll", s.roll),
                             ("pitch", s.pitch), ("platform_heading", s.heading)):
            rec[name] = values
        rec.tofile(root / "nav" / f"{strip}.out")
        replace("project.toml", f'"nav/{strip}.csv"', f'"nav/{strip}.out"')(root)

    return apply


def sbet_edit(strip: str, edit: Callable[[np.ndarray], None]) -> Defect:
    """Edit the records of the strip's SBET (see ``sbet_of``) in place."""

    def apply(root: Path) -> None:
        from scangeo.trajectory.readers import SBET_RECORD

        path = root / "nav" / f"{strip}.out"
        rec = np.fromfile(path, dtype=SBET_RECORD)
        edit(rec)
        rec.tofile(path)

    return apply


def raster(name: str, width: int, height: int, bands: int = 11, crs: str | None = None, nodata=None,
           value: float | None = None, dtype: str = "uint8", transform=None) -> Defect:
    """Write a raster over a project file (a raw image when crs is None)."""

    def apply(root: Path) -> None:
        import warnings

        import rasterio

        data = np.full((bands, height, width), 100 if value is None else value, dtype=dtype)
        kw = {"crs": crs, "transform": transform} if crs else {}
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)
            with rasterio.open(root / name, "w", driver="GTiff", width=width, height=height, count=bands,
                               dtype=dtype, nodata=nodata, **kw) as dst:
                dst.write(data)

    return apply


def dtm_edit(edit: Callable, drop_crs: bool = False) -> Defect:
    """Rewrite dtm.tif with ``edit(array, transform)`` applied to its heights (and without its CRS)."""

    def apply(root: Path) -> None:
        import rasterio

        path = root / "dtm.tif"
        with rasterio.open(path) as src:
            profile = src.profile
            data = src.read(1)
            transform = src.transform
        edit(data, transform, profile)
        if drop_crs:
            profile.pop("crs", None)
        path.unlink()
        with rasterio.open(path, "w", **profile) as dst:
            dst.write(data, 1)

    return apply
