"""The two-view refinement's first-order residuals (catadioptric.pose.two_view_rays): each pixel's
ray against its line, against the exact image distance and against their own derivative."""
import numpy as np
import pytest

from catadioptric.linefit import image_distances, segment_pixels
from catadioptric.pose.rotation import exp_rotation
from catadioptric.pose.two_view_rays import RayProblem
from catadioptric.rigs import preset


def _problem(name, uv_a, uv_b, a, s, R, t):
    """A one-line problem: the line through ``a`` along ``s`` (A's frame), pixels ``uv_a`` of A and
    ``uv_b`` of B, the pose ``x_B = R x_A + t``."""
    cam = preset(name)
    uv = np.concatenate([uv_a, uv_b])
    view = np.repeat([0, 1], [len(uv_a), len(uv_b)])
    c = np.zeros(3)
    return RayProblem(cam, cam, s[None], a[None], [0], uv, np.zeros(len(uv), int), view, (c, c), R, t)


def _line_pixels(name, n=40):
    """Exact pixels of a segment 4 m away in A and, moved by a pose, in B."""
    cam = preset(name)
    s = np.array([1.0, 0.2, 0.1]) / np.linalg.norm([1.0, 0.2, 0.1])
    a, b = np.array([0.5, 4.0, 1.0]) - 3.0 * s, np.array([0.5, 4.0, 1.0]) + 3.0 * s
    R, t = exp_rotation(np.array([0.02, -0.1, 0.05])), np.array([0.4, 0.1, 0.0])
    uv_a, _ = segment_pixels(cam, a, b, n)
    uv_b, _ = segment_pixels(cam, R @ a + t, R @ b + t, n)
    return uv_a, uv_b, a, s, R, t


@pytest.mark.parametrize("name", ["sphere", "hyperboloid"])
def test_the_residual_is_the_image_distance_to_first_order(name):
    """On its line's image a pixel's residual is zero (its ray meets the line); moved across the
    image by ``h`` pixels, the residual is ``h`` up to the curve's second order: the relative error
    falls in proportion to ``h`` (halving ``h`` halves it, within a factor 1.5 either way), and the
    exact distance (``image_distances``, Gauss-Newton on the depth) agrees with ``h`` to 5 %,
    as the test of that function asks."""
    uv_a, uv_b, a, s, R, t = _line_pixels(name)
    pb = _problem(name, uv_a, uv_b, a, s, R, t)
    e, _ = pb.residuals(R, pb.start(), np.zeros(pb.N))
    assert np.all(np.isfinite(e)) and np.max(np.abs(e)) < 1e-9, np.max(np.abs(e))
    tang = np.gradient(uv_a, axis=0)
    nrm = np.stack([-tang[:, 1], tang[:, 0]], axis=1) / np.linalg.norm(tang, axis=1, keepdims=True)
    inner = slice(3, -3)
    err = []
    for h in (4.0, 2.0, 1.0):
        moved = uv_a + h * nrm
        e_h, _ = _problem(name, moved, uv_b, a, s, R, t).residuals(R, pb.start(), np.zeros(pb.N))
        fo = np.abs(e_h[:len(uv_a), 0])[inner]
        exact, _ = image_distances(preset(name), a, s, moved)
        assert np.allclose(exact[inner], h, rtol=0.05)
        err.append(np.max(np.abs(fo / exact[inner] - 1.0)))
    assert err[0] < 0.1 and 2.0 / 1.5 < err[0] / err[1] < 2.0 * 1.5 and 2.0 / 1.5 < err[1] / err[2] < 2.0 * 1.5, err


@pytest.mark.parametrize("name", ["sphere", "hyperboloid"])
def test_the_jacobian_is_the_residuals_derivative(name):
    """Every column of the compiled Jacobian (pose, family direction, the line's angle and inverse
    distance, the scale; both views) against central differences of the residuals through
    ``apply``, at pixels 2 px off the line (where ``|g|``'s own move, the second term, counts):
    within 1e-6 of the column's largest entry (central differences of step 1e-6 err by about
    1e-10 here; a term left out errs by tenths)."""
    uv_a, uv_b, a, s, R, t = _line_pixels(name)
    rng = np.random.default_rng(5)
    pb = _problem(name, uv_a + rng.normal(0, 2, uv_a.shape), uv_b + rng.normal(0, 2, uv_b.shape), a, s, R, t)
    y = pb.start()
    mu = np.zeros(pb.N)
    e, state = pb.residuals(R, y, mu)
    A, b = pb.jacobian(R, y, mu, state)
    ok = np.isfinite(e[:, 0])
    assert np.all(b == 0) and np.all(A[:, 1] == 0) and np.all(A[~ok] == 0) and ok.mean() > 0.9
    for j in range(pb.ny):
        cols = pb.cols == j
        if not cols.any():
            continue
        analytic = np.sum(A[:, 0] * cols, axis=1)[ok]
        h = 1e-6
        num = []
        for sign in (1.0, -1.0):
            dy = np.zeros(pb.ny)
            dy[j] = sign * h
            R2, y2, _ = pb.apply(R, y, mu, dy, np.zeros(pb.N))
            num.append(pb.residuals(R2, y2, mu)[0][:, 0])
        num = ((num[0] - num[1]) / (2 * h))[ok]
        assert np.max(np.abs(num - analytic)) < 1e-6 * np.max(np.abs(analytic)), j
