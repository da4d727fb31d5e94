"""The report's co-registration section: how well a platform's sensors line up, per flight line.

For the variant that is rectified (the recommended one), ``results/NAME/report.json``'s ``platform``
section gives per strip its sensor, flight line and co-registration summary: the propagated 1-sigma
relative ground displacement of its rays against its flight line's reference strip (another
sensor's), median and largest over a grid of its image (:mod:`scangeo.adjustment.coregistration`).
One short table per flight line: strip, sensor, reference, median and max sigma (m), and the
co-registration layer of the strip (``ortho/<strip>.coregistration.tif``) when it has been rectified.
A one-sensor project, or a variant without a platform section, has no such section.
"""
from __future__ import annotations

from pathlib import Path

from scangeo.adjustment.outputs import read_report
from scangeo.rectify.coregistration_layer import layer_path
from scangeo.reports import html


def _metres(value) -> str:
    return "-" if value is None else f"{value:.3f}"


def coregistration_rows(platform: dict) -> dict[str, list[list[str]]]:
    """Per flight line, the rows strip, sensor, reference, median and max sigma (m) of its strips that have a
    co-registration (``report.json``'s ``platform`` section)."""
    out: dict[str, list[list[str]]] = {}
    strips = platform.get("strips") or {}
    for fid, members in (platform.get("flight_lines") or {}).items():
        rows = []
        for sid in members:
            s = strips.get(sid) or {}
            co = s.get("coregistration")
            if co:
                rows.append([sid, str(s.get("sensor", "")), str(co.get("reference", "")), _metres(co.get("median_m")),
                             _metres(co.get("max_m"))])
        if rows:
            out[fid] = rows
    return out


def coregistration_section(results: Path, variant: str) -> html.Section | None:
    """The section for ``variant`` (module docstring), or None when it has no co-registration.

    Parameters
    ----------
    results : Path
        ``PROJECT/results``.
    variant : str
        The variant whose ``report.json`` is read (the one rectified).

    Returns
    -------
    html.Section or None
        A table per flight line.
    """
    platform = read_report(results, variant).get("platform") or {}
    rows = coregistration_rows(platform)
    if not rows:
        return None
    sec = html.Section("Co-registration of the sensors", "coregistration")
    sec.parts.append(html.paragraph(
        f"{variant}: the propagated 1-sigma relative ground displacement (radial, metres) of each strip's rays against "
        "its flight line's reference strip of another sensor, from the adjustment's joint covariance: what "
        "misregisters the two sensors' orthoimages. Median and largest over a grid of the strip's image where "
        "both see the ground. Per cell: the co-registration layer beside the strip's orthoimage."))
    ortho = Path(results) / variant / "ortho"
    for fid, table_rows in rows.items():
        sec.parts.append(f"<h3>Flight line {html.esc(fid)}</h3>")
        layers = []
        for row in table_rows:
            layer = layer_path(ortho / f"{row[0]}.tif")
            layers.append(layer.relative_to(Path(results).parent).as_posix() if layer.exists() else "not rectified")
        sec.parts.append(html.table(["strip", "sensor", "reference", "median sigma (m)", "max sigma (m)", "layer"],
                                    [r + [lay] for r, lay in zip(table_rows, layers)],
                                    table_id=f"coregistration-{fid}", text_columns=(0, 1, 2, 5)))
    return sec


__all__ = ["coregistration_rows", "coregistration_section"]
