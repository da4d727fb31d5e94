"""Strategies: which variants to adjust and which is best.

* :mod:`scangeo.strategy.default_variants`: the default strategies (``scangeo/data/variants.toml``)
  for a project, from the diagnosis;
* :mod:`scangeo.strategy.comparison`: every variant adjusted and summarised against the reference;
* :mod:`scangeo.strategy.crossvalidation`: k-fold cross-validation over the control points, and AIC;
* :mod:`scangeo.strategy.evidence`: the recommendation, weighing the cross-validation with the check
  points, each with its noise.
"""
