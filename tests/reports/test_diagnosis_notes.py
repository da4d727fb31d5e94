"""The report's diagnosis section shows the diagnosis's notes (a sigma0 warning, a dropped break), escaped."""
from __future__ import annotations

import json

from scangeo.adjustment.summary import Comparison
from scangeo.reports.diagnosis_section import diagnosis_section


def test_the_diagnosis_notes_reach_the_report(tmp_path):
    (tmp_path / "results").mkdir()
    notes = ["the diagnosis's SE adjustment: sigma0 7.61 is far above 1 (limit 2) <blunders>",
             "strip 02: the BIC's break at line 700 was dropped, the split model does not need it"]
    diagnosis = {"problem_strips": ["02"], "breaks": [], "se_sigma0": 7.61, "criterion": {}, "notes": notes}
    (tmp_path / "results" / "diagnosis.json").write_text(json.dumps(diagnosis), encoding="utf-8")
    text = "".join(diagnosis_section(tmp_path, Comparison(str(tmp_path), "variants.toml", "SE", ["02"], [])).parts)
    assert "sigma0 7.61 is far above 1 (limit 2) &lt;blunders&gt;" in text
    assert "line 700 was dropped" in text
    del diagnosis["notes"]
    (tmp_path / "results" / "diagnosis.json").write_text(json.dumps(diagnosis), encoding="utf-8")
    assert "note:" not in "".join(diagnosis_section(tmp_path, Comparison(str(tmp_path), "v", "SE", ["02"], [])).parts)


def test_an_adopted_attribution_is_named_beside_the_searchs_own_model(tmp_path):
    (tmp_path / "results").mkdir()
    diagnosis = {"problem_strips": ["02"], "breaks": [], "se_sigma0": 1.1, "criterion": {},
                 "adopted": {"search_problem_strips": [], "delta_bic": -80.3, "threshold": 30.0, "steps": []}}
    (tmp_path / "results" / "diagnosis.json").write_text(json.dumps(diagnosis), encoding="utf-8")
    text = "".join(diagnosis_section(tmp_path, Comparison(str(tmp_path), "variants.toml", "S4", ["02"], [])).parts)
    assert "Problem strips: 02 (the attribution&#x27;s; the search&#x27;s own model had none)." in text
