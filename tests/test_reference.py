"""The fast solvers against the committed traced reference points (tests/data, regenerated
by tests/data/make_reference.py from the slow oracle)."""
import json
import os

import numpy as np
import pytest

from catadioptric import CatadioptricCamera

DATA = json.load(open(os.path.join(os.path.dirname(__file__), "data", "reference_points.json")))
CAMS = {name: CatadioptricCamera.from_dict(d) for name, d in DATA["rigs"].items()}


def _check(ours_pts, ours_flags, ref, L):
    ours = [(p, f) for p, f in zip(ours_pts, ours_flags) if np.all(np.isfinite(p))]
    assert len(ours) == len(ref), (ours, ref)
    for e in ref:
        d = [np.linalg.norm(p - np.array(e["r"])) for p, _ in ours]
        k = int(np.argmin(d))
        assert d[k] <= 1e-9 * L
        assert bool(ours[k][1]) == e["valid"]


@pytest.mark.parametrize("rig", sorted(CAMS))
def test_vanishing_points_match_reference(rig):
    cam = CAMS[rig]
    cases = [c for c in DATA["cases"] if c["rig"] == rig and c["kind"] == "vanishing"]
    vp = cam.vanishing_points(np.array([c["target"] for c in cases]), which="both")
    for i, c in enumerate(cases):
        plus = vp.sign[i] > 0
        _check(vp.mirror_points[i][plus], vp.visible[i][plus], c["plus"], cam.mirror.scale)
        minus = vp.sign[i] < 0
        _check(vp.mirror_points[i][minus], vp.visible[i][minus], c["minus"], cam.mirror.scale)


@pytest.mark.parametrize("rig", sorted(CAMS))
def test_projection_matches_reference(rig):
    cam = CAMS[rig]
    cases = [c for c in DATA["cases"] if c["rig"] == rig and c["kind"] == "point"]
    pr = cam.project(np.array([c["target"] for c in cases]))
    for i, c in enumerate(cases):
        _check(pr.mirror_points[i], pr.valid[i], c["plus"], cam.mirror.scale)
