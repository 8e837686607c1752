import numpy as np
import pytest

import catadioptric as cd
from catadioptric.lines import pluecker
from catadioptric.pose import (relative_rotation, rotation_angle_deg, rotation_from_directions,
                               rotation_with_sign_search, translation_from_lines)
from catadioptric.rigs import preset


def _rot(rng):
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return q * np.sign(np.linalg.det(q))


def test_procrustes_recovers_rotation_and_handles_two_directions():
    rng = np.random.default_rng(0)
    R = _rot(rng)
    a = rng.normal(size=(5, 3))
    assert np.allclose(rotation_from_directions(a, a @ R.T), R)
    assert np.allclose(rotation_from_directions(a[:2], a[:2] @ R.T), R)  # minimal case
    assert np.isclose(np.linalg.det(rotation_from_directions(a, a @ R.T)), 1)


def test_sign_search():
    rng = np.random.default_rng(1)
    R = _rot(rng)
    a = rng.normal(size=(4, 3))
    b = (a @ R.T) * np.array([1, -1, 1, -1])[:, None]
    R2, signs = rotation_with_sign_search(a, b)
    assert np.allclose(R2, R) and np.allclose(signs, [1, -1, 1, -1])
    assert rotation_angle_deg(relative_rotation(a, b) @ R.T) < 1e-6


def test_translation_from_lines_with_exact_pixels():
    """Pixels of two world lines seen by a non-central rig give back the rig's translation."""
    cam = preset("hyperboloid_9pct")
    rng = np.random.default_rng(2)
    R = _rot(rng)
    t = np.array([0.2, -0.1, 0.3])
    q_W = rng.normal(size=(2, 3)) * 2
    s_W = rng.normal(size=(2, 3))
    s_W /= np.linalg.norm(s_W, axis=1, keepdims=True)
    lam = np.linspace(-3, 3, 200)
    rays, idx = [], []
    for i in range(2):
        pts_M = (q_W[i] + lam[:, None] * s_W[i]) @ R.T + t
        pr = cam.project(pts_M)
        uv = pr.uv[pr.valid]
        r = cam.backproject(uv)
        rays.append(pluecker(r.origins, r.directions))
        idx.append(np.full(len(uv), i))
    t_est = translation_from_lines(R, pluecker(q_W, s_W), np.concatenate(rays), np.concatenate(idx))
    assert np.linalg.norm(t_est - t) < 1e-9


def test_pose_errors():
    with pytest.raises(cd.CatadioptricError, match=r"a: expected at least 2 directions, got 1"):
        rotation_from_directions(np.ones((1, 3)), np.ones((1, 3)))
    with pytest.raises(cd.CatadioptricError, match=r"a, b: expected the same number of directions, got 2 and 3"):
        rotation_from_directions(np.ones((2, 3)), np.ones((3, 3)))
    with pytest.raises(cd.CatadioptricError, match=r"ray_lines: expected at least 3 rays, got 2"):
        translation_from_lines(np.eye(3), np.ones((1, 6)), np.ones((2, 6)), [0, 0])
