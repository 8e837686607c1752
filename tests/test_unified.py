"""The unified central model: exact agreement with central rigs, its own identities, the line
conics, the OpenCV omnidir mapping and bad input."""
import os

import cv2
import numpy as np
import pytest

import catadioptric as cd
from catadioptric.rigs import preset
from catadioptric.unified import (UnifiedCamera, conic_from_plane_normal, fit_unified, unified_from_central)

CENTRAL = ["hyperboloid_central", "ellipsoid_central"]
DEPTHS = (1.0, 3.0, 10.0)


def _exact_samples(cam, step=1):
    uv = cam.pinhole.pixel_grid(step).reshape(-1, 2)
    rays = cam.backproject(uv)
    return uv, rays


def _conic_px(C, uv):
    """First-order (Sampson) distance in pixels of pixels ``uv (..., 2)`` from conics ``C (..., 3, 3)``."""
    h = np.concatenate([uv, np.ones(uv.shape[:-1] + (1,))], -1)
    Ch = np.einsum("...ij,...j->...i", C, h)
    val = np.abs(np.sum(h * Ch, -1))
    if np.linalg.matrix_rank(C.reshape(-1, 3, 3)[0], tol=1e-12) == 1:  # a double line l l^T (xi = 0)
        w, V = np.linalg.eigh(C)
        k = np.argmax(np.abs(w), axis=-1)
        line = np.take_along_axis(V, k[..., None, None], axis=-1)[..., 0]
        return np.abs(np.sum(line * h, -1)) / np.hypot(line[..., 0], line[..., 1])
    return val / (2 * np.hypot(Ch[..., 0], Ch[..., 1]))


def _angle(a, b):
    return np.arctan2(np.linalg.norm(np.cross(a, b), axis=-1), np.sum(a * b, axis=-1))


@pytest.mark.parametrize("name", CENTRAL)
def test_central_presets_agree_over_the_whole_image(name):
    """Every pixel of the 640x480 image: points at 1, 3, 10 m and at infinity along the exact ray
    project back onto the pixel to 1e-9 px; the model's lifting gives the exact ray; the pixels
    with a ray are the same."""
    cam = preset(name)
    assert cam.is_central
    u = unified_from_central(cam)
    assert u.is_pure  # the presets' optical axes lie along the mirror axis
    np.testing.assert_allclose(u.center, cam.viewpoint, atol=1e-15)
    uv, rays = _exact_samples(cam)
    ok = rays.valid
    assert ok.sum() > 50000
    for t in DEPTHS:
        pr = u.project(rays.origins[ok] + t * rays.directions[ok])
        assert pr.valid.all()
        assert np.max(np.linalg.norm(pr.uv - uv[ok], axis=-1)) < 1e-9
    pr = u.project_directions(rays.directions[ok])
    assert pr.valid.all() and np.max(np.linalg.norm(pr.uv - uv[ok], axis=-1)) < 1e-9
    back = u.backproject(uv)
    assert np.array_equal(back.valid, ok)
    assert np.max(_angle(back.directions[ok], rays.directions[ok])) < 1e-12
    # the exact reflected rays pass through the viewpoint
    v = cam.viewpoint - rays.origins[ok]
    assert np.max(np.linalg.norm(np.cross(v / np.linalg.norm(v, axis=-1, keepdims=True), rays.directions[ok]),
                                 axis=-1)) < 1e-12


@pytest.mark.parametrize("name", CENTRAL)
def test_central_presets_agree_with_exact_forward_projection(name):
    cam = preset(name)
    u = unified_from_central(cam)
    rng = np.random.default_rng(3)
    P = rng.normal(size=(4000, 3)) * 0.6
    ex = cam.project(P)
    un = u.project(P)
    seen = ex.valid.any(-1)
    assert seen.sum() > 300
    assert np.array_equal(seen, un.valid)
    assert np.all(ex.valid.sum(-1) <= 1)
    assert np.max(np.linalg.norm(ex.uv[seen, 0] - un.uv[seen], axis=-1)) < 1e-9


def test_eccentricity_closed_form():
    """xi = 2e / (1 + e^2) and |f_gen| = f_pin beta^2 / (alpha^2 + f^2) (docs/unified.md)."""
    for name, (a_across, c_along, kind) in {"hyperboloid_central": (0.03, 0.04, "h"),
                                             "ellipsoid_central": (0.04, 0.06, "e")}.items():
        cam = preset(name)
        u = unified_from_central(cam)
        f = np.hypot(a_across, c_along) if kind == "h" else np.sqrt(c_along**2 - a_across**2)
        e = f / c_along
        assert u.xi == pytest.approx(2 * e / (1 + e * e), rel=1e-14)
        fpin = cam.pinhole.K[0, 0]
        assert abs(u.K[0, 0]) == pytest.approx(fpin * a_across**2 / (c_along**2 + f * f), rel=1e-13)
        # a catadioptric image is a mirror image: det K < 0 with the right-handed sphere frame
        assert u.K[0, 0] > 0 and u.K[1, 1] < 0


@pytest.mark.parametrize("target, up", [((0.02, 0.01, 0.06), (0, 1, 0)), ((0.03, -0.02, 0.05), (0.3, 1, 0))])
@pytest.mark.parametrize("kind", ["hyperboloid", "ellipsoid"])
def test_tilted_pinhole_is_exact_with_R_tilt(kind, target, up):
    """A pinhole at the focus but not aimed along the axis (and with skew): exact with R_tilt != I."""
    if kind == "hyperboloid":
        m = cd.QuadricMirror.hyperboloid(0.03, 0.04, z_min=0.04, z_max=0.075)
        fov = 80.0
    else:
        m = cd.QuadricMirror.ellipsoid(0.04, 0.06, z_min=0.048, z_max=0.06)
        fov = 50.0
    base = cd.CatadioptricCamera.looking_at_mirror(m, cd.PinholeCamera.from_fov(200, 150, fov), m.foci[0],
                                                   target=target, up=up)
    K = base.pinhole.K.copy()
    K[0, 1] = 2.5
    K[1, 1] *= 1.07
    cam = cd.CatadioptricCamera(m, cd.PinholeCamera(K, 200, 150), base.center, base.R_cam_from_mirror)
    u = unified_from_central(cam)
    assert not u.is_pure
    uv, rays = _exact_samples(cam)
    ok = rays.valid
    assert ok.sum() > 1000
    for t in DEPTHS:
        pr = u.project(rays.origins[ok] + t * rays.directions[ok])
        assert pr.valid.all() and np.max(np.linalg.norm(pr.uv - uv[ok], axis=-1)) < 1e-9
    back = u.backproject(uv)
    assert np.array_equal(back.valid, ok)
    assert np.max(_angle(back.directions[ok], rays.directions[ok])) < 1e-12
    # the pure model cannot hold it: the tilt-free fit leaves a visible error
    fit = fit_unified(cam, step=6, tilt=False)
    assert fit.rms_px > 1e-3
    with pytest.raises(cd.CatadioptricError, match=r"R_tilt: OpenCV omnidir has no tilted pinhole"):
        u.to_omnidir()


def _random_unified(rng, xi, tilt=True):
    from scipy.spatial.transform import Rotation

    K = np.array([[rng.uniform(150, 300), rng.uniform(-3, 3), rng.uniform(280, 360)],
                  [0.0, rng.choice([-1, 1]) * rng.uniform(150, 300), rng.uniform(200, 280)], [0, 0, 1.0]])
    R = Rotation.from_rotvec(rng.normal(size=3)).as_matrix()
    Rt = Rotation.from_rotvec([*rng.normal(size=2) * 0.1, 0.0]).as_matrix() if tilt else np.eye(3)
    return UnifiedCamera(xi, K, R, rng.normal(size=3) * 0.1, Rt, 640, 480)


@pytest.mark.parametrize("xi", [0.0, 0.4, 0.96, 1.0, 1.3])
def test_lifting_inverts_projection(xi):
    rng = np.random.default_rng(int(xi * 100))
    u = _random_unified(rng, xi)
    P = u.center + rng.normal(size=(3000, 3)) * rng.uniform(0.1, 20, (3000, 1))
    pr = u.project(P)
    assert pr.valid.sum() > 500
    back = u.backproject(pr.uv[pr.valid])
    assert back.valid.all()
    d = P[pr.valid] - u.center
    assert np.max(_angle(back.directions, d)) < 1e-11
    # points the model cannot image: behind the virtual pinhole, or on the hidden side for xi > 1
    Xs = pr.sphere_points
    p = Xs + [0, 0, xi]
    front = (p @ u.R_tilt.T)[..., 2] > 0
    assert np.array_equal(pr.valid, front & (1 + xi * Xs[..., 2] >= 0))
    if xi > 1:
        # beyond the rim r^2 > 1 / (xi^2 - 1) of the normalised image there is no sphere point
        r_max = 1 / np.sqrt(xi * xi - 1)
        m = np.array([[1.5 * r_max, 0.0, 1.0]]) @ u.R_tilt.T
        uvb = (m @ u.K.T)[:, :2] / (m @ u.K.T)[:, 2:]
        assert not u.backproject(uvb).valid[0]


@pytest.mark.parametrize("xi", [0.5, 1.0, 1.3, 2.5])
def test_every_valid_ray_reprojects_to_its_pixel(xi):
    """Pixels far outside the image too (tilted model): a ray the lifting calls valid projects back
    onto its pixel; the lifting marks the others invalid (no sphere point, or one behind)."""
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(int(10 * xi))
    u0 = _random_unified(rng, xi)
    # a strong tilt: some pixels look at the virtual pinhole's back half (q_z < 0)
    u = UnifiedCamera(xi, u0.K, u0.R_sphere_from_mirror, u0.center, Rotation.from_rotvec([1.1, 0.4, 0]).as_matrix())
    m = np.concatenate([rng.uniform(-3, 3, size=(20000, 2)), np.ones((20000, 1))], -1)
    uv = (m @ u.K.T)[:, :2]
    back = u.backproject(uv)
    assert back.valid.sum() > 1000
    if xi >= 1:
        assert (~back.valid).sum() > 1000
    pr = u.project(back.origins[back.valid] + 5.0 * back.directions[back.valid])
    assert pr.valid.all()
    np.testing.assert_allclose(pr.uv, uv[back.valid], rtol=1e-9, atol=1e-8)
    assert np.all(np.isnan(back.directions[~back.valid]))


def test_vanishing_points_are_limits_of_far_points():
    rng = np.random.default_rng(7)
    u = _random_unified(rng, 0.9)
    d = rng.normal(size=(500, 3))
    vp = u.vanishing_points(d)
    q = rng.normal(size=3) * 0.05
    for sign, uv, valid, inside in ((1, vp.uv, vp.valid, vp.in_image),
                                    (-1, vp.uv_opposite, vp.valid_opposite, vp.in_image_opposite)):
        far = u.project(q + sign * 1e12 * d)
        assert np.array_equal(far.valid, valid)
        assert inside.sum() > 50
        assert np.max(np.abs(far.uv[inside] - uv[inside])) < 1e-6
    # the images of +d and -d are different points
    both = vp.valid & vp.valid_opposite
    assert both.sum() > 10
    assert np.min(np.linalg.norm(vp.uv[both] - vp.uv_opposite[both], axis=-1)) > 1.0
    # the line images pass through both vanishing points
    C = u.line_image(np.broadcast_to(q, d.shape), d)
    for uv, inside in ((vp.uv, vp.in_image), (vp.uv_opposite, vp.in_image_opposite)):
        assert np.max(_conic_px(C[inside], uv[inside])) < 1e-9


@pytest.mark.parametrize("xi", [0.0, 0.5, 0.9756, 1.0, 1.2])
def test_line_image_conic(xi):
    rng = np.random.default_rng(11)
    u = _random_unified(rng, xi)
    p0 = u.center + rng.normal(size=(40, 3))
    d = rng.normal(size=(40, 3))
    C = u.line_image(p0, d)
    assert np.allclose(C, np.swapaxes(C, -1, -2))
    t = np.linspace(-30, 30, 301)
    P = p0[:, None] + t[:, None] * d[:, None]
    pr = u.project(P)
    CC = np.broadcast_to(C[:, None], P.shape[:-1] + (3, 3))
    sel = pr.in_image
    assert sel.sum() > 1000
    assert np.max(_conic_px(CC[sel], pr.uv[sel])) < 1e-8
    # off the line image the conic does not vanish
    pq = u.project(P + rng.normal(size=P.shape) * 0.5)
    assert np.median(_conic_px(CC[pq.in_image], pq.uv[pq.in_image])) > 0.1
    # the samples lie on the line's image and end at the vanishing points
    smp = u.sample_line_image(p0, d, num=64)
    CS = np.broadcast_to(C[:, None], smp.uv.shape[:-1] + (3, 3))
    ins = smp.valid & u.in_image(smp.uv)
    assert np.max(_conic_px(CS[ins], smp.uv[ins])) < 1e-8
    vp = u.vanishing_points(d)
    end = smp.valid[:, -1]
    np.testing.assert_allclose(smp.uv[end, -1], vp.uv[end], atol=1e-9)
    start = smp.valid[:, 0]
    np.testing.assert_allclose(smp.uv[start, 0], vp.uv_opposite[start], atol=1e-9)
    assert all(len(run) >= 2 for run in smp.polylines(0))


def test_conic_perspective_limit_is_the_line():
    """xi = 0 is a pinhole: the conic degenerates to the image line n, counted twice."""
    n = np.array([0.3, -0.2, 0.9])
    np.testing.assert_allclose(conic_from_plane_normal(n, 0.0), np.outer(n, n), atol=1e-15)
    # a plane containing the sphere's axis (n_z = 0) gives a radial line for every xi
    n2 = np.array([0.6, 0.8, 0.0])
    np.testing.assert_allclose(conic_from_plane_normal(n2, 0.7), 0.51 * np.outer(n2, n2), atol=1e-15)


def _omnidir_reference(X, rvec, tvec, K, xi, D):
    """OpenCV omnidir's projection (Mei's model), written from its documented formula:
    X_c = R(rvec) X + tvec; X_s = X_c / |X_c|; x = (x_s / (z_s + xi), y_s / (z_s + xi));
    radial-tangential distortion (k1, k2, p1, p2); u = fx x_d + s y_d + cx, v = fy y_d + cy."""
    R, _ = cv2.Rodrigues(np.asarray(rvec, dtype=np.float64))
    Xc = X @ R.T + np.asarray(tvec)
    Xs = Xc / np.linalg.norm(Xc, axis=-1, keepdims=True)
    x = Xs[:, 0] / (Xs[:, 2] + xi)
    y = Xs[:, 1] / (Xs[:, 2] + xi)
    k1, k2, p1, p2 = D
    r2 = x * x + y * y
    radial = 1 + k1 * r2 + k2 * r2 * r2
    xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
    yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
    K = np.asarray(K)
    return np.stack([K[0, 0] * xd + K[0, 1] * yd + K[0, 2], K[1, 1] * yd + K[1, 2]], -1)


@pytest.mark.parametrize("source", ["central", "fit"])
def test_omnidir_mapping(source):
    """to_omnidir(): K = [[fx, s, cx], [0, fy, cy], [0, 0, 1]] is the model's K, D = 0, xi is xi,
    rvec = Rodrigues(R_sphere_from_mirror), tvec = -R center; the omnidir formula then gives the
    model's pixels."""
    if source == "central":
        u = unified_from_central(preset("hyperboloid_central"))
    else:
        u = fit_unified(preset("hyperboloid_9pct", width=160, height=120), step=4, tilt=False).camera
    om = u.to_omnidir()
    assert om["D"] == [0.0, 0.0, 0.0, 0.0]
    assert om["xi"] == u.xi and np.array_equal(np.array(om["K"]), u.K)
    assert (om["fx"], om["fy"], om["s"], om["cx"], om["cy"]) == (u.K[0, 0], u.K[1, 1], u.K[0, 1], u.K[0, 2], u.K[1, 2])
    rng = np.random.default_rng(2)
    X = u.center + rng.normal(size=(2000, 3)) * 2.0
    ours = u.project(X)
    ref = _omnidir_reference(X, om["rvec"], om["tvec"], om["K"], om["xi"], om["D"])
    ok = ours.in_image
    assert ok.sum() > 200
    assert np.max(np.linalg.norm(ours.uv[ok] - ref[ok], axis=-1)) < 1e-9
    img, _ = cv2.omnidir.projectPoints(X[ok].reshape(-1, 1, 3), np.array(om["rvec"]), np.array(om["tvec"]),
                                       np.array(om["K"]), om["xi"], np.zeros(4))
    assert np.max(np.abs(img.reshape(-1, 2) - ours.uv[ok])) < 1e-9
    # and back
    v = UnifiedCamera.from_omnidir(om["K"], om["xi"], om["rvec"], om["tvec"], om["D"])
    np.testing.assert_allclose(v.project(X).uv[ok], ours.uv[ok], atol=1e-9)
    # the reference is not vacuous: distortion moves the pixels
    moved = _omnidir_reference(X[ok], om["rvec"], om["tvec"], om["K"], om["xi"], (0.1, 0.0, 0.0, 0.01))
    assert np.max(np.linalg.norm(moved - ours.uv[ok], axis=-1)) > 1.0


def test_opencv_is_the_contrib_wheel_alone():
    """cv2.omnidir comes with opencv-contrib-python-headless only; the OpenCV wheels share one cv2
    folder, so exactly one of them may be installed (make fixes an older .venv: tools/one-opencv.sh)."""
    from importlib.metadata import distributions

    opencv = sorted({d.metadata["Name"].lower() for d in distributions()
                     if (d.metadata["Name"] or "").lower().startswith("opencv")})
    assert opencv == ["opencv-contrib-python-headless"], f"expected only the contrib wheel, got {opencv}"
    assert hasattr(cv2, "omnidir"), "cv2.omnidir is missing: pip install opencv-contrib-python-headless"


@pytest.mark.parametrize("name", CENTRAL)
def test_omnidir_undistort_points_and_rectification_map(name):
    """On a central rig, OpenCV's own omnidir functions agree with the exact rig through the exported
    parameters: cv2.omnidir.undistortPoints lifts each pixel onto the exact ray (it returns the
    perspective coordinates (x_s / z_s, y_s / z_s) of the sphere point), and
    cv2.omnidir.initUndistortRectifyMap (RECTIFY_PERSPECTIVE, new camera P) samples each pixel of a
    perspective view at the exact image of its direction ``R^T P^-1 (u, v, 1)``."""
    cam = preset(name)
    u = unified_from_central(cam)
    assert u.is_pure
    om = u.to_omnidir()
    K, D, xi = np.array(om["K"]), np.zeros((1, 4)), np.array([[om["xi"]]])
    uv = cam.pinhole.pixel_grid(8).reshape(-1, 2)
    exact = cam.backproject(uv)
    ok = exact.valid
    assert ok.sum() > 500
    und = cv2.omnidir.undistortPoints(uv[ok].reshape(-1, 1, 2), K, D, xi, np.eye(3)).reshape(-1, 2)
    Xs = exact.directions[ok] @ u.R_sphere_from_mirror.T  # the exact rays in the omnidir camera frame
    line = np.concatenate([und, np.ones((len(und), 1))], -1)  # the ray's line, sign of z_s dropped
    sin = np.linalg.norm(np.cross(line, Xs), axis=-1) / np.linalg.norm(line, axis=-1)
    assert np.max(sin) < 1e-9
    # the rectification map of a perspective view looking along the sphere's axis
    P = np.array([[150.0, 0.0, 159.5], [0.0, 150.0, 119.5], [0.0, 0.0, 1.0]])
    m1, m2 = cv2.omnidir.initUndistortRectifyMap(K, D, xi, np.eye(3), P, (320, 240), cv2.CV_32FC1,
                                                 cv2.omnidir.RECTIFY_PERSPECTIVE)
    rows, cols = np.mgrid[0:240:7, 0:320:7]
    d = np.stack([cols, rows, np.ones_like(cols)], -1).reshape(-1, 3).astype(float) @ np.linalg.inv(P).T
    pr = cam.project(cam.viewpoint + 1e3 * (d / np.linalg.norm(d, axis=-1, keepdims=True)) @ u.R_sphere_from_mirror)
    seen = pr.valid.any(-1) & cam.pinhole.in_image(np.nan_to_num(pr.uv[:, 0], nan=-1e9))
    assert seen.sum() > 300
    want = pr.uv[seen, 0]
    got = np.stack([m1[rows, cols].reshape(-1)[seen], m2[rows, cols].reshape(-1)[seen]], -1)
    # the map is float32 (about 3e-5 px at these coordinates); the rig is central, so a point 1 km along a
    # direction from the viewpoint has the pixel of the direction itself
    assert np.max(np.linalg.norm(got - want, axis=-1)) < 1e-3


def test_fit_recovers_central_rig_from_a_perturbed_start():
    cam = preset("hyperboloid_central", width=160, height=120)
    exact = unified_from_central(cam)
    start = UnifiedCamera(exact.xi - 0.05, exact.K * np.array([[1.04, 1, 1], [1, 0.97, 1], [1, 1, 1]]),
                          exact.R_sphere_from_mirror, exact.center + [0.001, -0.0005, 0.002])
    fit = fit_unified(cam, step=4, tilt=False, initial=start)
    assert fit.rms_px < 1e-8
    assert fit.camera.xi == pytest.approx(exact.xi, abs=1e-8)
    np.testing.assert_allclose(fit.camera.center, exact.center, atol=1e-9)
    np.testing.assert_allclose(fit.camera.K, exact.K, atol=1e-6)


def test_dict_round_trip():
    u = unified_from_central(preset("ellipsoid_central"))
    v = UnifiedCamera.from_dict(u.to_dict())
    P = np.random.default_rng(0).normal(size=(100, 3))
    np.testing.assert_array_equal(u.project(P).uv, v.project(P).uv)


# ------------------------------------------------------------------------- bad input
def test_errors_name_the_argument():
    u = unified_from_central(preset("hyperboloid_central"))
    with pytest.raises(cd.CatadioptricError, match=r"cam: expected a central rig \(pinhole at a focus of an "
                                                   r"ellipsoid or two-sheet hyperboloid\), got a hyperboloid mirror "
                                                   r"with the camera 0.009 m from the nearest focus"):
        unified_from_central(preset("hyperboloid_9pct"))
    with pytest.raises(cd.CatadioptricError, match=r"cam: expected a central rig .* got a sphere mirror"):
        unified_from_central(preset("sphere"))
    with pytest.raises(cd.CatadioptricError, match=r"cam: expected a CatadioptricCamera, got str"):
        unified_from_central("hyperboloid_central")
    with pytest.raises(cd.CatadioptricError, match=r"points: expected an array of shape \(\.\.\., 3\), got an array "
                                                   r"of shape \(4, 2\)"):
        u.project(np.zeros((4, 2)))
    with pytest.raises(cd.CatadioptricError, match=r"uv: expected finite values, got nan at index \(1, 0\)"):
        u.backproject(np.array([[1.0, 2.0], [np.nan, 0.0]]))
    with pytest.raises(cd.CatadioptricError, match=r"directions: expected nonzero direction vectors, got a zero "
                                                   r"vector at index \(1,\)"):
        u.vanishing_points(np.array([[1.0, 0, 0], [0, 0, 0]]))
    with pytest.raises(cd.CatadioptricError, match=r"xi: expected xi >= 0"):
        UnifiedCamera(-0.1, np.eye(3))
    with pytest.raises(cd.CatadioptricError, match=r"K: expected an upper-triangular generalized projection matrix"):
        UnifiedCamera(0.5, np.array([[100.0, 0, 0], [1.0, 100, 0], [0, 0, 1]]))
    with pytest.raises(cd.CatadioptricError, match=r"K: expected nonzero focal lengths"):
        UnifiedCamera(0.5, np.diag([0.0, 1.0, 1.0]))
    with pytest.raises(cd.CatadioptricError, match=r"R_sphere_from_mirror: expected a rotation matrix"):
        UnifiedCamera(0.5, np.eye(3), np.diag([1.0, 1.0, -1.0]))
    with pytest.raises(cd.CatadioptricError, match=r"sphere_z_range: expected \(lo, hi\) with -1 <= lo < hi <= 1"):
        UnifiedCamera(0.5, np.eye(3), sphere_z_range=(0.5, 0.2))
    with pytest.raises(cd.CatadioptricError, match=r"D: expected zero distortion"):
        UnifiedCamera.from_omnidir(np.eye(3), 0.9, D=[0.1, 0, 0, 0])
    with pytest.raises(cd.CatadioptricError, match=r"num: expected an integer in \[2, 10000000\], got 1"):
        u.sample_line_image([0, 0, 1.0], [1.0, 0, 0], num=1)
    with pytest.raises(cd.CatadioptricError, match=r"depths: expected positive depths in metres"):
        fit_unified(preset("hyperboloid_central", width=80, height=60), depths=(1.0, -2.0))
    with pytest.raises(cd.CatadioptricError, match=r"step: expected a positive integer, got 0"):
        fit_unified(preset("hyperboloid_central", width=80, height=60), step=0)


def test_sympy_derivation_checks_pass():
    """derivations/unified_central.py re-derives the closed forms used here (exit 0 when all hold)."""
    import subprocess
    import sys

    script = os.path.join(os.path.dirname(__file__), "..", "derivations", "unified_central.py")
    out = subprocess.run([sys.executable, script], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stdout + out.stderr
    assert out.stdout.count("ok  ") == 16 and "FAIL" not in out.stdout


# ---------------------------------------------------------------- issue 12: magnitudes and bad input
def test_points_directions_and_lines_of_extreme_magnitude():
    """Points 1e-300 to 1e300 from the viewpoint, directions and lines of any length: the same
    pixels and conics as moderate ones (norms overflowed beyond about 1e154, underflowed below 1e-162)."""
    u = UnifiedCamera(0.8, np.array([[200.0, 0, 160], [0, -200.0, 120], [0, 0, 1]]), width=320, height=240)
    rng = np.random.default_rng(3)
    d = rng.normal(size=(20, 3))
    ref = u.project(d)
    for k in (1e-300, 1e-162, 1e154, 1e300):
        pr = u.project(d * k)
        assert np.array_equal(pr.valid, ref.valid) and np.nanmax(np.abs(pr.uv - ref.uv)) < 1e-9
        vp = u.vanishing_points(d * k)
        assert np.array_equal(vp.valid, ref.valid) and np.nanmax(np.abs(vp.uv - ref.uv)) < 1e-9
    q, s = rng.normal(size=(5, 3)), rng.normal(size=(5, 3))
    C = u.line_image(q, s)
    for kq, ks in ((1e-200, 1e300), (1e300, 1e-300), (1e160, 1e160)):
        Ck = u.line_image(q * kq, s * ks)
        assert np.minimum(np.abs(Ck - C).max(axis=(1, 2)), np.abs(Ck + C).max(axis=(1, 2))).max() < 1e-9
    sm, smk = u.sample_line_image(q, s, num=16), u.sample_line_image(q * 1e300, s * 1e-300, num=16)
    assert np.array_equal(sm.valid, smk.valid) and np.nanmax(np.abs(sm.uv - smk.uv)) < 1e-6
    rays = u.backproject(np.array([[1e300, -1e300], [160.0, 120.0]]))
    assert np.all(np.isfinite(rays.directions[rays.valid]))


def test_bad_input_of_the_unified_model_is_refused_by_name():
    K = np.array([[200.0, 0, 160], [0, 200.0, 120], [0, 0, 1]])
    with pytest.raises(cd.CatadioptricError, match=r"width: expected a positive integer number of pixels or None, got True"):
        UnifiedCamera(0.5, K, width=True, height=240)
    with pytest.raises(cd.CatadioptricError, match=r"xi: expected a real number, got \(0.5\+1j\)"):
        UnifiedCamera(0.5 + 1j, K)
    with pytest.raises(cd.CatadioptricError, match=r"points: expected real numbers, got an array of dtype complex128"):
        UnifiedCamera(0.5, K).project(np.ones((2, 3)) + 1j)
    with pytest.raises(cd.CatadioptricError, match=r"num: expected an integer, got 16.0"):
        UnifiedCamera(0.5, K).sample_line_image([0, 0, 1.0], [1.0, 0, 0], num=16.0)
