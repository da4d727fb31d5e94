"""Strategies: which variants to adjust and which is best.

* :mod:`scangeo.strategy.default_variants`: the default strategies (``scangeo/data/variants.toml``)
  for a project, from the diagnosis;
* :mod:`scangeo.strategy.comparison`: every variant adjusted and summarised against the reference;
* :mod:`scangeo.strategy.crossvalidation`: a recommendation without check points (k-fold
  cross-validation over the control points, and BIC).
"""
