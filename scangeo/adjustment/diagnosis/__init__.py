"""Diagnosis of GPS/IMU drift: which strips need more than a constant correction, and where.

* :mod:`scangeo.adjustment.diagnosis.diagnose`: ``diagnose(project)``, the SE adjustment's misclosures
  arranged along each strip;
* :mod:`scangeo.adjustment.diagnosis.patterns`: C0 piecewise-linear error functions, breaks by BIC;
* :mod:`scangeo.adjustment.diagnosis.refine`: the breaks refined by the split model's cost;
* :mod:`scangeo.adjustment.diagnosis.output`: diagnosis.json.
"""
