"""The Juvika drone line (Resonon Pika-L, docs/real-data.md): scangeo import lcf's decisions, and the footprint's
corners on the sea against the data author's world file, for the conventions taken and their alternatives.

    python tests/benchmarks/juvika.py [--data FOLDER]

FOLDER holds Juvika_June2022_Pika_L_12.lcf, .bil.times and .wld (default ../shared/data/resonon). The cube is
not public: a stand-in of its size (900 samples x 2000 lines, one band of zeros) is written to a temporary
folder. Each row imports the line once (`--fov 36.5 --dtm 0 --geoid 30.52`, EGM96's undulation there) with one
convention changed, casts the four corner rays onto the plane at 0 m (the sea) and prints how far each lies from
the world file's corner (lines 0 and 1998: the last line was taken after the navigation ended).
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from scangeo.importers.lcf import import_lcf  # noqa: E402
from scangeo.io.project import Project  # noqa: E402
from tests.importers.sensor_files import write_cube  # noqa: E402

NAME = "Juvika_June2022_Pika_L_12"
N_EGM96 = 30.52  # EGM96 (PROJ's egm96_15.gtx, bilinear) at 67.2154 N, 15.0056 E


def corners(out: Path, world: np.ndarray) -> tuple[np.ndarray, float]:
    project = Project.load(out)
    strip = project.strips[0].id
    n = project.n_lines(strip)
    lines, pixels = np.array([0.0, 0, n - 1, n - 1]), np.array([0.0, 899, 0, 899])
    p_P, _ = project.geometry(strip).image_to_ground(lines, pixels, project.dtm)
    x, y, _ = project.map_frame.project_to_map(p_P)
    a, d, b, e, c, f = world
    dist = np.hypot(x - (a * pixels + b * lines + c), y - (d * pixels + e * lines + f))
    return dist, float(np.hypot(x[1] - x[0], y[1] - y[0]))


def changed_lcf(src: Path, dst: Path, column: int, change) -> Path:
    rows = []
    for line in src.read_text().splitlines():
        fields = line.split()
        fields[column] = repr(change(float(fields[column])))
        rows.append("\t".join(fields))
    dst.write_text("\n".join(rows) + "\n")
    return dst


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=str(Path(__file__).resolve().parents[3] / "shared" / "data" / "resonon"))
    args = ap.parse_args()
    data = Path(args.data)
    lcf, times, world = data / f"{NAME}.lcf", data / f"{NAME}.bil.times", np.loadtxt(data / f"{NAME}.wld")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        cube = write_cube(tmp / f"{NAME}.bil", np.zeros((2000, 900, 1), np.uint16))
        base = dict(lcf=lcf, times=times, fov_deg=36.5, pixels_increase="left", dtm=0, geoid=N_EGM96)
        flipped_roll = changed_lcf(lcf, tmp / "roll.lcf", 1, lambda v: -v)
        from_east = changed_lcf(lcf, tmp / "heading.lcf", 3, lambda v: float(np.mod(np.pi / 2 - v, 2 * np.pi)))
        rows = [
            ("**as imported** (altitude above the geoid, pixels growing to the left)", {}),
            ("pixels growing to the right", {"pixels_increase": "right"}),
            ("roll as stored (right wing down)", {"lcf": flipped_roll}),
            ("heading counter-clockwise from east", {"lcf": from_east}),
            ("altitude above the ellipsoid (the specification)", {"altitude": "ellipsoidal"}),
            ("the author's height: 10 m more above the sea (48 m)", {"dtm": -10}),
        ]
        print("| reading | corner line 0 / px 0 | line 0 / px 899 | line 1998 / px 0 | line 1998 / px 899 | "
              "swath at line 0 (m) |")
        print("|---|---|---|---|---|---|")
        for k, (label, change) in enumerate(rows):
            out = tmp / f"p{k}"
            result = import_lcf(cube, out, **{**base, **change})
            dist, swath = corners(out, world)
            print(f"| {label} | " + " | ".join(f"{v:.2f}" for v in dist) + f" | {swath:.2f} |")
            if k == 0:
                record = json.loads((out / "import.json").read_text())
        a, d, b, e, c, f = world
        print(f"\nworld file: swath {np.hypot(899 * a, 899 * d):.2f} m, {np.hypot(a, d) * 100:.2f} cm across, "
              f"{np.hypot(b, e) * 100:.2f} cm along")
        print(f"lines kept {result.lines}, line rate {result.line_rate_hz:.4f} Hz\n")
        for decision in record["decisions"]:
            print(f"- {decision['topic']}: {decision['choice']}")
            print(f"  figures: {json.dumps(decision['figures'])}")
            if decision["alternatives"]:
                print(f"  alternatives: {json.dumps(decision['alternatives'])}")
        for note in record["notes"] + [f"warning: {w}" for w in record["warnings"]]:
            print(f"- {note}")


if __name__ == "__main__":
    main()
