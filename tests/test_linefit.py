"""3-D lines from one non-central image, families of parallel lines, vanishing points from curves.

Synthetic data: points of a 3-D segment projected exactly (``cam.project``), kept where
valid and on the image, plus Gaussian pixel noise. Single-line reconstruction from one
image is badly conditioned on these rigs (docs/linefit.md): the noise levels of the
single-line statistical tests are scaled per rig (``UNIT``) so that the estimator is in
its linear regime; family and vanishing-point tests use 1 px.
"""
from functools import lru_cache

import numpy as np
import pytest

import catadioptric as cd
from catadioptric.lines import pluecker, segment_image
from catadioptric.linefit import (REFERENCE_FAMILIES, REFERENCE_SEGMENTS, direction_from_planes, family_pixels,
                                  fit_interpretation_plane, fit_line, fit_parallel_lines, image_distances,
                                  line_candidates, project_with_jacobian, segment_pixels,
                                  vanishing_points_from_curves)
from catadioptric.rigs import preset

# a well-conditioned segment per rig (close to the mirror, long) and the pixel noise "unit" that puts the
# fitted direction's standard error near 0.4 degrees (the rigs differ by two orders of magnitude); the
# same scenes as the tables of docs/linefit.md
SEGMENTS = {name: seg for name, (seg, unit) in REFERENCE_SEGMENTS.items()}
UNIT = {name: unit for name, (seg, unit) in REFERENCE_SEGMENTS.items()}
RIGS = list(SEGMENTS)


@lru_cache(maxsize=None)
def _cam(name):
    return preset(name)


@lru_cache(maxsize=None)
def _clean(name, n=100):
    a, b = (np.array(v) for v in SEGMENTS[name])
    uv, pts = segment_pixels(_cam(name), a, b, n)
    return uv, pts, a, b


def _angle(s, t):
    return float(np.arccos(np.clip(abs(s @ t) / np.linalg.norm(s) / np.linalg.norm(t), -1.0, 1.0)))


def _line_distance(point, direction, x):
    """Distance from point x to the line."""
    return float(np.linalg.norm(np.cross(x - point, direction)))


# ----------------------------------------------------------------------------- building blocks
@pytest.mark.parametrize("name", ["hyperboloid_9pct", "sphere", "ellipsoid", "paraboloid"])
def test_projection_jacobian_matches_finite_differences(name):
    cam = preset(name)
    rays = cam.backproject(cam.pinhole.pixel_grid(60).reshape(-1, 2))
    rng = np.random.default_rng(1)
    P = (rays.origins + rng.uniform(0.1, 2.0, len(rays.valid))[:, None] * rays.directions)[rays.valid]
    uv, G, vis = project_with_jacobian(cam, P, cam.pixels_of_mirror_points(rays.origins[rays.valid]))
    assert vis.all()
    h = 1e-6
    for k in range(3):
        e = np.zeros(3)
        e[k] = h
        fd = (project_with_jacobian(cam, P + e, uv)[0] - project_with_jacobian(cam, P - e, uv)[0]) / (2 * h)
        assert np.max(np.linalg.norm(fd - G[:, :, k], axis=-1) / np.linalg.norm(G, axis=(1, 2))) < 1e-6


@pytest.mark.parametrize("name", ["hyperboloid_9pct", "sphere", "ellipsoid", "paraboloid"])
def test_compiled_projection_jacobian_is_the_bordered_system_solved_whole(name):
    """The compiled block elimination (a cofactor inverse of the 3 x 3 block) and the whole bordered
    4 x 4 system solved by a pseudo-inverse (its fallback where the block is singular) give the same
    derivative: they differ by the rounding of the two solves (the block's condition number times
    the machine epsilon, below 1e-9 of the derivative's size on these rigs' pixels)."""
    from catadioptric.linefit.jacobian import _bordered_jacobian, _uv_jacobian

    cam = preset(name)
    rays = cam.backproject(cam.pinhole.pixel_grid(40).reshape(-1, 2))
    rng = np.random.default_rng(2)
    P = (rays.origins + rng.uniform(0.1, 30.0, len(rays.valid))[:, None] * rays.directions)[rays.valid]
    r = rays.origins[rays.valid]
    G, B = _uv_jacobian(cam, r, P), _bordered_jacobian(cam, r, P)
    assert np.max(np.abs(G - B).max(axis=(1, 2)) / np.abs(G).max(axis=(1, 2))) < 1e-9


@pytest.mark.parametrize("name", RIGS + ["sphere_axial"])
def test_linear_candidates_hold_the_line_and_the_axis_of_axial_rigs(name):
    cam = _cam(name) if name in SEGMENTS else preset(name)
    a, b = (np.array(v) for v in SEGMENTS.get(name, SEGMENTS["sphere"]))
    uv, pts = segment_pixels(cam, a, b, 30)
    L = line_candidates(cam, uv)
    s = (b - a) / np.linalg.norm(b - a)
    true = np.concatenate([s, np.cross(a, s)])
    dist = np.min(np.minimum(np.linalg.norm(L - true, axis=1), np.linalg.norm(L + true, axis=1)))
    assert dist < 1e-8
    # every ray of a sphere rig meets the line through the camera and the sphere's centre (the
    # mirror axis when the camera is on it): a second exact solution of the linear system
    if cam.mirror.kind == "sphere":
        centre = np.array([0.0, 0.0, cam.mirror.center_z])
        t = cam.center - centre
        t /= np.linalg.norm(t)
        axis = np.concatenate([t, np.cross(centre, t)])
        d_axis = np.min(np.minimum(np.linalg.norm(L - axis, axis=1), np.linalg.norm(L + axis, axis=1)))
        assert d_axis < 1e-6


def test_image_distances_measure_pixel_offsets_from_the_curve():
    cam = _cam("sphere")
    uv, pts, a, b = _clean("sphere", 40)
    s = (b - a) / np.linalg.norm(b - a)
    d0, lam = image_distances(cam, a, s, uv)
    assert np.max(d0[2:-2]) < 1e-6
    assert np.allclose(a + lam[:, None] * s, pts, atol=1e-6)
    # shift interior pixels by 2 px across the curve's local tangent
    tang = np.gradient(uv, axis=0)
    nrm = np.stack([-tang[:, 1], tang[:, 0]], axis=1)
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    d2, _ = image_distances(cam, a, s, uv + 2.0 * nrm)
    assert np.allclose(d2[3:-3], 2.0, atol=0.05)


# ----------------------------------------------------------------------------- single lines
@pytest.mark.parametrize("name", RIGS + ["sphere_axial"])
def test_exact_pixels_give_the_exact_line(name):
    cam = _cam(name) if name in SEGMENTS else preset(name)
    a, b = (np.array(v) for v in SEGMENTS.get(name, SEGMENTS["sphere"]))
    uv, pts = segment_pixels(cam, a, b, 60)
    corners = np.array([[0.0, 0.0], [cam.pinhole.width - 1.0, 0.0]])  # pixels that miss the mirror
    f = fit_line(cam, np.concatenate([uv, corners]))
    assert not f.inliers[-2:].any() and np.isnan(f.depths[-2:]).all() and np.isinf(f.distances[-2:]).all()
    f = fit_line(cam, uv)
    s = (b - a) / np.linalg.norm(b - a)
    assert f.direction @ s > 0  # oriented from the first pixel's point to the last one's
    assert _angle(f.direction, s) < 1e-6
    assert _line_distance(f.point, f.direction, a) < 1e-6
    assert np.linalg.norm(f.moment - np.cross(a, s)) < 1e-6
    assert f.inliers.all() and f.rms < 1e-6
    assert np.allclose(f.points, pts, atol=1e-6)
    assert abs(f.point @ f.direction) < 1e-12  # the point of the line nearest the origin


@pytest.mark.parametrize("name", ["sphere", "hyperboloid_9pct"])
def test_fit_on_the_traced_curve_of_catadioptric_lines(name):
    """Pixels evenly spaced along the exact curve traced by catadioptric.lines (not uniform in depth)."""
    cam = _cam(name)
    a, b = (np.array(v) for v in SEGMENTS[name])
    uv = np.concatenate([p.uv for img in segment_image(cam, a, b, max_step_px=2.0) for p in img.pieces])
    uv = uv[:: max(1, len(uv) // 80)]
    f = fit_line(cam, uv)
    assert np.linalg.norm(f.pluecker - pluecker(a, b - a)) < 1e-6
    assert f.rms < 1e-6


def test_line_coplanar_with_the_axis_is_reported_as_unconstrained():
    """An axial rig sees a line in a plane through its axis only through that plane (every line of
    the plane meets every ray of the plane): the fit matches the pixels, the covariance says so."""
    cam = preset("sphere_axial")
    a, b = np.array([0.15, 0.02, -0.3]), np.array([0.15, 0.02, 0.2])  # parallel to the axis
    uv, _ = segment_pixels(cam, a, b, 40)
    f = fit_line(cam, uv + np.random.default_rng(0).normal(0.0, 0.2, uv.shape), ransac=False)
    assert f.rms < 0.5
    assert f.direction_std > 1.0  # radians: unconstrained, not the 0 of a pseudo-inverse
    tilted = fit_line(cam, segment_pixels(cam, a + [0, 0.05, 0], b - [0, 0.05, 0], 40)[0])
    assert tilted.direction_std < 1e-6


def _single_errors(name, sigma, seeds, **kw):
    uv, pts, a, b = _clean(name)
    s = (b - a) / np.linalg.norm(b - a)
    mid = 0.5 * (a + b)
    ang, pos, pred = [], [], []
    for seed in seeds:
        noisy = uv + np.random.default_rng(seed).normal(0.0, sigma, uv.shape)
        f = fit_line(_cam(name), noisy, **kw)
        ang.append(_angle(f.direction, s))
        pos.append(_line_distance(f.point, f.direction, mid))
        pred.append(f.direction_std)
    return np.array(ang), np.array(pos), np.array(pred)


@pytest.mark.parametrize("name", RIGS)
def test_errors_grow_linearly_with_pixel_noise(name):
    """sigma = UNIT x (0.25, 0.5, 1, 2): median direction and position errors over 6 seeds."""
    levels = [0.25, 0.5, 1.0, 2.0]
    med_a, med_p = [], []
    for k in levels:
        ang, pos, pred = _single_errors(name, k * UNIT[name], range(6), ransac=False, loss="linear")
        med_a.append(np.median(ang))
        med_p.append(np.median(pos))
    med_a, med_p = np.array(med_a), np.array(med_p)
    assert np.all(np.diff(med_a) > 0) and np.all(np.diff(med_p) > 0)
    assert 2.0 < med_a[3] / med_a[1] < 8.0
    assert 2.0 < med_p[3] / med_p[1] < 8.0
    assert med_a[2] < np.radians(1.5)  # the line is recovered at the unit noise


def test_direction_covariance_matches_monte_carlo():
    name = "hyperboloid_9pct"
    uv, pts, a, b = _clean(name, 60)
    s = (b - a) / np.linalg.norm(b - a)
    m_true = np.cross(a, s)
    rng = np.random.default_rng(11)
    ds, dm, cov_s, cov_m = [], [], [], []
    for _ in range(200):
        f = fit_line(_cam(name), uv + rng.normal(0.0, UNIT[name], uv.shape), ransac=False, loss="linear")
        ds.append(f.direction - s)
        dm.append(f.moment - m_true)
        cov_s.append(f.direction_cov)
        cov_m.append(f.moment_cov)
    mc_s = np.trace(np.cov(np.array(ds).T))
    mc_m = np.trace(np.cov(np.array(dm).T))
    assert abs(np.trace(np.mean(cov_s, axis=0)) / mc_s - 1) < 0.3
    assert abs(np.trace(np.mean(cov_m, axis=0)) / mc_m - 1) < 0.3
    # the direction covariance is tangent to the unit sphere
    assert abs(s @ np.mean(cov_s, axis=0) @ s) < 1e-3 * mc_s


def test_given_pixel_sigma_scales_the_covariance():
    uv, pts, a, b = _clean("sphere")
    noisy = uv + np.random.default_rng(2).normal(0.0, 0.3, uv.shape)
    f1 = fit_line(_cam("sphere"), noisy, ransac=False, loss="linear", pixel_sigma=1.0)
    f2 = fit_line(_cam("sphere"), noisy, ransac=False, loss="linear", pixel_sigma=2.0)
    assert f1.sigma == 1.0
    assert np.allclose(f2.direction_cov, 4.0 * f1.direction_cov)
    f3 = fit_line(_cam("sphere"), noisy, ransac=False, loss="linear")
    assert 0.2 < f3.sigma < 0.4  # estimated from the residuals


def test_noise_estimate_and_inliers_follow_the_pixel_noise():
    """Estimated from the residuals (no pixel_sigma), the noise comes out at the noise added and the
    3.5-sigma polish keeps about every pixel: the distance to a fitted curve is a 1-D error (half-normal
    median 0.674 sigma). Taken for a 2-D one (median 1.18 sigma), the threshold fell to 2 sigma, 5 %
    of the good pixels were dropped and the noise came out 12 % low."""
    uv, pts, a, b = _clean("sphere", 400)
    sig, kept = [], []
    for seed in range(4):
        noisy = uv + np.random.default_rng(seed).normal(0.0, 0.3, uv.shape)
        f = fit_line(_cam("sphere"), noisy, f_scale=0.05, seed=seed)  # the loss scale below the noise
        sig.append(f.sigma)
        kept.append(f.inliers.mean())
    assert 0.95 < np.mean(sig) / 0.3 < 1.05
    assert np.mean(kept) > 0.99


def _with_outliers(name, sigma, frac, seed):
    """Replace a fraction of the pixels by strays spread over the part of the image that sees the world."""
    uv, pts, a, b = _clean(name)
    cam = _cam(name)
    rng = np.random.default_rng(seed)
    noisy = uv + rng.normal(0.0, sigma, uv.shape)
    bad = rng.random(len(uv)) < frac
    cand = rng.uniform([0, 0], [cam.pinhole.width - 1, cam.pinhole.height - 1], (20 * len(uv), 2))
    cand = cand[cam.backproject(cand).valid]
    noisy[bad] = cand[: bad.sum()]
    return noisy, bad, a, b


def test_twenty_percent_outliers_do_not_break_the_fit():
    name = "sphere"
    sigma = 0.5 * UNIT[name]
    for seed in (5, 6):
        noisy, bad, a, b = _with_outliers(name, sigma, 0.2, seed)
        assert 0.12 < bad.mean() < 0.3
        s = (b - a) / np.linalg.norm(b - a)
        f = fit_line(_cam(name), noisy, f_scale=sigma, seed=seed)  # RANSAC + soft_l1 + polish on the inliers
        clean = fit_line(_cam(name), noisy[~bad], f_scale=sigma)
        assert np.mean(f.inliers[~bad]) > 0.95
        assert np.mean(f.inliers[bad]) < 0.05
        assert _angle(f.direction, s) < max(2 * _angle(clean.direction, s), np.radians(0.5))
        assert f.rms < 2 * sigma
        # plain least squares over every pixel is thrown off (the test can fail)
        naive = fit_line(_cam(name), noisy, ransac=False, loss="linear", inlier_threshold=1e6)
        assert _angle(naive.direction, s) > 5 * max(_angle(f.direction, s), np.radians(0.1))


def test_finite_difference_jacobian_gives_the_same_fit():
    uv, pts, a, b = _clean("ellipsoid", 40)
    noisy = uv + np.random.default_rng(4).normal(0.0, UNIT["ellipsoid"], uv.shape)
    f1 = fit_line(_cam("ellipsoid"), noisy, ransac=False, loss="linear")
    f2 = fit_line(_cam("ellipsoid"), noisy, ransac=False, loss="linear", jac="2-point")
    assert _angle(f1.direction, f2.direction) < 0.05 * f1.direction_std
    assert abs(f1.rms - f2.rms) < 1e-6 * f1.rms


# ----------------------------------------------------------------------------- families
FAMILIES = REFERENCE_FAMILIES


@lru_cache(maxsize=None)
def _family_scene(name):
    return family_pixels(_cam(name), *FAMILIES[name])


@pytest.mark.parametrize("name", RIGS)
def test_family_exact_at_zero_noise(name):
    s, sets, qs = _family_scene(name)
    assert len(sets) >= 3
    fam = fit_parallel_lines(_cam(name), sets)
    assert _angle(fam.direction, s) < 1e-6
    for q, p in zip(qs, fam.points):
        assert _line_distance(p, fam.direction, q) < 1e-6
    assert fam.n_lines == len(sets) and fam.rms < 1e-6


def test_family_fit_beats_single_fits_on_the_direction():
    name = "hyperboloid_9pct"
    cam = _cam(name)
    s, sets, _ = _family_scene(name)
    fam_err, single_err = [], []
    for seed in range(3):
        rng = np.random.default_rng(seed)
        noisy = [u + rng.normal(0.0, 1.0, u.shape) for u in sets]
        fam = fit_parallel_lines(cam, noisy)
        fam_err.append(_angle(fam.direction, s))
        single_err += [_angle(fit_line(cam, u).direction, s) for u in noisy[:2]]
        assert fam.direction_std < np.radians(1.0)
    assert np.median(fam_err) < np.radians(0.5)
    assert np.median(fam_err) < 0.2 * np.median(single_err)


@pytest.mark.parametrize("name", RIGS)
def test_vanishing_points_from_curves_match_the_true_ones(name):
    cam = _cam(name)
    s, sets, _ = _family_scene(name)
    rng = np.random.default_rng(21)
    noisy = [u + rng.normal(0.0, 1.0, u.shape) for u in sets]
    res = vanishing_points_from_curves(cam, noisy)
    assert res.direction @ s > 0  # oriented toward the far ends of the curves
    assert _angle(res.direction, s) < np.radians(1.0)
    true = cam.vanishing_points(s, which="both")
    obs = res.observable()
    assert len(obs) >= 1
    vp_pixel = np.array(FAMILIES[name][0], dtype=float)
    assert np.min(np.linalg.norm(res.uv[obs][res.sign[obs] > 0] - vp_pixel, axis=-1)) < 3.0
    for k in obs:
        same = (true.sign == res.sign[k]) & true.visible
        err = np.min(np.linalg.norm(true.uv[same] - res.uv[k], axis=-1))
        assert err < 3.0
        sd = np.sqrt(np.trace(res.uv_cov[k]))
        assert 0 < sd < 5.0 and err < 4 * sd + 0.1
        assert np.isfinite(res.spread_max[k]) and res.spread_rms[k] <= res.spread_max[k]
    assert res.individual_uv.shape == (len(sets),) + res.uv.shape
    assert len(res.individual) == len(sets)


# ----------------------------------------------------------------------------- central cameras
def test_central_camera_gives_only_the_interpretation_plane():
    cam = preset("hyperboloid_central")
    V = cam.viewpoint
    rays = cam.backproject(np.array([[150.0, 240.0], [470.0, 250.0]]))
    s = cam.backproject(np.array([330.0, 60.0])).directions
    normals, covs = [], []
    rng = np.random.default_rng(3)
    for d in rays.directions:
        q = V + 0.5 * d
        uv, _ = segment_pixels(cam, q - 0.3 * s, q + 3.0 * s, 50)
        with pytest.raises(cd.CatadioptricError, match=r"cam: the camera is central .* use fit_interpretation_plane"):
            fit_line(cam, uv)
        n_true = np.cross(q - V, s)
        n_true /= np.linalg.norm(n_true)
        exact = fit_interpretation_plane(cam, uv)
        assert _angle(exact.normal, n_true) < 1e-9 and np.allclose(exact.viewpoint, V)
        p = fit_interpretation_plane(cam, uv + rng.normal(0.0, 1.0, uv.shape))
        assert _angle(p.normal, n_true) < 5 * np.sqrt(np.trace(p.normal_cov))
        normals.append(p.normal)
        covs.append(p.normal_cov)
    with pytest.raises(cd.CatadioptricError, match=r"cam: the camera is central"):
        fit_parallel_lines(cam, [uv, uv])
    # two parallel lines: their direction is normal to both planes
    assert _angle(np.cross(*normals), s) < np.radians(1.0)
    s_fit, cov = direction_from_planes(normals, covs)
    assert _angle(s_fit, s) < 5 * np.sqrt(np.trace(cov)) and abs(s_fit @ cov @ s_fit) < 1e-12
    with pytest.raises(cd.CatadioptricError, match=r"cam: expected a central camera"):
        fit_interpretation_plane(_cam("sphere"), uv)


def test_planes_fitted_together_are_each_line_s_own():
    """``fit_interpretation_planes`` of a family's lines (a third of the pixels of every other line
    moved 10 px across it, one line too short), checked line by line against the model written out
    here: each normal is the fixed point of the reweighted eigenvector iterations on its own
    inliers (the smallest eigenvector of ``sum w_j d_j d_j^T``, ``w_j = 1 / |Jd_j^T n|^2``), the
    moved pixels are not inliers and the others are, the distances are ``|n . d_j| / |Jd_j^T
    n|``, the covariance ``E (A^T A)^-1 E^T sigma^2`` over the inliers; a line fitted alone
    (``fit_interpretation_plane``) is the same, with an int seed and with one Generator drawn
    from line after line; the short line is reported, not fitted."""
    from catadioptric.linefit import fit_interpretation_planes
    from catadioptric.linefit.planes import pixel_rays_with_jacobian

    cam = preset("hyperboloid_central")
    _, clean, _ = family_pixels(cam, *FAMILIES["hyperboloid_central"])
    rng = np.random.default_rng(5)
    sets = [u + rng.normal(0.0, 1.0, u.shape) for u in clean]
    sets.insert(1, sets[0][:2])
    clean.insert(1, clean[0][:2])
    moved = [np.zeros(len(u), dtype=bool) for u in sets]
    for i in range(0, len(sets), 2):  # 10 px across the curve (not where it jumps from one arc to another)
        step = np.linalg.norm(np.diff(clean[i], axis=0), axis=1)
        smooth = np.zeros(len(clean[i]), dtype=bool)
        smooth[1:-1] = (step[:-1] < 20.0) & (step[1:] < 20.0)
        moved[i][3:-3:3] = smooth[3:-3:3]
        tangent = np.gradient(clean[i], axis=0)
        across = np.stack([-tangent[:, 1], tangent[:, 0]], axis=1) / np.linalg.norm(tangent, axis=1, keepdims=True)
        sets[i][moved[i]] += 10.0 * across[moved[i]]
    for seed in (4, "generator"):
        make = (lambda: np.random.default_rng(9)) if seed == "generator" else (lambda: seed)
        fits, failures = fit_interpretation_planes(cam, sets, seed=make())
        assert set(fits) == set(range(len(sets))) - {1} and list(failures) == [1]
        assert failures[1] == "uv: expected at least 3 pixels, got 2"
        one_seed = make()
        for i, u in enumerate(sets):
            if i == 1:
                continue
            f = fits[i]
            rays = pixel_rays_with_jacobian(cam, u)
            assert rays.ok.all()
            np.testing.assert_array_equal(f.inliers, ~moved[i])
            d, Jd, inl = rays.d, rays.Jd, f.inliers
            jn = np.linalg.norm(np.einsum("mkj,k->mj", Jd, f.normal), axis=1)
            w = 1.0 / jn**2
            n_fix = np.linalg.eigh((d[inl] * w[inl, None]).T @ d[inl])[1][:, 0]
            assert _angle(n_fix, f.normal) < 1e-10
            dist = np.abs(d @ f.normal) / jn
            np.testing.assert_allclose(f.distances, dist, rtol=1e-10, atol=1e-12)
            assert f.rms == pytest.approx(np.sqrt(np.mean(dist[inl] ** 2)), rel=1e-10)
            sigma = np.sqrt(np.sum(dist[inl] ** 2) / (inl.sum() - 2))
            e1 = np.cross(f.normal, [1.0, 0.0, 0.0] if abs(f.normal[0]) < 0.8 else [0.0, 1.0, 0.0])
            e1 /= np.linalg.norm(e1)
            E = np.stack([e1, np.cross(f.normal, e1)], axis=1)
            A = (d[inl] @ E) / jn[inl, None]
            np.testing.assert_allclose(f.normal_cov, E @ np.linalg.inv(A.T @ A) @ E.T * sigma**2, rtol=1e-8,
                                       atol=1e-8 * np.abs(f.normal_cov).max())
            alone = fit_interpretation_plane(cam, u, seed=one_seed)
            assert np.array_equal(alone.inliers, f.inliers) and _angle(alone.normal, f.normal) < 1e-12


@pytest.mark.parametrize("name", ["hyperboloid_central", "ellipsoid_central"])
def test_central_vanishing_points_from_curves(name):
    cam = preset(name)
    vp_pixel = FAMILIES[name][0]
    s, sets, _ = family_pixels(cam, *FAMILIES[name])
    assert len(sets) >= 3
    rng = np.random.default_rng(8)
    res = vanishing_points_from_curves(cam, [u + rng.normal(0.0, 1.0, u.shape) for u in sets])
    assert res.family is None and len(res.individual) == len(sets)
    assert res.individual_uv.shape[0] == len(sets) * (len(sets) - 1) // 2
    assert res.direction @ s > 0 and _angle(res.direction, s) < np.radians(0.5)
    k = res.observable()[res.sign[res.observable()] > 0][0]
    err = np.linalg.norm(res.uv[k] - vp_pixel)
    assert err < 2.0 and err < 4 * np.sqrt(np.trace(res.uv_cov[k])) + 0.1
    with pytest.raises(cd.CatadioptricError, match=r"uv_sets: a central camera needs at least 2 curves"):
        vanishing_points_from_curves(cam, sets[:1])


# ----------------------------------------------------------------------------- bad input
def test_bad_input_is_named():
    cam = _cam("sphere")
    uv = _clean("sphere", 30)[0]
    E = cd.CatadioptricError
    with pytest.raises(E, match=r"uv: expected an array of shape \(\.\.\., 2\), got an array of shape \(30, 3\)"):
        fit_line(cam, np.zeros((30, 3)))
    with pytest.raises(E, match=r"uv: expected an array of shape \(M, 2\), got an array of shape \(2, 30, 2\)"):
        fit_line(cam, np.stack([uv, uv]))
    with pytest.raises(E, match=r"uv: expected at least 5 pixels, got 4"):
        fit_line(cam, uv[:4])
    with pytest.raises(E, match=r"uv: expected finite values, got nan at index \(3, 1\)"):
        bad = uv.copy()
        bad[3, 1] = np.nan
        fit_line(cam, bad)
    with pytest.raises(E, match=r"uv: expected at least 5 pixels that see the world through the mirror, got 0"):
        fit_line(cam, np.tile([[-0.4, -0.4]], (8, 1)))
    with pytest.raises(E, match=r"loss: expected one of \['linear', 'soft_l1'"):
        fit_line(cam, uv, loss="l1")
    with pytest.raises(E, match=r"f_scale: expected a positive number, got 0.0"):
        fit_line(cam, uv, f_scale=0)
    with pytest.raises(E, match=r"pixel_sigma: expected a positive number"):
        fit_line(cam, uv, pixel_sigma=-1)
    with pytest.raises(E, match=r"seed: expected an int, None or a numpy Generator, got str"):
        fit_line(cam, uv, seed="x")
    with pytest.raises(E, match=r"jac: expected 'analytic', '2-point' or '3-point', got 'cs'"):
        fit_line(cam, uv, jac="cs")
    with pytest.raises(E, match=r"max_trials: expected a positive integer, got 0"):
        fit_line(cam, uv, max_trials=0)
    with pytest.raises(E, match=r"cam: expected a CatadioptricCamera, got str"):
        fit_line("sphere", uv)
    with pytest.raises(E, match=r"uv_sets: expected a non-empty list of \(M_i, 2\) pixel arrays, got list of length 0"):
        fit_parallel_lines(cam, [])
    with pytest.raises(E, match=r"uv_sets\[1\]: expected at least 5 pixels, got 2"):
        fit_parallel_lines(cam, [uv, uv[:2]])
    with pytest.raises(E, match=r"direction: expected a non-zero vector"):
        image_distances(cam, [0, 0, 1.0], [0, 0, 0], uv)
    with pytest.raises(E, match=r"n: expected a positive integer, got 0"):
        segment_pixels(cam, [0, 0, 1.0], [1, 0, 1.0], 0)
    with pytest.raises(E, match=r"uv: keeps fewer than 3 inlier pixels"):
        scatter = np.random.default_rng(0).uniform(100, 500, (30, 2))
        fit_line(cam, scatter, f_scale=0.1, inlier_threshold=0.01, ransac=False)


@pytest.mark.parametrize("name", ["hyperboloid_central", "sphere"])
def test_pixel_rays_derivatives_are_central_differences_of_each_pixel_s_own_rays(name):
    """``pixels_with_rays`` back-projects each pixel and its four neighbours a quarter pixel away in one
    call: its rays and derivatives are, to the bit, those of back-projecting them one set at a time
    (pixels off the mirror included: NaN where they have no ray), for a batch of any shape."""
    from catadioptric.linefit.distances import pixels_with_rays

    cam = _cam(name)
    rng = np.random.default_rng(3)
    uv = rng.uniform([-20.0, -20.0], [cam.pinhole.width + 20.0, cam.pinhole.height + 20.0], size=(4, 50, 2))
    px, valid = pixels_with_rays(cam, uv)
    r = cam.backproject(uv)
    assert 0 < valid.sum() < valid.size and np.array_equal(valid, r.valid)
    np.testing.assert_array_equal(px.o, r.origins)
    np.testing.assert_array_equal(px.d, r.directions)
    for k in range(2):
        e = np.eye(2)[k] * 0.25
        rp, rm = cam.backproject(uv + e), cam.backproject(uv - e)
        np.testing.assert_array_equal(px.Jo[..., k], (rp.origins - rm.origins) / 0.5)
        np.testing.assert_array_equal(px.Jd[..., k], (rp.directions - rm.directions) / 0.5)


def test_planes_refined_together_are_each_line_s_own_to_the_bit():
    """``refine_planes`` over many lines sums, at each iteration, the rays of the lines still moving
    only: every line's normal is, to the bit, the one it gets refined alone (lines that converge at
    once beside lines that take many iterations; a ray outside the mask left out)."""
    from catadioptric.linefit.planes import pixel_rays_with_jacobian, refine_planes

    cam = _cam("hyperboloid_central")
    _, clean, _ = family_pixels(cam, *FAMILIES["hyperboloid_central"])
    rng = np.random.default_rng(11)
    sets = [u + rng.normal(0.0, s, u.shape) for u, s in zip(clean, np.linspace(0.0, 3.0, len(clean)))]
    rays = pixel_rays_with_jacobian(cam, np.concatenate(sets))
    line = np.repeat(np.arange(len(sets)), [len(u) for u in sets])
    mask = rays.ok & (rng.random(len(line)) > 0.1)
    together = refine_planes(rays, line, mask, len(sets))
    assert len(sets) >= 3 and np.all(np.isfinite(together))
    for g in range(len(sets)):
        m = line == g
        alone = refine_planes(rays.take(m), np.zeros(m.sum(), dtype=int), mask[m], 1)
        np.testing.assert_array_equal(together[g], alone[0])


def test_ransac_planes_draw_each_line_s_samples_as_written():
    """``_ransac_planes`` draws each line's pairs as the first two of each random order (argsort of
    ``rng.random((64, M))`` per round, a fresh Generator from an int seed per line), scores every
    hypothesis by ``sum min(d^2, thr^2)`` over the line's own rays and keeps the lowest:
    the model written out here gives the same normal, to the bit, for every line."""
    from catadioptric.linefit.central import _ransac_planes
    from catadioptric.linefit.planes import pixel_rays_with_jacobian, plane_distances

    cam = _cam("hyperboloid_central")
    _, clean, _ = family_pixels(cam, *FAMILIES["hyperboloid_central"])
    rng = np.random.default_rng(13)
    sets = [u + rng.normal(0.0, 1.0, u.shape) for u in clean]
    rays = pixel_rays_with_jacobian(cam, np.concatenate(sets))
    line = np.repeat(np.arange(len(sets)), [len(u) for u in sets])
    keep = rays.ok
    rays, line = rays.take(keep), line[keep]
    counts = np.bincount(line, minlength=len(sets))
    thr, trials = 3.0, 100
    best = _ransac_planes(rays, line, counts, 5, thr, trials)
    assert len(sets) >= 3 and np.all(np.isfinite(best))
    for g in range(len(sets)):
        own = rays.take(line == g)
        draw = np.random.default_rng(5)
        idx = np.concatenate([np.argsort(draw.random((64, counts[g])), axis=1)[:, :2] for _ in range(2)])
        hyp = np.cross(own.d[idx[:, 0]], own.d[idx[:, 1]])
        hyp /= np.linalg.norm(hyp, axis=1, keepdims=True)
        cost = np.sum(np.minimum(plane_distances(hyp, own) ** 2, thr**2), axis=1)
        np.testing.assert_array_equal(best[g], hyp[np.argmin(cost)])
