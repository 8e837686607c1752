"""The two-view refinement's linear algebra (catadioptric.pose.bundle): the reduced normal
equations, with every pixel's depth eliminated, against the dense system they stand for."""
import numpy as np

from catadioptric.pose._kernels import reduced_normal_equations


def _random_problem(rng, N=40, F=3, L=7):
    ny = 6 + 2 * F + 2 * L
    fam_of_line = rng.integers(0, F, L)
    owner = rng.integers(0, L, N)
    cols = np.empty((N, 10), dtype=np.int64)
    cols[:, :6] = np.arange(6)
    cols[:, 6] = 6 + 2 * fam_of_line[owner]
    cols[:, 7] = cols[:, 6] + 1
    cols[:, 8] = 6 + 2 * F + 2 * owner
    cols[:, 9] = cols[:, 8] + 1
    A = rng.normal(size=(N, 2, 10))
    b = rng.normal(size=(N, 2))
    e = rng.normal(size=(N, 2))
    w = rng.uniform(0.1, 1.0, N)
    w[::7] = 0.0  # outliers of the robust stage
    return A, b, e, w, cols, ny


def test_reduced_normal_equations_are_the_dense_schur_complement():
    """Dense Jacobian ``J = [Jy | Jmu]`` (2N rows; the depths' columns one per pixel), weights
    repeated on both rows of a pixel: ``S = Hyy - Hym Hmm_d^-1 Hmy``, ``g = gy - Hym Hmm_d^-1 gm``
    with the depths' diagonal damped by ``1 + lam``."""
    rng = np.random.default_rng(4)
    for lam in (0.0, 1e-3, 10.0):
        A, b, e, w, cols, ny = _random_problem(rng)
        N = len(A)
        J = np.zeros((2 * N, ny + N))
        for n in range(N):
            for k in range(2):
                np.add.at(J[2 * n + k], cols[n], A[n, k])
                J[2 * n + k, ny + n] = b[n, k]
        W = np.repeat(w, 2)
        H = J.T @ (W[:, None] * J)
        grad = J.T @ (W * e.reshape(-1))
        Hmm = np.diag(H[ny:, ny:]) * (1.0 + lam) + 1e-300
        assert np.allclose(H[ny:, ny:], np.diag(np.diag(H[ny:, ny:])))  # each depth alone
        S_ref = H[:ny, :ny] - (H[:ny, ny:] / Hmm) @ H[ny:, :ny]
        g_ref = grad[:ny] - (H[:ny, ny:] / Hmm) @ grad[ny:]
        S, g, Hym, gm, Hmm_d = reduced_normal_equations(A, b, e, w, lam, cols, ny)
        scale = np.abs(H).max()
        assert np.abs(S - S_ref).max() < 1e-12 * scale
        assert np.abs(g - g_ref).max() < 1e-12 * np.abs(grad).max()
        assert np.allclose(gm, grad[ny:], rtol=1e-13, atol=1e-15)
        assert np.allclose(Hmm_d, Hmm, rtol=1e-13)
        # the depths' back-substitution: the full dense step agrees with the reduced one
        D = H.copy()
        D[ny:, ny:] = np.diag(Hmm)
        D[:ny, :ny] += 1e-6 * np.eye(ny)
        full = np.linalg.solve(D, -np.r_[grad[:ny], grad[ny:]])
        dy = np.linalg.solve(S + 1e-6 * np.eye(ny), -g)
        dmu = -(gm + np.sum(Hym * dy[cols], axis=1)) / Hmm_d
        assert np.allclose(full[:ny], dy, rtol=1e-8, atol=1e-10)
        assert np.allclose(full[ny:], dmu, rtol=1e-8, atol=1e-10)


def test_non_finite_residuals_count_as_zero():
    rng = np.random.default_rng(5)
    A, b, e, w, cols, ny = _random_problem(rng)
    e2 = e.copy()
    e2[3] = np.nan
    e0 = e.copy()
    e0[3] = 0.0
    S1, g1, *_ = reduced_normal_equations(A, b, e2, w, 0.0, cols, ny)
    S0, g0, *_ = reduced_normal_equations(A, b, e0, w, 0.0, cols, ny)
    assert np.array_equal(S1, S0) and np.array_equal(g1, g0)


def test_lines_stay_outside_the_mirror():
    """A line's distance from c_A never falls below twice the mirror's size, at the start or after
    any step: a line started (or pushed) inside the mirror would have points that reflect nowhere
    and pixels without a gradient."""
    from catadioptric.pose.bundle import _Problem
    from catadioptric.rigs import preset

    cam = preset("hyperboloid")
    c = np.zeros(3)
    s = np.array([[1.0, 0.0, 0.0]])
    points = np.array([[0.0, 0.01, 0.0], [0.0, 4.0, 1.0]])  # 1 cm from the centre, and 4 m away
    uv = np.full((6, 2), 100.0)
    owner = np.array([0, 0, 0, 1, 1, 1])
    view = np.array([0, 0, 1, 0, 1, 1])
    pb = _Problem(cam, cam, s, points, [0, 0], uv, owner, view, (c, c), np.eye(3), np.array([3.0, 0.0, 0.0]))
    d_min = 2.0 * cam.mirror.scale
    y = pb.start()
    dist = lambda y: np.exp(y[5]) / y[7 + 2 * pb.F::2]  # each line's distance from c_A
    assert np.all(dist(y) >= d_min * (1 - 1e-12))
    assert abs(dist(y)[1] - np.hypot(4.0, 1.0)) < 1e-9  # a line outside is untouched
    dy = np.zeros(pb.ny)
    dy[7 + 2 * pb.F::2] = 1e6  # a step that would bring both lines to the centre
    _, y2, _ = pb.apply(np.eye(3), y, np.zeros(len(uv)), dy, np.zeros(len(uv)))
    assert np.all(dist(y2) >= d_min * (1 - 1e-12))
    assert np.allclose(dist(y2), d_min)
