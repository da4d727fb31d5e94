"""Strategy comparison and residual reports (docs/reports.md).

* :mod:`scangeo.reports.default_variants`: the default strategies (``scangeo/data/variants.toml``) for a project;
* :mod:`scangeo.reports.comparison`: every variant adjusted and summarised against the reference;
* :mod:`scangeo.reports.true_error`: the true error of an orientation on a simulated project;
* :mod:`scangeo.reports.tables`: the comparison as Markdown, CSV and JSON;
* :mod:`scangeo.reports.residual_vectors`, :mod:`scangeo.reports.geopackage`: check-point residual
  vectors on the ground, and as a GeoPackage for GIS;
* :mod:`scangeo.reports.figures`, :mod:`scangeo.reports.html`: plots and the self-contained HTML report;
* :mod:`scangeo.reports.demo`: simulate, compare, rectify and report in one call.
"""
