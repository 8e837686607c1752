"""The relative-rotation experiment end to end: render a pair with Mitsuba, fit the families of
parallel lines in both views, recover the rotation between the views."""
import json
import os

import numpy as np
import pytest

from catadioptric.cli import main
from catadioptric.validate import relative_rotation as rr
from catadioptric.validate.views import line_pixels, load_dataset


@pytest.fixture(scope="module")
def pair(tmp_path_factory):
    out = str(tmp_path_factory.mktemp("pair") / "tiny_street")
    assert main(["render", "tiny_street", "--out", out, "--quality", "draft", "--no-progress"]) == 0
    return out


def test_relative_rotation_from_a_rendered_pair(pair, tmp_path):
    rep = str(tmp_path / "report")
    assert main(["validate", "relative-rotation", pair, "--out", rep, "--noise", "1.0"]) == 0
    res = json.load(open(os.path.join(rep, "report.json")))
    used = [f for f in res["families"] if f["used"]]
    assert len(used) >= 3
    assert res["angle_error_deg"] < 2.0  # the rotation between the views, from vanishing points
    R = np.array(res["R"])
    assert np.allclose(R @ R.T, np.eye(3), atol=1e-12)
    assert os.path.getsize(os.path.join(rep, "vanishing_points.png")) > 10_000
    assert "Reproduce:" in open(os.path.join(rep, "report.md")).read()


def test_line_pixels_are_the_ridge_of_each_line_band(pair):
    v = load_dataset(pair)[0]
    labels = [ln["label"] for ln in v.lines if ln["label"] > 0]
    counts = [(len(line_pixels(v, l, ridge=False)), len(line_pixels(v, l))) for l in labels]
    full, ridge = np.array(counts).T
    assert np.all(ridge <= full) and np.all((ridge > 0) == (full > 0))
    # every ridge pixel carries the line's label
    lab = labels[int(np.argmax(full))]
    uv = line_pixels(v, lab).astype(int)
    assert np.all(v.labels[uv[:, 1], uv[:, 0]] == lab)


def test_central_family_direction_of_exact_lines():
    """Three parallel lines seen by an exactly central rig: the planes meet along the direction."""
    from catadioptric.rigs import preset
    from catadioptric.unified import unified_from_central

    cam = preset("hyperboloid_central")
    uni = unified_from_central(cam)
    s = np.array([0.3, -0.2, 0.9])
    s /= np.linalg.norm(s)
    sets = []
    for q in ([1.0, 0.5, 0.0], [-0.8, 1.2, 0.3], [0.4, -1.5, -0.2]):
        lam = np.linspace(-2, 2, 400)
        pr = cam.project(np.array(q) + lam[:, None] * s)
        sets.append(pr.uv[pr.valid & pr.in_image])
    d, sig = rr.central_family_direction(uni, sets)
    assert min(np.linalg.norm(d - s), np.linalg.norm(d + s)) < 1e-9 and sig < 1e-9


def test_noise_sweep_grows_with_noise(tmp_path):
    from catadioptric.validate import noise_sweep as ns

    res = ns.run(rigs=["hyperboloid", "sphere"], trials=20, seed=1)
    for r in res["rigs"].values():
        assert r["vp_error_mm"][0] < 1e-9 and r["direction_error_deg"][0] < 1e-9 and r["rotation_error_deg"][0] < 1e-6
        assert r["vp_error_mm"][-1] > r["vp_error_mm"][1] > 0
        assert r["direction_error_deg"][-1] > r["direction_error_deg"][1] > 0
    assert "Reproduce" in ns.markdown(res, "cmd")
