"""The shared HySpex pair as one platform project: the control/check split of the single lines, per camera.

``tests/benchmarks/real_data.py``'s split (PARGE's used GCPs sorted by line, alternately control and
check; its unused ones left out) for each camera of a platform project, whose GCP ids carry the
sensor's prefix (``vnir-GCP01``), and the check-point rms per strip.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import scipy.io

from tests.importers.reference_fit import alternate_split

#: the pair's status files under the shared data folder, by the sensor id the import gives them
PAIR = {"vnir": "hyspex/20200522_Husky_VNIR_boresight_IFSAR.gcs",
        "swir": "hyspex/20200522_Husky_SWIR_boresight_IFSAR.gcs"}


def gcp_ids(status) -> tuple[list[str], np.ndarray, np.ndarray]:
    """The import's GCP ids of a status file (GCP01...), and the rows of the split's control and check."""
    gcp = scipy.io.readsav(str(status), python_dict=True)["gcparr"]
    width = max(2, len(str(len(gcp))))
    control, check = alternate_split(gcp)
    return [f"GCP{k + 1:0{width}d}" for k in range(len(gcp))], control, check


def split_roles(statuses: dict[str, Path], all_check: tuple[str, ...] = ()) -> dict[str, str]:
    """Roles of the split for every sensor's GCPs (``SENSOR-GCPnn``); the sensors of ``all_check`` have every
    used GCP a check point. PARGE's unused GCPs are ignored."""
    roles = {"*": "ignore"}
    for sensor, status in statuses.items():
        ids, control, check = gcp_ids(status)
        for k in control:
            roles[f"{sensor}-{ids[k]}"] = "check" if sensor in all_check else "control"
        for k in check:
            roles[f"{sensor}-{ids[k]}"] = "check"
    return roles


def split_variants(root: Path, roles: dict[str, str], name: str = "split.toml") -> Path:
    """A copy of the import's variants.toml with the roles as its defaults'."""
    table = ", ".join(f'"{k}" = "{v}"' for k, v in roles.items())
    text = (root / "variants.toml").read_text().replace("[defaults]\n", f"[defaults]\nroles = {{{table}}}\n", 1)
    path = root / name
    path.write_text(text)
    return path


def check_rms(adjusted) -> dict[str, tuple[float, float, float, int]]:
    """Per strip: check-point rms along (lines), across (pixels), both together, and their number."""
    out = {}
    for strip, entry in adjusted.result.rms_per_strip().items():
        c = entry["check"]
        if not c.get("n"):
            continue
        out[strip] = (c["rms_along_lines"], c["rms_across_px"], math.hypot(c["rms_along_lines"], c["rms_across_px"]),
                      c["n"])
    return out


def subset_rms(adjusted, strip: str, points) -> tuple[float, float, float, int]:
    """Check-point rms (along lines, across pixels, both, n) of one strip over the given point ids."""
    c = adjusted.result.checks
    wanted = set(points)
    ok = (c.strip == strip) & (c.status == 0) & np.array([str(p) in wanted for p in c.point], bool)
    along, across = float(np.sqrt(np.mean(c.line[ok] ** 2))), float(np.sqrt(np.mean(c.pixel[ok] ** 2)))
    return along, across, math.hypot(along, across), int(ok.sum())


def relative_deg(adjusted, sensor: str, reference: str):
    """The adjusted relative mounting of ``sensor`` to ``reference``: (roll, pitch, heading) and sigmas, deg."""
    for e in adjusted.result.relative_mountings():
        if (e.sensor, e.reference) == (sensor, reference):
            return np.degrees(e.boresight), np.degrees(e.boresight_sigma)
    raise KeyError((sensor, reference))
