"""The shared HySpex pair (VNIR-1800 and SWIR-384, 2020-05-22) as one platform project: the figures of
docs/real-data.md, "The platform".

Run: python tests/benchmarks/real_pair.py [--data ../shared/data] [--keep DIR]

1. **Each camera alone** (``scangeo import parge`` of one line; real_data.py's split: PARGE's used GCPs
   sorted by line, alternately control and check): the check rms of PARGE and BORESIGHT, lines along /
   pixels across / both together (the bar of the joint adjustment).
2. **The platform import** of both lines: how the navigation agrees, the time offset, the sensors'
   mountings on the INS and how far each camera's single-line attitude departs from its constant
   mounting; the ground points of every GCP's image position through the platform project against its
   single-line project (the same DTM plane and geoid).
3. **The joint adjustment** on the same split per camera, for the platform's geoid undulation
   (PARGE's height offset of the VNIR line, of the SWIR line, their mean): PARGE, BORESIGHT, CALIBRATED,
   and the relative mounting of the two boresights with its precision.
4. **The SWIR through the VNIR**: every SWIR GCP a check point, the VNIR's split control, BORESIGHT
   (both boresights free) and a relative-mounting prior from PARGE's stored offsets (in level flight and
   over the line's attitudes), from its boresight results, and the imported one; the SWIR's check rms
   over its 42 used GCPs and over the split's 21 check points, against its own BORESIGHT figure.
"""
from __future__ import annotations

import argparse
import json
import shutil
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np
import scipy.io

warnings.simplefilter("ignore")
HERE = Path(__file__).resolve()
sys.path.insert(0, str(HERE.parents[2]))

from scangeo.importers.parge import import_parge  # noqa: E402
from scangeo.importers.parge_platform import import_parge_platform  # noqa: E402
from scangeo.io.project import Project  # noqa: E402
from scangeo.io.project_schema import RelativeMountingKeys  # noqa: E402
from scangeo.workflow import adjust  # noqa: E402
from tests.benchmarks.real_data import check_rms as single_check_rms  # noqa: E402
from tests.benchmarks.real_data import split_variants as single_split  # noqa: E402
from tests.importers.pair_split import (  # noqa: E402
    PAIR,
    check_rms,
    gcp_ids,
    relative_deg,
    split_roles,
    split_variants,
    subset_rms,
)

#: the relative-mounting prior's sigma (deg): docs/real-data.md, "The SWIR through the VNIR"
PRIOR_SIGMA_DEG = (0.03, 0.03, 0.06)


def _f(v) -> str:
    return f"{v[0]:.3f} / {v[1]:.3f} / {v[2]:.3f}"


def alone(statuses: dict[str, Path], work: Path) -> dict[str, dict[str, float]]:
    out = {}
    print("== each camera alone (single-line import, alternate split): check rms lines / px / both")
    for sensor, status in statuses.items():
        root = work / f"alone-{sensor}"
        import_parge(status, root)
        variants = single_split(status, root)
        out[sensor] = {}
        for v in ("PARGE", "BORESIGHT"):
            a, p, _ = single_check_rms(root, v, variants)
            out[sensor][v] = float(np.hypot(a, p))
            print(f"  {sensor} {v:10s} {a:.3f} / {p:.3f} / {np.hypot(a, p):.3f}")
    return out


def platform_import(statuses: dict[str, Path], work: Path) -> None:
    root = work / "platform"
    r = import_parge_platform([statuses["vnir"], statuses["swir"]], root)
    print("== the platform import")
    for fl, strips in r.flight_lines.items():
        print(f"  flight line {fl}: {', '.join(strips)}")
    Project.load(root)  # the project reads
    rec = json.loads((root / "import.json").read_text())
    arrays = rec["flight_lines"]["L1"]["arrays"]["swir-L1"]
    ins = rec["flight_lines"]["L1"]["agreement"]["swir-L1"]
    mean = arrays["position_mean_neu_m"]
    print(f"  swir's navigation against vnir's at the SWIR's {arrays['common_records']} line times (swir minus vnir):")
    print(f"    positions within {arrays['position_max_m']:.3f} m (mean north {mean[0]:+.3f}, east {mean[1]:+.3f}, up "
          f"{mean[2]:+.4f} m); after the time offset {1e3 * ins['time_offset_s']:+.3f} ms within "
          f"{ins['position_max_shifted_m']:.3f} m (mean {np.round(ins['position_mean_neu_shifted_m'], 4)} m)")
    print(f"    attitude arrays as given: constant {np.round(arrays['attitude_constant_deg'], 4)} deg, rms beyond "
          f"{np.round(arrays['attitude_rms_deg'], 4)} deg; after the time offset rms "
          f"{np.round(arrays['attitude_rms_shifted_deg'], 4)} deg; body rotation departs "
          f"{np.round(arrays['rotation_departure_deg'], 4)} deg (rms, largest) from its constant")
    print(f"    INS copies (PARGE's stored offsets added back), after the time offset: constant "
          f"{np.round(ins['attitude_constant_shifted_deg'], 6)} deg, rms beyond "
          f"{np.round(ins['attitude_rms_shifted_deg'], 4)} deg; body rotation departs "
          f"{np.round(ins['rotation_departure_deg'], 4)} deg")
    for s, m in r.sensors.items():
        print(f"  {s}: boresight on the INS {np.round(m.boresight_deg, 4)} deg (single line "
              f"{np.round(m.single_line_boresight_deg, 4)} on its arrays); its single-line attitude departs "
              f"{m.departure_deg[0]:.4f} deg rms, {m.departure_deg[1]:.4f} at most")
    for pair, figures in rec["relative_mountings"].items():
        for k, v in figures.items():
            print(f"  relative mounting {pair} {k}: {np.round(v, 4) if v is not None else None}")
    ground_agreement(statuses, work)


def ground_agreement(statuses: dict[str, Path], work: Path) -> None:
    """Ground points (map, on one plane, one geoid) of every GCP's image position: platform vs single line."""
    plane, geoid = 180.0, 5.0
    root = work / "ground-platform"
    import_parge_platform([statuses["vnir"], statuses["swir"]], root, dtm=plane, geoid=geoid)
    platform = Project.load(root)
    for sensor, status in statuses.items():
        single_root = work / f"ground-{sensor}"
        import_parge(status, single_root, dtm=plane, geoid=geoid)
        single = Project.load(single_root)
        (strip,) = [s.id for s in single.strips]
        g = scipy.io.readsav(str(status), python_dict=True)["gcparr"]
        line, pixel = g[:, 1], g[:, 0]
        a = _ground(single, strip, line, pixel)
        b = _ground(platform, f"{sensor}-L1", line, pixel)
        d = np.linalg.norm(a - b, axis=1)
        print(f"  ground points of {len(d)} GCP image positions, {sensor} through the platform against its single "
              f"line: median {1e3 * np.median(d):.0f} mm, largest {1e3 * d.max():.0f} mm")


def _ground(project: Project, strip: str, line, pixel) -> np.ndarray:
    geometry = project.geometry(strip)
    p_P = geometry.image_to_ground(line, pixel, project.dtm)[0]
    x, y, z = project.map_frame.project_to_map(p_P)
    return np.column_stack([x, y, z])


def joint(statuses: dict[str, Path], work: Path, geoids: dict[str, float | None]) -> None:
    print("== the joint adjustment (the split of each camera): check rms lines / px / both; sigma0")
    for label, geoid in geoids.items():
        root = work / f"joint-{label}"
        import_parge_platform([statuses["vnir"], statuses["swir"]], root, geoid=geoid)
        variants = split_variants(root, split_roles(statuses))
        for v in ("PARGE", "BORESIGHT", "CALIBRATED"):
            adjusted = adjust(root, v, variants_file=variants)
            rms = check_rms(adjusted)
            rel, sig = relative_deg(adjusted, "swir", "vnir")
            print(f"  N {label:12s} {v:10s} vnir {_f(rms['vnir-L1'])}  swir {_f(rms['swir-L1'])}  sigma0 "
                  f"{adjusted.result.adjustment.statistics.sigma0:.3f}  swir:vnir {np.round(rel, 4)} +- "
                  f"{np.round(sig, 4)}")


def through(statuses: dict[str, Path], work: Path, geoids: dict[str, float | None]) -> None:
    print(f"== the SWIR through the VNIR: every SWIR GCP a check point; BORESIGHT; prior sigma {PRIOR_SIGMA_DEG} deg")
    rec = json.loads((work / "platform" / "import.json").read_text())["relative_mountings"]["swir:vnir"]
    priors = {"stored offsets (level)": rec["parge_stored_offsets_deg"],
              "stored offsets (the line)": rec["parge_stored_offsets_on_the_line_deg"],
              "boresight results (level)": rec["parge_boresight_results_deg"],
              "imported (the arrays)": rec["imported_deg"]}
    _, _, check = gcp_ids(statuses["swir"])
    ids, _, _ = gcp_ids(statuses["swir"])
    subset = [f"swir-{ids[k]}" for k in check]
    for label, geoid in geoids.items():
        for name, value in priors.items():
            root = work / f"through-{label}-{name.split()[0]}-{name.split()[-1].strip('()')}"
            prior = RelativeMountingKeys(sensor="swir", reference="vnir", boresight_deg=tuple(value),  # type: ignore[arg-type]
                                         boresight_sigma_deg=PRIOR_SIGMA_DEG)
            import_parge_platform([statuses["vnir"], statuses["swir"]], root, geoid=geoid, relative_mountings=(prior,))
            variants = split_variants(root, split_roles(statuses, all_check=("swir",)))
            adjusted = adjust(root, "BORESIGHT", variants_file=variants)
            rms = check_rms(adjusted)
            sub = subset_rms(adjusted, "swir-L1", subset)
            rel, sig = relative_deg(adjusted, "swir", "vnir")
            swir = rms["swir-L1"]
            print(f"  N {label:12s} {name:27s} {np.round(value, 4)}: swir all {swir[3]} {_f(swir)}, "
                  f"the split's {sub[3]} {_f(sub)}; vnir {_f(rms['vnir-L1'])}; adjusted {np.round(rel, 4)} +- "
                  f"{np.round(sig, 4)}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=str(HERE.parents[3] / "shared" / "data"), help="the shared data folder")
    ap.add_argument("--keep", default=None, help="keep the projects in this folder")
    args = ap.parse_args()
    statuses = {s: Path(args.data) / p for s, p in PAIR.items()}
    work = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="scangeo-pair-"))
    alone(statuses, work)
    platform_import(statuses, work)
    from scangeo.importers.parge_status import ParGeStatus

    offsets = {s: float(np.median(ParGeStatus.read(p).altitude - ParGeStatus.read(p).height))
               for s, p in statuses.items()}
    geoids = {"vnir's (default)": None, "swir's": offsets["swir"], "mean": float(np.mean(list(offsets.values())))}
    joint(statuses, work, geoids)
    through(statuses, work, geoids)
    if not args.keep:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
