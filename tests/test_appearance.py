"""What a line looks like (catadioptric.appearance, catadioptric.detect.appearance): the sides of a
detected step edge named by its plane, and lines of two views matched only where their brighter
sides agree under the candidate rotation (catadioptric.pose.matching, step 3)."""
import numpy as np
import pytest

from catadioptric._checks import CatadioptricError
from catadioptric.appearance import LineAppearance, contrasts_agree
from catadioptric.detect import detect_lines
from catadioptric.pose import ViewLines, rotation_angle_deg
from catadioptric.pose.families import fit_view_families
from catadioptric.pose.matching import family_matches, match_lines
from catadioptric.render.tracer import pixel_rays
from catadioptric.rigspec import load_rig

from test_lines_in_order import _board_views, _symmetric_truths

BRIGHT, DARK = 200.0, 60.0


def test_a_step_edges_sides_are_named_by_its_plane():
    """An image bright where the rays point to +y and dark elsewhere: the edge's plane is y = 0, and
    its bright side is the side of +y whatever the sign of the normal the detector fitted."""
    cam = load_rig("hyperboloid_central", width=320, height=240)
    rays = pixel_rays(cam)
    d = np.asarray(rays.directions)
    img = np.where(np.asarray(rays.valid), np.where(d[..., 1] > 0, BRIGHT, DARK), 0.0)
    det = detect_lines(np.repeat(img[..., None], 3, axis=2).round().astype(np.uint8), cam)
    y = np.array([0.0, 1.0, 0.0])
    on = [i for i in range(len(det)) if abs(det.normal[i] @ y) > 0.999 and len(det.uv[i]) > 50]
    assert on, "the edge of the plane y = 0 is detected"
    app = det.appearance
    for i in on:
        # the +y side is bright, measured against either sign of the normal
        assert app.contrast([i], [y])[0] > 0.8 * (BRIGHT - DARK)
        assert app.contrast([i], [-y])[0] < -0.8 * (BRIGHT - DARK)
        bright = 0 if det.normal[i] @ y > 0 else 1
        assert np.all(app.sides[i, bright] > BRIGHT - 10) and np.all(app.sides[i, 1 - bright] < DARK + 10)
    # the JSON summary carries the sides
    assert set(det.to_dict()["lines"][on[0]]["sides"]) == {"positive", "negative", "offset_px"}


def test_contrasts_agree_unless_both_are_strong_and_opposite():
    a = np.array([20.0, 20.0, 2.0, -20.0, np.nan])
    b = np.array([30.0, -30.0, -30.0, 3.0, -30.0])
    assert contrasts_agree(a, b, 5.0).tolist() == [True, False, True, True, True]


def _with_appearance(views, Rs, flip_b=False, seed=1):
    """The board's lines given sides: each 3-D line has a bright side, a direction ``w`` in the
    board's plane normal to the line (random per line, fixed in the world); in a view the side
    ``n . d > 0`` of a line with normal ``n`` is bright when ``n . (R w) > 0``. ``flip_b``: B's
    sides swapped (every line looks like its mirror image)."""
    rng = np.random.default_rng(seed)
    ws = []
    for k in range(18):
        w = np.array([0.0, 1.0, 0.0]) if k < 8 else np.array([1.0, 0.0, 0.0])  # rows: along x; columns: along y
        ws.append(w * rng.choice([-1.0, 1.0]))
    out = []
    for v, R, name in zip(views, Rs, "AB"):
        normals, sides = [], []
        for k, uv in enumerate(v.uv):
            r = v.cam.backproject(uv).directions
            n = np.linalg.svd(r)[2][-1]
            bright = (n @ (R @ ws[k]) > 0) != (flip_b and name == "B")
            normals.append(n)
            sides.append([[BRIGHT] * 3, [DARK] * 3] if bright else [[DARK] * 3, [BRIGHT] * 3])
        app = LineAppearance(np.array(normals), np.array(sides), np.full(len(normals), 3.0), 1.0)
        out.append(ViewLines(v.cam, v.uv, v.family, None, appearance=app))
    return out


def test_lines_whose_brighter_sides_differ_are_not_matched():
    """Under the board's true motion, lines with their true sides match as they do by geometry
    alone; with B's sides swapped (every line of B looks like the mirror image of A's), none does."""
    views, Rs = _board_views()
    truths = _symmetric_truths(*Rs)
    ea, _ = fit_view_families(views[0], exact=False)
    eb, _ = fit_view_families(views[1], exact=False)
    # the assignment that is the board's motion itself, not one of its symmetries (the sides of a
    # line turned over by a symmetry are swapped)
    m = min(family_matches(ea, eb), key=lambda m: rotation_angle_deg(m.R @ truths[0].T))
    assert rotation_angle_deg(m.R @ truths[0].T) < 0.5
    plain = match_lines(views[0], views[1], ea, eb, m)
    va, vb = _with_appearance(views, Rs)
    same = match_lines(va, vb, ea, eb, m)
    assert same.n_inliers >= plain.n_inliers >= 0.9 * 80
    assert all(a == b for a, b in same.pairs)  # line k of A is line k of B (_board_views)
    fa, fb = _with_appearance(views, Rs, flip_b=True)
    flipped = match_lines(fa, fb, ea, eb, m)
    # no line is matched to itself; what is matched is lines that agree by chance (half the wrong
    # pairs of a repeated pattern), and they find fewer of A's corners in B
    assert not any(a == b for a, b in flipped.pairs), flipped.pairs
    assert flipped.n_inliers < 0.5 * same.n_inliers and flipped.cost > same.cost, (flipped.n_inliers, same.n_inliers)


def test_the_answer_reports_what_the_geometry_alone_would_have_said():
    """The board without labels: its lines alone cannot tell the board's motion from its half-turns
    (the geometry alone ranks a symmetric answer first); lines with sides can, and the answer's
    evidence says both: the geometry alone's costs are those of the same views without sides."""
    from catadioptric.pose import relative_pose

    views, Rs = _board_views()
    truths = _symmetric_truths(*Rs)
    plain = relative_pose(*views)
    assert plain.evidence["appearance"] is False and plain.evidence["margin_geometry_alone"] is None
    res = relative_pose(*_with_appearance(views, Rs))
    ev = res.evidence
    assert ev["appearance"] is True and ev["margin"] == res.margin
    # the motion itself, not a symmetry, and decisive; by the geometry alone another answer was first
    assert rotation_angle_deg(res.R @ truths[0].T) < 0.5 and not res.ambiguous
    assert ev["margin_geometry_alone"] < 0 < ev["bar"] <= ev["margin"]
    # the geometry alone is the run without sides, assignment by assignment
    assert sorted(ev["cost_geometry_alone"]) == pytest.approx(sorted(c.cost for c in plain.candidates), rel=1e-12)
    assert min(rotation_angle_deg(plain.R @ T.T) for T in truths[1:]) < 0.5


def test_view_lines_refuse_an_appearance_of_another_length():
    views, _ = _board_views()
    v = views[0]
    app = LineAppearance(np.zeros((3, 3)), np.zeros((3, 2, 1)), np.zeros(3), 1.0)
    with pytest.raises(CatadioptricError, match=r"appearance: expected one row per line \(18\), got 3"):
        ViewLines(v.cam, v.uv, v.family, None, appearance=app)
