"""The report of ``scangeo lidar adjust``: strip-difference GeoTIFF and figure, report.html.

``differences.tif``: two float32 bands (``before``, ``after``), the height difference (m, map units in
the trajectory-free mode) of the first overlapping strip pair of every planar cell, NaN elsewhere.
``differences.png``: the same side by side. ``report.html``: mode, accounting, sigma0, the estimated
parameters with precision and significance, regularisation notes, data snooping, patch and strip
figures before/after.
"""

from __future__ import annotations

import html
from pathlib import Path

import numpy as np

from scangeo.atomic import atomic_path, write_text
from scangeo.lidar.differences import Differences, mosaic


def write_difference_grid(path: Path, before: Differences, after: Differences, crs) -> None:
    import rasterio  # start-up cost: GDAL loads only when the difference grid is written
    from affine import Affine

    gb, (x0, y1), rows, cols = mosaic(before)
    ga, *_ = mosaic(after)
    profile = dict(
        driver="GTiff",
        width=cols,
        height=rows,
        count=2,
        dtype="float32",
        nodata=np.nan,
        crs=crs,
        transform=Affine(before.size, 0.0, x0, 0.0, -before.size, y1),
        compress="deflate",
    )
    with atomic_path(path) as tmp, rasterio.open(tmp, "w", **profile) as dst:
        dst.write(gb, 1)
        dst.write(ga, 2)
        dst.set_band_description(1, "before")
        dst.set_band_description(2, "after")


def write_difference_figure(path: Path, before: Differences, after: Differences, unit_name: str = "m") -> None:
    import matplotlib  # start-up cost: matplotlib loads only when a figure is drawn

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    gb, *_ = mosaic(before)
    ga, *_ = mosaic(after)
    lim = float(np.nanpercentile(np.abs(gb), 95)) if np.isfinite(gb).any() else 0.1
    fig, axes = plt.subplots(1, 2, figsize=(11, 5), constrained_layout=True)
    for ax, g, title, d in ((axes[0], gb, "before", before), (axes[1], ga, "after", after)):
        im = ax.imshow(g, cmap="RdBu_r", vmin=-lim, vmax=lim, interpolation="nearest")
        ax.set_title(f"strip differences {title}: rms {d.rms():.3f} {unit_name}")
        ax.set_xticks([]), ax.set_yticks([])
    fig.colorbar(im, ax=axes, shrink=0.8, label=f"dz ({unit_name})")
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110)
    plt.close(fig)


def _table(rows: list[dict], columns: list[str]) -> str:
    def cell(v):
        if isinstance(v, float):
            return f"{v:.6g}"
        return html.escape(str(v))

    head = "".join(f"<th>{html.escape(c)}</th>" for c in columns)
    body = "".join("<tr>" + "".join(f"<td>{cell(r.get(c, ''))}</td>" for c in columns) + "</tr>" for r in rows)
    return f"<table><tr>{head}</tr>{body}</table>"


def write_html(path: Path, results: dict, figure: str | None) -> None:
    ev = results.get("evaluation") or {}
    parts = [
        f"<h1>scangeo lidar adjust</h1><p><b>mode:</b> {html.escape(results['mode_description'])}</p>",
        f"<p>sigma0 = {results['sigma0']:.3f}; converged: {results['converged']}</p>",
        "<h2>Accounting</h2>",
        _table([results["accounting"]], list(results["accounting"])),
        "<h2>Strips</h2>",
        _table(
            [{"strip": s, **v} for s, v in results["strips"].items()],
            ["strip", "returns", "t_start", "t_end", "planar_cells", "patches"],
        ),
        "<h2>Patches</h2>",
        _table([results["patches"]], ["tie", "control", "height", "check"]),
    ]
    if ev:
        rows = [
            {"figure": k, **{kk: vv for kk, vv in v.items() if kk in ("before", "after", "cells", "count")}}
            for k, v in ev.items()
            if k != "pairs_after" and v.get("before") == v.get("before")  # NaN: no such patches
        ]
        parts += [
            "<h2>Before and after</h2>",
            _table(rows, ["figure", "before", "after", "cells", "count"]),
            "<h2>Strip pairs after</h2>",
            _table([{"pair": k, **v} for k, v in ev["pairs_after"].items()], ["pair", "cells", "rms", "mean"]),
        ]
    if figure:
        parts.append(
            f'<img src="{html.escape(figure)}" alt="strip differences before and after" style="max-width:100%">'
        )
    parts += [
        "<h2>Estimated parameters</h2>",
        "<p>t = |value| / sigma, tested against zero at 5 % (two-sided, the redundancy's degrees of freedom): "
        "a coefficient that is not significant is a candidate to leave out of the model.</p>",
        _table(results["parameters"], ["key", "component", "value", "sigma", "unit", "t", "significant"]),
    ]
    tilts = results.get("patch_tilts")
    if tilts:
        parts.append(
            f"<h2>Patch tilts</h2><p>{tilts['significant']} of {tilts['patches']} patch planes are tilted "
            f"significantly (5 %) from their initial normals by the adjustment; largest t {tilts['max_t']:.1f}.</p>"
        )
    reg = results["regularisation"]
    parts.append(
        "<h2>Regularisation</h2>"
        + (_table(reg, ["key", "component", "sigma", "reason"]) if reg else "<p>none: every unknown is determined</p>")
    )
    rej = results["rejections"]
    parts.append(
        "<h2>Data snooping</h2>" + (_table(rej, ["group", "patch", "w", "round"]) if rej else "<p>nothing rejected</p>")
    )
    parts.append("<h2>Notes</h2><ul>" + "".join(f"<li>{html.escape(n)}</li>" for n in results["notes"]) + "</ul>")
    style = (
        "<style>body{font-family:sans-serif;max-width:1100px;margin:auto}table{border-collapse:collapse}"
        "td,th{border:1px solid #ccc;padding:2px 6px;font-size:13px}</style>"
    )
    write_text(
        path,
        f"<!doctype html><html><head><meta charset='utf-8'><title>lidar adjust</title>{style}</head>"
        f"<body>{''.join(parts)}</body></html>",
    )
