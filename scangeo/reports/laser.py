"""The report of a laser project: strip differences (raster and picture) and ``results/report.html``.

:func:`write_differences` writes ``results/differences.tif``, a cloud-optimised GeoTIFF of two
float32 bands (``before``, ``after``): the height difference (m; map units in the trajectory-free
mode) of the first overlapping strip pair of every planar grid cell, NaN elsewhere.

:func:`write_laser_report` reads what the stages wrote (``results/comparison.json``, the recommended
variant's ``results/NAME/results.json``, ``results/differences.tif``, ``results/cleaning/``) and
writes one self-contained HTML file with what ALS users look at:

1. the variants side by side and the recommended one;
2. a map of the tie, control, height and check patches;
3. the strip differences before and after, as maps, with their rms, per strip pair;
4. the block's connectivity: how many strips each tie patch was found in (a histogram);
5. the t-tests of the correction parameters and the calibration;
6. the residuals of the control and check patches;
7. the rejected observations (cleaning and the variant's own snooping) with w and MDB;
8. the notes of the adjustment.
"""
from __future__ import annotations

import datetime
import json
import math
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from scangeo.atomic import atomic_path, write_text
from scangeo.errors import InputFileError
from scangeo.lidar.differences import Differences, mosaic
from scangeo.reports import html
from scangeo.reports.figures import colour, png
from scangeo.version import __version__

#: The strip-difference raster beside the report.
DIFFERENCES = Path("results") / "differences.tif"
KIND_STYLE = {"tie": ("#1f77b4", "."), "control": ("#d62728", "^"), "height": ("#ff7f0e", "s"),
              "check": ("#2ca02c", "o")}


def write_differences(path: Path, before: Differences, after: Differences, crs) -> Path:
    """The strip differences before and after as a two-band COG (module docstring)."""
    import rasterio  # start-up cost: GDAL loads only when the difference grid is written
    from affine import Affine

    gb, (x0, y1), rows, cols = mosaic(before)
    ga, *_ = mosaic(after)
    profile = dict(driver="COG", width=cols, height=rows, count=2, dtype="float32", nodata=np.nan, crs=crs,
                   transform=Affine(before.size, 0.0, x0, 0.0, -before.size, y1), compress="deflate",
                   blocksize=256)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        with rasterio.open(tmp, "w", **profile) as dst:
            dst.write(gb, 1)
            dst.write(ga, 2)
            dst.set_band_description(1, "before")
            dst.set_band_description(2, "after")
    return path


def _read_differences(path: Path) -> tuple[np.ndarray, np.ndarray, tuple[float, float, float, float]]:
    import rasterio  # start-up cost: GDAL loads only when the report is written

    with rasterio.open(path) as src:
        b = src.bounds
        return src.read(1), src.read(2), (b.left, b.right, b.bottom, b.top)


def differences_figure(before: np.ndarray, after: np.ndarray, extent, rms: tuple[float, float], unit: str) -> bytes:
    """The strip differences before and after, side by side, on one colour scale."""
    lim = float(np.nanpercentile(np.abs(before), 95)) if np.isfinite(before).any() else 0.1
    fig = Figure(figsize=(11, 5), layout="constrained")
    axes = fig.subplots(1, 2)
    images = []
    for ax, g, title, r in ((axes[0], before, "before", rms[0]), (axes[1], after, "after", rms[1])):
        images.append(ax.imshow(g, cmap="RdBu_r", vmin=-lim, vmax=lim, interpolation="nearest", extent=extent))
        ax.set_title(f"strip differences {title}: rms "
                     + (f"{100 * r:.2f} cm" if unit == "m" else f"{r:.4f} {unit}"))
        ax.set_aspect("equal")
        ax.ticklabel_format(useOffset=False, style="plain")
        ax.tick_params(labelsize=7)
    fig.colorbar(images[0], ax=list(axes), shrink=0.8, label=f"dz ({unit})")
    return png(fig)


def patch_map(patches: list[dict], strips: dict[str, dict] | None = None) -> bytes:
    """The patches by kind over the block (map coordinates)."""
    fig = Figure(figsize=(8, 7), layout="constrained")
    ax = fig.subplots()
    for kind, (c, m) in KIND_STYLE.items():
        sel = [p for p in patches if p["kind"] == kind]
        if sel:
            ax.scatter([p["x"] for p in sel], [p["y"] for p in sel], s=8 if kind == "tie" else 40, c=c, marker=m,
                       label=f"{kind} ({len(sel)})")
    ax.set_aspect("equal")
    ax.set_xlabel("x (map)")
    ax.set_ylabel("y (map)")
    ax.ticklabel_format(useOffset=False, style="plain")
    ax.tick_params(labelsize=7)
    ax.legend(loc="best", fontsize=8)
    ax.set_title("patches of the adjustment")
    return png(fig)


def connectivity_figure(strips_per_patch: dict[str, int]) -> bytes:
    """Histogram: how many tie patches were found in 2, 3, ... strips."""
    fig = Figure(figsize=(6, 3.5), layout="constrained")
    ax = fig.subplots()
    n = [int(k) for k in strips_per_patch]
    ax.bar(n, list(strips_per_patch.values()), color=colour(0))
    ax.set_xticks(n)
    ax.set_xlabel("strips the tie patch was found in")
    ax.set_ylabel("tie patches")
    ax.set_title("connectivity of the block")
    return png(fig)


def _f(x, digits: int = 3) -> str:
    if x is None:
        return "–"
    if isinstance(x, float):
        return "–" if not math.isfinite(x) else f"{x:.{digits}f}"
    return str(x)


def _cm(ev: dict, key: str, which: str) -> str:
    v = (ev.get(key) or {}).get(which)
    return "–" if v is None or not math.isfinite(v) else f"{100 * v:.2f}"


def _read_json(path: Path) -> dict:
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError as exc:
        raise InputFileError(f"{path}: not found; run the compare stage first (scangeo run)") from exc
    except (OSError, ValueError) as exc:
        raise InputFileError(f"{path}: cannot read ({exc})") from exc


def _comparison_section(c: dict) -> html.Section:
    rows = c["table"]
    head = ["variant"] + [h for h in rows[0] if h != "variant"] if rows else ["variant"]
    body = [[r["variant"] + (" (recommended)" if r["variant"] == c["recommended"] else "")]
            + [_f(r[h]) for h in head[1:]] for r in rows]
    parts = [html.table(head, body, "laser-variants"),
             html.paragraph(f"Recommended: {c['recommended']} ({c['why']}). Variants from {c['variants_file']}.")]
    if c.get("errors"):
        parts.append(html.bullet_list([f"{n}: {e}" for n, e in c["errors"].items()]))
    return html.Section("Variants", "variants", parts)


def _differences_section(root: Path, r: dict) -> html.Section:
    ev = r.get("evaluation") or {}
    unit = "m" if r["mode"] == "trajectory" else "map units"
    rows = [[label, _cm(ev, key, "before"), _cm(ev, key, "after")] for key, label in (
        ("strip_differences_rms_m", "strip differences"), ("strip_differences_flat_rms_m", "  on flat cells"),
        ("tie_patch_discrepancies_rms_m", "tie patch discrepancies"), ("check_patches_rms_m", "check patches"),
        ("control_check_points_rms_m", "check points on control patches"))]
    parts = [html.table(["rms (cm)", "before", "after"], rows, "laser-before-after")]
    grid = root / DIFFERENCES
    if grid.exists():
        before, after, extent = _read_differences(grid)
        sd = ev.get("strip_differences_rms_m", {})
        parts.append(html.figure(differences_figure(before, after, extent, (sd.get("before", math.nan),
                                                                             sd.get("after", math.nan)), unit),
                                 f"strip differences of the overlapping strips before and after the adjustment "
                                 f"({DIFFERENCES.as_posix()}, bands before and after)", "strip-differences"))
    pairs = ev.get("pairs_after") or {}
    if pairs:
        parts.append(html.table(["strip pair", "cells", "rms after (cm)", "mean after (cm)"],
                                [[k, str(v["cells"]), f"{100 * v['rms']:.2f}", f"{100 * v['mean']:.2f}"]
                                 for k, v in pairs.items()], "laser-pairs"))
    return html.Section("Strip differences", "strip-differences-section", parts)


def _patches_section(r: dict) -> html.Section:
    parts = [html.figure(patch_map(r.get("patch_map", [])), "tie, control, height and check patches", "patch-map"),
             html.paragraph(", ".join(f"{n} {k}" for k, n in r["patches"].items()) + " patches.")]
    spp = r.get("strips_per_patch") or {}
    if spp:
        parts.append(html.figure(connectivity_figure(spp), "how many strips each tie patch was found in",
                                 "connectivity"))
        parts.append(html.table(["strips", "tie patches"], [[k, str(v)] for k, v in spp.items()], "strips-per-patch"))
    return html.Section("Patches and connectivity", "patches", parts)


def _parameters_section(r: dict) -> html.Section:
    rows = [[p["key"], p["component"], f"{p['value']:+.6f}", f"{p['sigma']:.6f}", p["unit"], f"{p['t']:.2f}",
             "yes" if p["significant"] else "no"] for p in r["parameters"]]
    t = r.get("patch_tilts") or {}
    parts = [html.paragraph("t = |value| / sigma, tested against zero at 5 % (two-sided, the redundancy's degrees "
                            "of freedom): a coefficient that is not significant is a candidate to leave out."),
             html.table(["key", "component", "value", "sigma", "unit", "t", "significant"], rows, "laser-t-tests")]
    if t:
        parts.append(html.paragraph(f"{t['significant']} of {t['patches']} patch planes are tilted significantly "
                                    f"(5 %) from their initial normals; largest t {t['max_t']:.1f}."))
    return html.Section("Correction parameters (t-tests)", "parameters", parts)


def _residuals_section(r: dict) -> html.Section:
    ev = r.get("evaluation") or {}
    parts = []
    checks = ev.get("check_patches") or {}
    if checks:
        parts.append(html.table(["check patch : strip", "before (cm)", "after (cm)"],
                                [[k, f"{100 * v[0]:.2f}", f"{100 * v[1]:.2f}"] for k, v in checks.items()],
                                "laser-check-patches"))
    control = ev.get("control_check_points") or {}
    if control:
        parts.append(html.table(["check point on a control patch", "before (cm)", "after (cm)"],
                                [[k, f"{100 * v[0]:.2f}", f"{100 * v[1]:.2f}"] for k, v in control.items()],
                                "laser-control-points"))
    if not parts:
        parts.append(html.paragraph("no control or check patches (no ground.csv)"))
    return html.Section("Control and check patches", "control", parts)


def _rejections_section(root: Path, r: dict) -> html.Section:
    parts = []
    cleaning = root / "results" / "cleaning" / "cleaning.json"
    if cleaning.exists():
        c = _read_json(cleaning)
        rows = [[x["strip"], x["patch"], f"{x['w']:.2f}", f"{100 * x['mdb_m']:.2f}"]
                for x in c["observations_rejected"]]
        parts.append(html.paragraph(f"Set aside by the cleaning ({c['model']}): {c['rejected']} patch observations; "
                                    f"sigma0 {c['sigma0_before']:.3f} -> {c['sigma0_after']:.3f}."))
        if rows:
            parts.append(html.table(["strip", "patch", "w", "MDB (cm)"], rows, "laser-cleaning"))
    rej = r["rejections"]
    parts.append(html.paragraph(f"Rejected by the variant's own data snooping: {len(rej)}."))
    if rej:
        parts.append(html.table(["observations", "patch", "w", "MDB (cm)", "round"],
                                [[x["group"], x["patch"], f"{x['w']:.2f}", _f(100 * x["mdb"], 2), str(x["round"])]
                                 for x in rej], "laser-rejections"))
    return html.Section("Rejected observations", "rejections", parts)


def write_laser_report(root: Path, out: Path | None = None) -> tuple[Path, int]:
    """``report.html`` of a compared laser project into ``out`` (default PROJECT/results; module docstring);
    returns it and its figure count."""
    root = Path(root)
    c = _read_json(root / "results" / "comparison.json")
    name = c.get("recommended")
    if not name:
        raise InputFileError(f"{root / 'results' / 'comparison.json'}: no variant could be adjusted")
    r = _read_json(root / "results" / name / "results.json")
    sections = [_comparison_section(c), _patches_section(r), _differences_section(root, r), _parameters_section(r),
                _residuals_section(r), _rejections_section(root, r),
                html.Section("Notes", "notes", [html.bullet_list(list(r.get("notes", [])))])]
    intro = [html.paragraph(f"Laser project {root.name}: variant {name}, mode {r['mode_description']}; sigma0 "
                            f"{r['sigma0']:.3f}, converged: {r['converged']}. scangeo {__version__}, "
                            f"{datetime.datetime.now(datetime.UTC).isoformat(timespec='seconds')}.")]
    text = html.document(f"scangeo laser report: {root.name}", intro, sections)
    folder = Path(out) if out is not None else root / "results"
    folder.mkdir(parents=True, exist_ok=True)
    path = write_text(folder / "report.html", text)
    return path, text.count('class="report-figure"')


__all__ = ["DIFFERENCES", "connectivity_figure", "differences_figure", "patch_map", "write_differences",
           "write_laser_report"]
