import numpy as np
import pytest

import catadioptric as cd
from catadioptric.lines import pluecker
from catadioptric.pose import (refine_rotation, rotation_angle_deg, rotation_from_directions, sign_candidates,
                               translation_from_lines)
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
    # huge and tiny vectors are directions like any other
    assert np.allclose(rotation_from_directions(a * 1e200, a @ R.T * 1e-200), R)


def test_refined_rotation_covariance_matches_monte_carlo():
    rng = np.random.default_rng(3)
    R = _rot(rng)
    a = rng.normal(size=(6, 3))
    a /= np.linalg.norm(a, axis=1, keepdims=True)
    sig = np.radians(0.5)
    P = np.eye(3)[None] - a[:, :, None] * a[:, None, :]
    C = sig**2 * P
    errs = []
    for _ in range(300):
        an = a + rng.normal(size=a.shape) * sig
        bn = a @ R.T + rng.normal(size=a.shape) * sig
        fit = refine_rotation(an, bn, C, np.array([R @ c @ R.T for c in C]), robust=False)
        w = fit.R @ R.T
        errs.append(0.5 * np.array([w[2, 1] - w[1, 2], w[0, 2] - w[2, 0], w[1, 0] - w[0, 1]]))
    mc = np.cov(np.array(errs).T)
    assert 0.7 < np.trace(mc) / np.trace(fit.cov) < 1.4


def test_a_family_fitted_far_off_cannot_pull_the_robust_rotation():
    rng = np.random.default_rng(4)
    R = _rot(rng)
    a = np.eye(3)[[0, 1, 2, 0]] + [[0, 0, 0], [0, 0, 0], [0, 0, 0], [0, 0.3, 0.1]]
    a /= np.linalg.norm(a, axis=1, keepdims=True)
    b = a @ R.T
    b[3] = np.array([0.2, 0.9, 0.4]) / np.linalg.norm([0.2, 0.9, 0.4])  # 40+ degrees off, claimed precise
    C = np.array([np.eye(3) * 1e-6] * 4)
    fit = refine_rotation(a, b, C, C)
    assert rotation_angle_deg(fit.R @ R.T) < 1e-3 and fit.weights[3] < 1e-3


def test_sign_candidates_of_an_orthogonal_triad_are_the_four_half_turns():
    rng = np.random.default_rng(1)
    R = _rot(rng)
    a = np.eye(3)
    C = np.array([np.eye(3) * 1e-8] * 3)
    cands = sign_candidates(a, a @ R.T, C, C)
    # identity pattern and the three half-turns fit exactly; the reflections do not
    assert len(cands) == 4
    angles = sorted(rotation_angle_deg(c.R @ R.T) for c in cands)
    assert angles[0] < 1e-6 and np.allclose(angles[1:], 180.0, atol=1e-6)
    # known signs: one candidate, nothing searched
    signs = np.array([1.0, -1.0, 1.0])
    one = sign_candidates(a, (a @ R.T) * signs[:, None], C, C, signs=signs)
    assert len(one) == 1 and rotation_angle_deg(one[0].R @ R.T) < 1e-6


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
    E = cd.CatadioptricError
    with pytest.raises(E, match=r"a: expected at least 2 directions, got 1"):
        rotation_from_directions(np.ones((1, 3)), np.ones((1, 3)))
    with pytest.raises(E, match=r"a, b: expected the same number of directions, got 2 and 3"):
        rotation_from_directions(np.ones((2, 3)), np.ones((3, 3)))
    with pytest.raises(E, match=r"a, b: expected two non-parallel directions, got parallel \(or antiparallel\)"):
        rotation_from_directions([[1, 0, 0], [-1, 0, 0]], [[1, 0, 0], [-1, 0, 0]])
    with pytest.raises(E, match=r"a: expected non-zero directions, got a zero vector at row 1"):
        rotation_from_directions([[1, 0, 0], [0, 0, 0], [0, 1, 0]], np.eye(3))
    with pytest.raises(E, match=r"weights: expected non-negative weights, got -1.0"):
        rotation_from_directions(np.eye(3), np.eye(3), [1, -1, 1])
    with pytest.raises(E, match=r"weights: expected 3 weights \(one per direction\), got 2"):
        rotation_from_directions(np.eye(3), np.eye(3), [1, 1])
    with pytest.raises(E, match=r"R: expected a rotation matrix"):
        rotation_angle_deg(np.diag([1.0, 1.0, -1.0]))
    with pytest.raises(E, match=r"ray_lines: expected at least 3 rays, got 2"):
        translation_from_lines(np.eye(3), np.ones((1, 6)), np.ones((2, 6)), [0, 0])
    with pytest.raises(E, match=r"signs: expected 3 values of \+1 or -1, got \[1.0, 0.0, 1.0\]"):
        sign_candidates(np.eye(3), np.eye(3), np.zeros((3, 3, 3)), np.zeros((3, 3, 3)), signs=[1, 0, 1])


def test_relative_translation_from_lines_both_ways():
    """The paper's Pluecker constraint both ways: lines known in each view's frame and the rays of the
    other view's pixels give t exactly (the linear start the paper proposes, Sec. 4.3)."""
    from catadioptric.pose import relative_translation_from_lines

    cam = preset("sphere")
    rng = np.random.default_rng(5)
    R = _rot(rng)
    t = np.array([1.5, -0.4, 0.2])
    q = rng.normal(size=(4, 3)) * 3 + [0, 0, 1]
    s = rng.normal(size=(4, 3))
    s /= np.linalg.norm(s, axis=1, keepdims=True)
    La = pluecker(q, s)
    Lb = pluecker(q @ R.T + t, s @ R.T)
    lam = np.linspace(-2, 2, 60)
    rays, owners = [], []
    for pose_R, pose_t in ((np.eye(3), np.zeros(3)), (R, t)):
        rr, oo = [], []
        for i in range(4):
            pr = cam.project((q[i] + lam[:, None] * s[i]) @ pose_R.T + pose_t)
            r = cam.backproject(pr.uv[pr.valid])
            rr.append(pluecker(r.origins, r.directions))
            oo.append(np.full(len(r.origins), i))
        rays.append(np.concatenate(rr))
        owners.append(np.concatenate(oo))
    t_est, res = relative_translation_from_lines(R, La, Lb, rays[0], owners[0], rays[1], owners[1])
    assert np.linalg.norm(t_est - t) < 1e-9 and np.nanmax(np.abs(res)) < 1e-9


def test_ray_depths_are_signed_distances_along_the_rays():
    from catadioptric.pose.translation import ray_depths

    s = np.array([0.0, 0.0, 1.0])
    q = np.array([2.0, 0.0, 0.0])  # the line x = 2, y = 0
    o = np.array([[0.0, 0.0, 0.0], [0.0, 1.0, 5.0], [0.0, 0.0, 0.0]])
    d = np.array([[3.0, 0.0, 0.0], [0.0, 0.0, 1.0], [-1.0, 0.0, 0.0]])  # not unit; parallel; away
    assert np.allclose(ray_depths(q, s, o, d), [2.0, 0.0, -2.0], atol=1e-15)


def test_triangulated_line_fits_the_rays_in_angle():
    """A line 2 m from view A, seen also from a view 64 m away nearly in line with it (a start
    whose baseline is far too long, the line nearly parallel to it: both views' planes nearly
    coincide), rays from origins spread over centimetres (a non-central rig) with 3 mrad of
    angular noise: weighed in angle, the line's offset as seen from A is at the level of the noise
    over the square root of the rays (0.47 mrad); weighed in metres (the far view's misses 32
    times larger, counted as much as the near view's) it is several times more."""
    from catadioptric.pose.translation import ray_depths, triangulate_line

    s = np.array([0.0, 0.0, 1.0])
    q_true = np.array([0.0, 2.0, 0.0])
    pts = q_true + np.linspace(-2.0, 2.0, 40)[:, None] * s
    off = {0: [], 1: []}
    for seed in range(40):
        rng = np.random.default_rng(seed)

        def rays(c):
            o = c + 0.03 * rng.normal(size=(len(pts), 3))
            d = pts - o
            d = d / np.linalg.norm(d, axis=1, keepdims=True) + 3e-3 * rng.normal(size=d.shape)
            return o, d / np.linalg.norm(d, axis=1, keepdims=True)

        (oa, da), (ob, db) = rays(np.zeros(3)), rays(np.array([6.0, 64.0, 0.0]))
        for it in off:
            q, well = triangulate_line(s, np.concatenate([oa, ob]), np.concatenate([da, db]), iters=it)
            assert well and np.median(ray_depths(q, s, oa, da)) > 0 and np.median(ray_depths(q, s, ob, db)) > 0
            off[it].append(abs(q[0] - q_true[0]) / np.linalg.norm(q_true))  # the angle at A, radians
    assert np.median(off[1]) < 0.6e-3 and np.median(off[0]) > 4 * np.median(off[1])


def test_lines_triangulated_at_once_are_each_line_s_least_squares():
    """``triangulate_lines`` of several lines with their rays interleaved: without reweighting, each
    line's point minimises the sum of its rays' squared distances to it (checked against a
    general least-squares solver over the two coordinates across the line); with it, each line's
    answer is that of ``triangulate_line`` on its own rays alone."""
    from scipy.optimize import least_squares

    from catadioptric.pose.translation import triangulate_line, triangulate_lines

    rng = np.random.default_rng(3)
    G, n = 4, 25
    s = rng.normal(size=(G, 3))
    s /= np.linalg.norm(s, axis=1, keepdims=True)
    line = rng.permutation(np.repeat(np.arange(G), n))
    o = rng.normal(size=(len(line), 3)) * 0.5
    pts = rng.normal(size=(G, 3))[line] * 3 + rng.normal(size=(len(line), 1)) * s[line]
    d = pts - o + 0.02 * rng.normal(size=o.shape)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    q0, well = triangulate_lines(s, o, d, line, iters=0)
    assert well.all() and np.allclose(np.sum(q0 * s, axis=1), 0.0, atol=1e-12)
    for g in range(G):
        m = line == g
        e1 = np.cross(s[g], [1.0, 0.0, 0.0])
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(s[g], e1)
        n_ = np.cross(d[m], s[g])

        def miss(xy):
            return np.sum((xy[0] * e1 + xy[1] * e2 - o[m]) * n_, axis=1) / np.linalg.norm(n_, axis=1)

        xy = least_squares(miss, np.zeros(2), xtol=1e-15, ftol=1e-15, gtol=1e-15).x
        assert np.linalg.norm(q0[g] - (xy[0] * e1 + xy[1] * e2)) < 1e-9 * np.linalg.norm(q0[g])
        q1, w1 = triangulate_line(s[g], o[m], d[m])
        assert w1 and np.allclose(triangulate_lines(s, o, d, line)[0][g], q1, rtol=0, atol=1e-12)
