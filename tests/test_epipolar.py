"""Rotation and translation direction refined together from the families' directions and the rays
where lines meet (catadioptric.pose.epipolar): exact on exact data, better than the directions
alone when the meeting rays are precise, and not pulled far by one wrong inlier."""
import numpy as np
import pytest

from catadioptric._checks import CatadioptricError
from catadioptric.pose import rotation_angle_deg
from catadioptric.pose.central import CrossingFit, MeetingRays
from catadioptric.pose.epipolar import refine_with_crossings
from catadioptric.pose.rotation import exp_rotation, refine_rotation


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _tangent_cov(x, sigma):
    """Isotropic covariance ``sigma^2`` on the plane normal to each unit row of ``x``."""
    return sigma**2 * (np.eye(3) - x[:, :, None] * x[:, None, :])


def _scene(seed, dir_noise=0.0, ray_noise=0.0, K=60):
    """Three families seen in both views and K meeting points; ``x_B = R x_A + T`` with both centres
    at the origins (a central camera), so the displacement between the centres is ``T``."""
    rng = np.random.default_rng(seed)
    R = exp_rotation(rng.normal(size=3) * 0.3)
    T = _unit(rng.normal(size=3)) * 3.0
    a = _unit(np.array([[1.0, 0.1, 0.0], [0.0, 1.0, 0.2], [0.1, 0.0, 1.0]]))
    b = a @ R.T
    ad = _unit(a + rng.normal(size=a.shape) * dir_noise)
    bd = _unit(b + rng.normal(size=b.shape) * dir_noise)
    X = rng.normal(size=(K, 3)) * 6.0
    X[:, 2] += 2.0
    xa = _unit(X)
    xb = _unit(X @ R.T + T)
    xa_n = _unit(xa + rng.normal(size=xa.shape) * ray_noise)
    xb_n = _unit(xb + rng.normal(size=xb.shape) * ray_noise)
    s_dir = max(dir_noise, 1e-6)
    s_ray = max(ray_noise, 1e-6)
    rays = MeetingRays(xa_n, xb_n, K, 1e-3, _tangent_cov(xa_n, s_ray), _tangent_cov(xb_n, s_ray))
    fit = CrossingFit(t=_unit(T + rng.normal(size=3) * 0.05), cov=np.eye(3) * 1e-4, cost=0.0, n_crossings=K,
                      n_inliers=K, n_lines=K, threshold_rad=3e-3, inliers=np.ones(K, dtype=bool))
    return ad, bd, _tangent_cov(ad, s_dir), _tangent_cov(bd, s_dir), rays, fit, R, _unit(T)


def test_exact_directions_and_rays_give_the_exact_pose():
    a, b, Ca, Cb, rays, fit, R, t = _scene(1)
    R0 = exp_rotation([0.004, -0.006, 0.003]) @ R
    res = refine_with_crossings(a, b, Ca, Cb, rays, fit, R0)
    assert np.radians(rotation_angle_deg(res.R @ R.T)) < 1e-9
    assert np.linalg.norm(res.t - t) < 1e-9
    assert res.n_inliers == 60 and res.cov.shape == (6, 6)


@pytest.mark.parametrize("seed", range(5))
def test_precise_meeting_rays_improve_on_the_directions_alone(seed):
    """Directions 1 degree off, meeting rays 0.05 degree off: the rotation is fixed by the rays."""
    a, b, Ca, Cb, rays, fit, R, _ = _scene(seed, dir_noise=np.radians(1.0), ray_noise=np.radians(0.05))
    alone = refine_rotation(a, b, Ca, Cb)
    res = refine_with_crossings(a, b, Ca, Cb, rays, fit, alone.R)
    assert rotation_angle_deg(res.R @ R.T) < 0.1 < rotation_angle_deg(alone.R @ R.T)
    # the covariance says so too
    assert np.trace(res.cov[:3, :3]) < np.trace(alone.cov)


def test_one_wrong_inlier_does_not_pull_the_rotation():
    a, b, Ca, Cb, rays, fit, R, _ = _scene(3, dir_noise=np.radians(0.2), ray_noise=np.radians(0.02))
    good = refine_with_crossings(a, b, Ca, Cb, rays, fit, R).R
    rays.xb[0] = _unit(rays.xb[0] + np.array([0.3, -0.2, 0.1]))  # 20 degrees off, still called an inlier
    bad = refine_with_crossings(a, b, Ca, Cb, rays, fit, R).R
    assert rotation_angle_deg(bad @ good.T) < 0.02


def test_it_needs_two_inliers_with_covariances():
    a, b, Ca, Cb, rays, fit, R, _ = _scene(2)
    fit.inliers[:] = False
    fit.inliers[0] = True
    with pytest.raises(CatadioptricError, match="two inlier meeting rays"):
        refine_with_crossings(a, b, Ca, Cb, rays, fit, R)
