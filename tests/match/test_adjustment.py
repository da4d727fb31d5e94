"""An adjustment with only matched ties and matched control against the same one with the simulator's
points: check-point rms within 15 %.

Both run on the same block and are judged on the same check points (the simulator's ``K*``); the
matched project has the matched ties and the matched control (from the truth orthoimage and the
project's DTM) and no simulated tie, control or height point. Default size: the ``small`` preset
(2 strips x 600 lines; variants BE and SE); ``SCANGEO_SCALE=full``: vienna2000 with every default
variant (BE, SE, P2, P4, S2, S4; images take about 10 minutes to render).
"""
from __future__ import annotations

import os

import pytest

from scangeo.match import match_project
from scangeo.strategy.comparison import compare_project
from scangeo.truth.matches import matched_points_project

FULL = os.environ.get("SCANGEO_SCALE", "").lower() == "full"
SMALL_VARIANTS = """
[variants.BE]
strategy = "BE"
snooping = false
dtm_heights = true
dtm_height_points = ["*"]

[variants.SE]
strategy = "SE"
snooping = false
dtm_heights = true
dtm_height_points = ["*"]
"""

pytestmark = pytest.mark.scale


@pytest.fixture(scope="module")
def blocks(tmp_path_factory):
    from scangeo.simulate.block import simulate
    from scangeo.simulate.config import load_preset

    folder = tmp_path_factory.mktemp("match_adjust")
    preset = "vienna2000" if FULL else "small"
    simulated = folder / "simulated"
    simulate(simulated, load_preset(preset))
    match_project(simulated, references=[simulated / "truth" / "ortho.tif"], workers=2)
    matched = matched_points_project(simulated, folder / "matched")
    if not FULL:
        for root in (simulated, matched):
            (root / "variants.toml").write_text(SMALL_VARIANTS, encoding="utf-8")
    names = None if FULL else ["BE", "SE"]
    return compare_project(simulated, names=names, folds=0), compare_project(matched, names=names, folds=0)


def test_matched_points_adjust_as_well_as_the_simulators(blocks):
    simulated, matched = blocks
    for v in simulated.variants:
        if v.error is not None or v.name == "DG":
            continue
        ours = matched.variant(v.name).check_pooled_rms()
        theirs = v.check_pooled_rms()
        print(f"{v.name}: check rms {theirs:.3f} px with the simulator's points, {ours:.3f} px with matched points")
        assert ours <= 1.15 * theirs
