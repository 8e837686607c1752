"""Exact images of 3-D lines and segments."""
import numpy as np
import pytest

import catadioptric as cd
from catadioptric.lines import pluecker, pluecker_point_direction
from catadioptric.rigs import preset

from steps import max_step_excess


def _dist_to_polyline(pts, poly):
    a, b = poly[:-1], poly[1:]
    ab = b - a
    t = np.clip(np.einsum("pij,ij->pi", pts[:, None] - a[None], ab) / np.maximum(np.sum(ab * ab, 1), 1e-300), 0, 1)
    proj = a[None] + t[..., None] * ab[None]
    return np.min(np.linalg.norm(pts[:, None] - proj, axis=-1), axis=1)


@pytest.mark.parametrize("name", ["hyperboloid_9pct", "sphere", "ellipsoid", "paraboloid"])
def test_line_images_agree_with_forward_projection(name):
    cam = preset(name)
    rng = np.random.default_rng(1)
    q = rng.normal(size=(6, 3)) * 0.8
    s = rng.normal(size=(6, 3))
    images = cam.line_image(q, s)
    for i, im in enumerate(images):
        for p in im.pieces:
            # consecutive vertices at most 1 px apart on the image; every vertex is an exact image
            assert max_step_excess(p.uv, cam.pinhole.width, cam.pinhole.height) <= 1e-9
            assert np.allclose(cam.pixels_of_mirror_points(p.mirror_points), p.uv, atol=1e-9)
        # dense samples of the line project onto the traced curve, and nothing is missed
        lam = np.tan(np.linspace(-np.pi / 2 + 1e-4, np.pi / 2 - 1e-4, 4001))
        pr = cam.project(q[i] + lam[:, None] * s[i] / np.linalg.norm(s[i]))
        pts = pr.uv[pr.valid]
        if len(pts) == 0:
            assert not im.pieces
            continue
        allp = [p.uv for p in im.pieces if len(p.uv) > 1]
        d = np.min([_dist_to_polyline(pts, poly) for poly in allp], axis=0)
        assert np.max(d) < 0.05  # chord error of 1 px steps on smooth curves


def test_line_image_ends_at_its_vanishing_points():
    cam = preset("hyperboloid_9pct")
    s = np.array([0.3, -0.5, 0.2])
    q = np.array([0.5, 0.4, -0.3])
    im = cam.line_image(q, s)[0]
    vp = cam.vanishing_points(np.array([s, -s]))
    for row, sign in ((0, np.inf), (1, -np.inf)):
        if vp.valid[row, 0]:
            ends = [p for p in im.pieces if p.params[-1] == sign or p.params[0] == sign]
            assert ends
            end_uv = [p.uv[-1] if p.params[-1] == sign else p.uv[0] for p in ends]
            assert min(np.linalg.norm(u - vp.uv[row, 0]) for u in end_uv) < 1e-9
            assert np.allclose(im.vanishing_uv[row, 0], vp.uv[row, 0])


def test_a_line_seen_several_times():
    """Near the caustic of the off-focus ellipsoid a line has several image pieces."""
    cam = preset("ellipsoid")
    q = cam.mirror.foci[1] + np.array([-0.00218, -0.00271, 0.00045])  # a point seen twice
    assert cam.project(q).valid.sum() == 2
    for s in np.eye(3):
        im = cam.line_image(q, s)[0]
        assert len(im.pieces) >= 2
        # dense samples near the caustic (where the image moves fast) land on the traced pieces
        pr = cam.project(q + np.linspace(-0.05, 0.05, 20001)[:, None] * s)
        pts = pr.uv[pr.valid]
        d = np.min([_dist_to_polyline(pts, p.uv) for p in im.pieces if len(p.uv) > 1], axis=0)
        assert np.max(d) < 0.05


def test_segment_images_stay_within_the_segment():
    cam = preset("sphere")
    p0 = np.array([[1.0, 0.5, -0.2], [-0.5, 1.0, 0.3]])
    p1 = np.array([[1.0, -0.5, -0.2], [-0.5, -1.0, 0.8]])
    ims = cam.segment_image(p0, p1)
    for i, im in enumerate(ims):
        L = np.linalg.norm(p1[i] - p0[i])
        for p in im.pieces:
            assert np.all((p.params >= -1e-12) & (p.params <= L + 1e-12))


def test_pluecker_round_trip():
    rng = np.random.default_rng(0)
    q, s = rng.normal(size=(5, 3)), rng.normal(size=(5, 3))
    L = pluecker(q, s)
    assert np.allclose(np.sum(L[:, :3] * L[:, 3:], axis=1), 0)
    q0, s0 = pluecker_point_direction(L)
    assert np.allclose(s0, s / np.linalg.norm(s, axis=1, keepdims=True))
    assert np.allclose(np.linalg.norm(np.cross(q0 - q, s0), axis=1), 0)  # q0 lies on the line


def test_line_image_errors():
    cam = preset("sphere")
    with pytest.raises(cd.CatadioptricError, match=r"points, directions: expected the same number of lines, got 2 and 1"):
        cam.line_image(np.zeros((2, 3)), np.ones((1, 3)))
    with pytest.raises(cd.CatadioptricError, match=r"directions: expected non-zero vectors, got a zero vector at index 0"):
        cam.line_image(np.zeros((1, 3)), np.zeros((1, 3)))
    with pytest.raises(cd.CatadioptricError, match=r"p0, p1: expected distinct end points, got equal ones at index 0"):
        cam.segment_image(np.ones((1, 3)), np.ones((1, 3)))
