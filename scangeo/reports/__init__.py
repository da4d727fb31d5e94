"""Rendering of adjustments and comparisons (docs/reports.md): tables, plots, HTML, GeoPackage.

* :mod:`scangeo.reports.tables`: the comparison as Markdown, CSV and JSON;
* :mod:`scangeo.reports.residual_vectors`, :mod:`scangeo.reports.geopackage`: check-point residual
  vectors on the ground, and as a GeoPackage for GIS;
* :mod:`scangeo.reports.figures`, :mod:`scangeo.reports.html`: plots and the self-contained HTML report;
* :mod:`scangeo.reports.matching`: the matching section of the report;
* :mod:`scangeo.reports.reliability`: reliability maps, and the plan of ``scangeo plan``.

The comparison of variants, the cross-validation and the default variants are in
:mod:`scangeo.strategy`; the demo in :mod:`scangeo.pipeline.demo`;
the true error on simulated projects in :mod:`scangeo.truth`.
"""
