"""The "Correlated unknowns" section: rows grouped by kind of pair, each kind explained once."""
from __future__ import annotations

from scangeo.reports.correlations import note
from scangeo.reports.tables import markdown, markdown_tables
from scangeo.strategy.comparison import Comparison, VariantSummary


def _pair(model: str, a: str, b: str, r: float) -> dict:
    return {"model": model, "a": a, "b": b, "r": r, "note": note(a, b, r, f"model {model}")}


def _comparison() -> Comparison:
    # as in the demo: every strip's x0 with roll0 and y0 with pitch0, in two variants; one degree-1 pair
    se = [_pair(m, "x0", "roll0", -0.998 + k * 0.001) for k, m in enumerate(("01", "02", "03"))]
    se += [_pair(m, "y0", "pitch0", 0.9991) for m in ("01", "03")]
    s2 = [_pair("02", "x0", "roll0", -0.993), _pair("02.2", "x1", "roll1", 0.961)]
    variants = [VariantSummary("SE", "SE", correlations=se), VariantSummary("S2", "S", correlations=s2),
                VariantSummary("DG", "DG")]
    return Comparison("p", "variants.toml", "SE", ["01", "02", "03"], variants)


def test_rows_are_grouped_by_kind_of_pair_most_frequent_first():
    head, rows = markdown_tables(_comparison())["correlations"]
    assert head == ["pair", "variant", "models (r)"]
    assert rows == [
        ["shift in x ~ roll", "SE", "01 -0.998, 02 -0.997, 03 -0.996"],
        ["shift in x ~ roll", "S2", "02 -0.993"],
        ["shift in y ~ pitch", "SE", "01 +0.999, 03 +0.999"],
        ["shift in x (degree 1 term) ~ roll (degree 1 term)", "S2", "02.2 +0.961"],
    ]


def test_each_kind_is_explained_once():
    text = markdown(_comparison())
    section = text[text.index("## Correlated unknowns"):]
    assert section.count("move the footprint alike") == 3  # three kinds, seven pairs
    assert "* **shift in x ~ roll**: The shift in x and the roll of a GPS/IMU model move the footprint" in section
    assert "* **shift in y ~ pitch**: The shift in y and the pitch of a GPS/IMU model" in section
    assert section.count("| shift in x ~ roll |") == 2


def test_no_section_without_correlated_pairs():
    c = _comparison()
    for v in c.variants:
        v.correlations = []
    assert "correlations" not in markdown_tables(c)
    assert "Correlated unknowns" not in markdown(c)
