"""Evaluation against a simulation's truth (``truth/`` of ``scangeo simulate``), in one place:

* :mod:`scangeo.truth.true_error`: the true error of an orientation over each strip's image;
* :mod:`scangeo.truth.matches`: the true error of matched tie points, and a project whose control
  points are measured by matching.

Used by the comparison (true error per variant), the demo and the tests; it reads the project and
``truth/`` only.
"""
