"""Is an adjustment's sigma0 plausible? A warning that names the likely causes when it is not.

An adjustment that decides something (the diagnosis's SE, the cross-validation's folds) rests on its
residuals. With sigma0 far above 1 they are dominated by something the model does not expect, and
what is decided from them is suspect. :func:`sigma0_warning` says so, and why it may be.

The limit, ``SIGMA0_LIMIT = 2``: measured on the simulated blocks (docs/adjustment.md, "Cleaning"),
the diagnosis's SE has sigma0 about 1.0-1.6 on clean data, the problem strip's drift included (SE
sees it mainly through tie points without DTM heights), and 3.9-14 with 5 to 20 blunders of 10-40 px.
"""
from __future__ import annotations

import math
from pathlib import Path

from scangeo.io.rejected import rejected_path

#: sigma0 above this is "far above 1": a warning.
SIGMA0_LIMIT = 2.0


def sigma0_warning(sigma0: float | None, what: str, project_root=None, limit: float = SIGMA0_LIMIT) -> str | None:
    """A warning for ``what`` (e.g. "the diagnosis's SE adjustment") when ``sigma0 > limit``, else None.

    The causes named: blunders (first when the project was not cleaned: no
    ``results/cleaning/rejected.csv``), image or ground sigmas too small, a strip model too stiff for
    its GPS/IMU drift, a wrong DTM (or tie points with DTM heights off open terrain), and a wrong
    sensor calibration.
    """
    if sigma0 is None or not math.isfinite(sigma0) or sigma0 <= limit:
        return None
    cleaned = project_root is not None and rejected_path(Path(project_root)).exists()
    blunders = ("blunders left among the measurements (see results/cleaning/rejected.csv; lower the critical value "
                "or check the points with the largest w)" if cleaned else
                "blunders among the measurements: the project was not cleaned (run `scangeo clean PROJECT` first)")
    causes = [blunders,
              "sigmas too small (sigma_px in points.csv, sigma_xy/sigma_z in ground.csv, the variant's GPS/IMU sigmas)",
              "a strip model too stiff for its GPS/IMU drift (a problem strip: see the diagnosis's breaks)",
              "a wrong DTM or DTM sigma (tie points with DTM heights on buildings or trees)",
              "a wrong sensor calibration, lever arm or time offset"]
    return (f"{what}: sigma0 {sigma0:.2f} is far above 1 (limit {limit:g}); what it decides is suspect. "
            "Likely causes: " + "; ".join(causes) + ".")


__all__ = ["SIGMA0_LIMIT", "sigma0_warning"]
