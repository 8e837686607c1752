"""The translation direction of two central views from where lines meet (pose/central.py): the
cheirality test in angle, the meeting rays' covariance, and the twisted pair told apart."""
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from catadioptric.pose.central import _both_ahead, _cheirality_violation, _meeting_cov


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


@settings(max_examples=300, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_the_violation_is_zero_exactly_when_the_rays_meet_in_front_of_both(seed):
    rng = np.random.default_rng(seed)
    T = _unit(rng.normal(size=3))  # c_A - c_B
    X = rng.normal(size=3) * rng.uniform(0.2, 20.0)
    p, q = _unit(X - T), _unit(X)
    for sp, sq in ((1, 1), (1, -1), (-1, 1), (-1, -1)):
        v = _cheirality_violation(sp * p[None], sq * q[None], T[None])[0, 0]
        both, _ = _both_ahead(sp * p[None], sq * q[None], T[None])
        assert (v < 1e-9) == bool(both[0, 0]), (sp, sq, v)


@settings(max_examples=100, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_both_ahead_is_the_signs_of_the_least_squares_depths(seed):
    """The depths' signs without their division, against ``lam p + T = mu q`` solved in least squares."""
    rng = np.random.default_rng(seed)
    p, q, T = _unit(rng.normal(size=(50, 3))), _unit(rng.normal(size=(50, 3))), rng.normal(size=(7, 3))
    both, pq = _both_ahead(p, q, T)
    assert np.allclose(pq, np.sum(p * q, axis=1), rtol=0, atol=1e-15)
    for h in range(len(T)):
        for k in range(len(p)):
            (lam, mu), *_ = np.linalg.lstsq(np.stack([p[k], -q[k]], axis=1), -T[h], rcond=None)
            if min(abs(lam), abs(mu)) > 1e-9:
                assert both[h, k] == (lam > 0 and mu > 0), (h, k, lam, mu)


def test_the_twisted_pair_violates_by_the_rays_angles_from_the_baseline():
    """A half-turn about the baseline keeps every epipolar plane (the residuals cannot tell it) but
    puts the two rays on opposite sides of the baseline: the violation is the turn that brings
    both onto it, ``theta_p + theta_q`` (or its complement), which is what the noise is compared with."""
    T = np.array([1.0, 0.0, 0.0])
    X = np.array([30.0, 2.0, 0.5])  # a far point, 4 degrees off the baseline
    p, q = _unit(X - T), _unit(X)
    half_turn = np.diag([1.0, -1.0, -1.0])
    v = _cheirality_violation((half_turn @ p)[None], q[None], T[None])[0, 0]
    th_p, th_q = np.arccos(p @ T), np.arccos(q @ T)
    assert np.isclose(v, th_p + th_q) and v > np.radians(7.0)
    assert _cheirality_violation(p[None], q[None], T[None])[0, 0] == 0.0


def test_meeting_ray_covariance_matches_monte_carlo():
    rng = np.random.default_rng(4)
    n_i, n_j = _unit(np.array([0.1, 0.9, 0.3])), _unit(np.array([0.8, -0.2, 0.5]))
    C_i = np.diag([2.0, 1.0, 0.5]) * 1e-6
    C_j = np.diag([0.5, 3.0, 1.0]) * 1e-6
    x = _unit(np.cross(n_i, n_j))
    cov = _meeting_cov(x[None], n_i[None], C_i[None], n_j[None], C_j[None])[0]
    draws = _unit(np.cross(rng.multivariate_normal(n_i, C_i, 20000), rng.multivariate_normal(n_j, C_j, 20000)))
    mc = np.cov((draws - x).T)
    assert np.allclose(cov, mc, atol=0.05 * np.abs(cov).max())


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1), st.booleans())
def test_the_truncated_costs_test_cheirality_where_the_residual_passes_as_over_all(seed, weighted):
    """``truncated_residuals2`` looks at the violation only where a residual passes: its inliers and
    costs are those of the rule written out over every ray and hypothesis (residual within ``c2``
    and violation within the threshold, or three times each ray's own angle with weights)."""
    from catadioptric.pose.central import residual_weights, residuals2, truncated_residuals2

    rng = np.random.default_rng(seed)
    K, H = int(rng.integers(1, 40)), int(rng.integers(1, 30))
    p, q = _unit(rng.normal(size=(K, 3))), _unit(rng.normal(size=(K, 3)))
    A = _unit(np.cross(p, q))
    T = _unit(rng.normal(size=(H, 3)))
    thr, c2 = float(rng.uniform(0.01, 0.5)), 9.0
    W = ang = None
    if weighted:
        cov = np.eye(3)[None] * rng.uniform(1e-5, 1e-2, size=(K, 1, 1))
        W, ang = residual_weights(p, q, cov, cov, 0.01)
    r2, inl = truncated_residuals2(A, p, q, T, thr, c2, W=W, ang=ang)
    full_r2 = residuals2(A, T, thr, W)
    lim = thr if W is None else 3.0 * ang[None, :]
    expected = (full_r2 <= c2) & (_cheirality_violation(p, q, T) <= lim)
    assert np.array_equal(inl, expected)
    assert np.array_equal(r2, np.where(expected, full_r2, c2))


def test_the_crossing_fits_pairs_are_drawn_once_per_seed_and_rays():
    """The crossing fit's pairs of rays are the draws of its seed (distinct usable rays), kept for the
    next rotation candidate of the same rays: the same array, read-only; other rays or another seed
    draw anew."""
    from catadioptric.pose.central import _pair_samples

    idx = np.array([0, 2, 3, 5, 8, 9], dtype=np.intp)
    P = _pair_samples(7, 300, idx.tobytes())
    rng = np.random.default_rng(7)
    expected = np.array([rng.choice(idx, 2, replace=False) for _ in range(300)])
    assert np.array_equal(P, expected) and np.all(P[:, 0] != P[:, 1]) and np.isin(P, idx).all()
    assert _pair_samples(7, 300, idx.tobytes()) is P and not P.flags.writeable
    assert not np.array_equal(_pair_samples(8, 300, idx.tobytes()), P)
    assert np.isin(_pair_samples(7, 300, idx[1:].tobytes()), idx[1:]).all()
