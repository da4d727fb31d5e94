"""Which stages of ``scangeo run`` can run on a project without points.csv: matching writes one when there are
images of several strips (or a reference); a single strip without a reference (an imported drone line without
GCPs) has nothing to match, and then nothing to clean, diagnose or compare."""
from __future__ import annotations

from types import SimpleNamespace

from scangeo.pipeline.stages import stage


def _ctx(tmp_path, strips: int, references=(), points: bool = False, images: bool = True):
    if points:
        (tmp_path / "points.csv").write_text("point,strip,line,pixel\n")
    project = SimpleNamespace(strips=[SimpleNamespace(id=str(k)) for k in range(strips)])
    return SimpleNamespace(root=tmp_path, project=project, settings=SimpleNamespace(references=tuple(references)),
                           images=lambda: [tmp_path / f"{k}.tif" for k in range(strips)] if images else [])


def test_matching_decides_whether_a_project_without_points_can_be_adjusted(tmp_path):
    two = _ctx(tmp_path, 2)
    assert stage("match").cannot_run(two) is None and stage("clean").cannot_run(two) is None
    one = _ctx(tmp_path, 1)
    assert "a single strip and no --reference" in stage("match").cannot_run(one)
    for name in ("clean", "diagnose", "compare"):
        assert "no points.csv" in stage(name).cannot_run(one)
    assert stage("rectify").cannot_run(one) is None
    with_reference = _ctx(tmp_path, 1, references=[tmp_path / "ortho.tif"])
    assert stage("match").cannot_run(with_reference) is None and stage("compare").cannot_run(with_reference) is None
    with_points = _ctx(tmp_path, 1, points=True)
    assert stage("compare").cannot_run(with_points) is None
