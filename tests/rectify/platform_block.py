"""A platform of two whiskbrooms for the rectification tests, made from the session's ``small_block``.

Sensor ``a`` is the block's scanner (100 pixels, 25 lines/s, its 11-band uint8 images); sensor ``b`` flies
beside it on the same flight lines ``L01``, ``L02`` with half the pixels over the same scan angle and half
the line rate (50 pixels, 12.5 lines/s: a ground pixel twice as large both ways), 4 bands of uint16 and its
boresight 0.05 deg off in roll. Pixel ``k`` of ``b`` looks where pixel ``2 k + 0.5`` of ``a`` looks and line
``m`` is taken when ``a``'s line ``2 m`` is, so ``b``'s measurements are ``a``'s tie and check
measurements at those positions (``b`` has no control of its own): the flight lines' corrections and the
tie points carry ``a``'s control over to it.
"""
from __future__ import annotations

import re
from pathlib import Path

from tests.session_projects import as_platform, copy_project, write_strip_image

#: a's boresight calibrated beside b's, position corrections per flight line (no attitude polynomial: it
#: and a boresight would be one unknown twice)
VARIANTS = '[variants.SE_B]\nstrategy = "SE"\nattitude_degree = -1\ncalibrate = ["boresight"]\n'
B_BANDS = ("swir1", "swir2", "swir3", "swir4")


def make_platform(small_block: Path, root: Path) -> Path:
    """A copy of ``small_block`` at ``root`` as the platform of the module docstring."""
    copy_project(small_block, root, truth=True)
    as_platform(root)
    text = (root / "project.toml").read_text()
    sensor_a = re.search(r'\[\[sensors\]\]\nid = "a"\n(.*?)\n\n', text, re.S).group(1)
    sensor_b = sensor_a.replace("pixels = 100", "pixels = 50").replace("line_rate_hz = 25.0", "line_rate_hz = 12.5")
    sensor_b = re.sub(r"boresight_deg = \[[^\]]*\]", "boresight_deg = [0.05, 0.0, 0.0]", sensor_b)
    sensor_b = re.sub(r"bands = \[[^\]]*\]", "bands = [" + ", ".join(f'"{b}"' for b in B_BANDS) + "]", sensor_b)
    sensor_b = re.sub(r"wavelengths_nm = \[[^\]]*\]", "wavelengths_nm = [1200, 1400, 1600, 2200]", sensor_b)
    at = text.index("[[flight_lines]]")
    strips = []
    for sid in ("01", "02"):
        body = re.search(rf'\[\[strips\]\]\nid = "{sid}"\n(.*?)(?=\n\n|\Z)', text, re.S).group(1)
        body = body.replace(f"images/{sid}.tif", f"images/b{sid}.tif").replace('sensor = "a"', 'sensor = "b"')
        body = body.replace("lines = 200", "lines = 100")
        strips.append(f'[[strips]]\nid = "b{sid}"\n{body}\n')
        write_strip_image(root / "images" / f"b{sid}.tif", 100, 50, bands=len(B_BANDS), dtype="uint16")
    text = (text[:at] + '[[sensors]]\nid = "b"\n' + sensor_b + "\n\n" + text[at:].rstrip("\n") + "\n\n"
            + "\n".join(strips))
    (root / "project.toml").write_text(text)
    _copy_measurements(root)
    (root / "variants.toml").write_text(VARIANTS)
    return root


def _copy_measurements(root: Path) -> None:
    """b's measurements: a's tie and check measurements at b's line and pixel (module docstring)."""
    roles = dict(line.split(",")[0::6] for line in (root / "ground.csv").read_text().splitlines()[1:])
    rows = (root / "points.csv").read_text().splitlines()
    extra = []
    for row in rows[1:]:
        point, strip, line, pixel, *rest = row.split(",")
        if roles.get(point, "tie") == "control":
            continue
        m, k = float(line) / 2.0, float(pixel) / 2.0 - 0.25
        if not (0.0 <= m <= 99.0 and 0.0 <= k <= 49.0):
            continue
        extra.append(",".join([point, f"b{strip}", f"{m:.4f}", f"{k:.4f}", *rest]))
    (root / "points.csv").write_text("\n".join(rows + extra) + "\n")


__all__ = ["B_BANDS", "VARIANTS", "make_platform"]
