"""Forward projection against the independent oracle, round trips and properties."""
import numpy as np
import pytest
from hypothesis import given, strategies as st

import catadioptric as cd
from catadioptric.rigs import preset, preset_names

from oracle import reflection_points

# the five mirror kinds, central, axial and off-axis placements
ORACLE_RIGS = ["sphere", "sphere_axial", "ellipsoid", "ellipsoid_central", "hyperboloid", "hyperboloid_central",
               "paraboloid", "cone"]


def _targets(cam, rng, n_seen=6, n_random=6):
    uv = np.stack([rng.uniform(0, cam.pinhole.width - 1, 400), rng.uniform(0, cam.pinhole.height - 1, 400)], -1)
    rays = cam.backproject(uv)
    ok = np.nonzero(rays.valid)[0][:n_seen]
    lam = rng.uniform(0.05, 3.0, len(ok))
    seen = rays.origins[ok] + lam[:, None] * rays.directions[ok]
    # random points around the rig: some seen once, some twice (concave mirrors), some never
    rnd = rng.normal(size=(n_random, 3)) * 0.3
    return np.concatenate([seen, rnd])


def _match(ours_pts, ours_valid, oracle, L):
    """Every oracle solution is one of ours with the same validity, and vice versa."""
    ours = [(p, v) for p, v in zip(ours_pts, ours_valid) if np.all(np.isfinite(p))]
    assert len(ours) == len(oracle), (ours, oracle)
    for r, v in oracle:
        d = [np.linalg.norm(p - r) for p, _ in ours]
        k = int(np.argmin(d))
        assert d[k] <= 1e-9 * max(L, 1.0), (d[k], r, ours)
        assert ours[k][1] == v


@pytest.mark.parametrize("name", ORACLE_RIGS)
def test_project_matches_oracle(name):
    cam = preset(name, width=320, height=240)
    rng = np.random.default_rng(abs(hash(name)) % 2**32)
    P = _targets(cam, rng)
    pr = cam.project(P)
    for i, p in enumerate(P):
        oracle = reflection_points(cam, p, 1.0)
        _match(pr.mirror_points[i], pr.valid[i], oracle, cam.mirror.scale)


def test_points_seen_twice_and_never():
    """Off its focus, a concave ellipsoid sees points near the caustic (around the other focus)
    two to four times; some points are not seen at all."""
    cam = preset("ellipsoid", width=320, height=240)
    rng = np.random.default_rng(5)
    P = cam.mirror.foci[1] + rng.normal(size=(20000, 3)) * 0.002
    pr = cam.project(P)
    counts = pr.valid.sum(axis=1)
    assert np.any(counts >= 3) and np.any(counts == 2) and np.any(counts == 0)
    picks = [np.nonzero(counts == k)[0][:2] for k in range(counts.max() + 1)]
    for i in np.concatenate(picks):
        _match(pr.mirror_points[i], pr.valid[i], reflection_points(cam, P[i], 1.0), cam.mirror.scale)


@pytest.mark.parametrize("name", preset_names())
def test_round_trip_pixel_ray_point_pixel(name):
    cam = preset(name)
    rng = np.random.default_rng(1)
    uv = np.stack([rng.uniform(-0.5, 639.5, 3000), rng.uniform(-0.5, 479.5, 3000)], -1)
    rays = cam.backproject(uv)
    ok = rays.valid
    assert ok.sum() > 100
    lam = rng.uniform(0.01, 50.0, ok.sum())
    P = rays.origins[ok] + lam[:, None] * rays.directions[ok]
    pr = cam.project(P)
    err = np.linalg.norm(pr.uv - uv[ok][:, None, :], axis=-1)
    err = np.where(pr.valid, err, np.inf).min(axis=1)
    assert np.max(err) < 1e-9


def test_project_shapes_and_padding():
    cam = preset("hyperboloid")
    P = np.random.default_rng(0).normal(size=(4, 5, 3))
    pr = cam.project(P)
    K = pr.uv.shape[-2]
    assert pr.uv.shape == (4, 5, K, 2) and pr.mirror_points.shape == (4, 5, K, 3) and pr.valid.shape == (4, 5, K)
    # padding is NaN, never zeros; valid entries come first
    assert np.all(np.isnan(pr.uv[~pr.valid & np.isnan(pr.mirror_points[..., 0])]))
    v = pr.valid.astype(int)
    assert np.all(np.diff(v, axis=-1) <= 0)


def test_backproject_hits_first_in_patch_and_ignores_the_other_sheet():
    cam = preset("hyperboloid_central")
    m = cam.mirror
    uv = cam.pinhole.pixel_grid(8).reshape(-1, 2)
    rays = cam.backproject(uv)
    r = rays.origins[rays.hit]
    assert np.all(np.abs(m.implicit(r)) < 1e-15)
    assert np.all((r[:, 2] >= m.z_min) & (r[:, 2] <= m.z_max))
    # the camera sits at the lower focus, beyond the lower sheet: every ray crosses that sheet
    # first (outside the patch), which must not block
    assert rays.hit.mean() > 0.2
    # central: every reflected ray passes through the other focus
    F = cam.viewpoint
    d = np.cross(F - rays.origins[rays.valid], rays.directions[rays.valid])
    assert np.max(np.linalg.norm(d, axis=-1)) < 1e-15


# ---------------------------------------------------------------- properties
@st.composite
def rigs(draw):
    kind = draw(st.sampled_from(["sphere", "ellipsoid", "hyperboloid", "paraboloid", "cone"]))
    if kind == "sphere":
        m = cd.QuadricMirror.sphere(draw(st.floats(0.02, 0.1)), z_min=0.0, z_max=0.2)
        base = np.array([0.0, 0.0, draw(st.floats(0.2, 0.5))])
    elif kind == "ellipsoid":
        a = draw(st.floats(0.02, 0.06))
        c = a * draw(st.floats(1.2, 2.0))
        f = np.sqrt(c * c - a * a)
        m = cd.QuadricMirror.ellipsoid(a, c, z_min=f + 0.25 * (c - f), z_max=c)
        base = m.foci[0]
    elif kind == "hyperboloid":
        a, c = draw(st.floats(0.02, 0.05)), draw(st.floats(0.02, 0.05))
        m = cd.QuadricMirror.hyperboloid(a, c, z_min=c, z_max=c + draw(st.floats(0.01, 0.05)))
        base = m.foci[0]
    elif kind == "paraboloid":
        m = cd.QuadricMirror.paraboloid(draw(st.floats(0.005, 0.03)), z_min=0.0, z_max=0.03)
        base = np.array([0.0, 0.0, -draw(st.floats(0.1, 0.4))])
    else:
        m = cd.QuadricMirror.cone(draw(st.floats(0.3, 1.1)), z_min=-0.05, z_max=-0.005)
        base = np.array([0.0, 0.0, draw(st.floats(0.1, 0.4))])
    off = np.array([draw(st.floats(-0.01, 0.01)) for _ in range(3)])
    pin = cd.PinholeCamera.from_fov(200, 150, 90.0)
    return cd.CatadioptricCamera.looking_at_mirror(m, pin, base + off,
                                                   target=(0, 0, 0.5 * (m.z_min + m.z_max)))


@given(rigs(), st.integers(0, 2**31 - 1))
def test_property_round_trip_and_reflection_law(cam, seed):
    rng = np.random.default_rng(seed)
    uv = np.stack([rng.uniform(0, 199, 300), rng.uniform(0, 149, 300)], -1)
    rays = cam.backproject(uv)
    ok = rays.valid
    if not np.any(ok):
        return
    P = rays.origins[ok] + rng.uniform(0.01, 10.0, (ok.sum(), 1)) * rays.directions[ok]
    pr = cam.project(P)
    err = np.where(pr.valid, np.linalg.norm(pr.uv - uv[ok][:, None], axis=-1), np.inf).min(axis=1)
    assert np.max(err) < 1e-8
    # every valid solution obeys the law of reflection and lies on the patch
    r = pr.mirror_points[pr.valid]
    tgt = np.broadcast_to(P[:, None, :], pr.mirror_points.shape)[pr.valid]
    n = cam.mirror.normal(r)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    i = (r - cam.center) / np.linalg.norm(r - cam.center, axis=-1, keepdims=True)
    o = (tgt - r) / np.linalg.norm(tgt - r, axis=-1, keepdims=True)
    assert np.max(np.linalg.norm(i - 2 * np.sum(i * n, -1, keepdims=True) * n - o, axis=-1)) < 1e-9
    assert np.all(cam.mirror.in_patch(r, 1e-12))


@pytest.mark.parametrize("name", ["ellipsoid", "hyperboloid_9pct", "sphere"])
def test_targets_near_the_plane_of_camera_and_axis(name):
    """Nearly symmetric configurations: reflection points with x ~ 1e-4 in the solver frame,
    where x = sqrt(rho^2 - y^2) is ill-conditioned (a regression: such points were lost)."""
    cam = preset(name, width=320, height=240)
    c = cam.center
    az = np.arctan2(c[1], c[0])
    rng = np.random.default_rng(8)
    u = np.array([np.cos(az), np.sin(az), 0.0])
    v = np.array([-np.sin(az), np.cos(az), 0.0])
    F = cam.mirror.foci[-1] if cam.mirror.foci else np.array([0, 0, 0.5 * (cam.mirror.z_min + cam.mirror.z_max)])
    P = F + rng.normal(size=(6, 1)) * 0.003 * u + rng.normal(size=(6, 1)) * 1e-4 * v + rng.normal(size=(6, 1)) * [0, 0, 0.003]
    pr = cam.project(P)
    for i, p in enumerate(P):
        _match(pr.mirror_points[i], pr.valid[i], reflection_points(cam, p, 1.0, n_phi=1440, n_z=600), cam.mirror.scale)


@pytest.mark.parametrize("name", ["sphere", "ellipsoid", "hyperboloid", "hyperboloid_central", "paraboloid"])
def test_a_row_gets_the_same_bits_alone_and_in_any_batch(name):
    """The result of a point or a direction does not depend on the other rows of its batch nor on
    the BLAS thread count (no BLAS product in the pipeline: a BLAS product rounds a row by its place
    in the blocks of the batch; with 3316 rows, 4 to 13 of 35 rows differed in the last bits)."""
    cam = preset(name, width=320, height=240)
    rng = np.random.default_rng(2)
    P = rng.normal(size=(3316, 3)) * 0.2
    pr = cam.project(P)
    vp = cam.vanishing_points(P, which="both")
    rows = np.arange(0, len(P), 97)
    for i in rows:
        one = cam.project(P[i])
        assert np.array_equal(one.uv, pr.uv[i], equal_nan=True) and np.array_equal(one.valid, pr.valid[i])
    v1 = cam.vanishing_points(P[rows], which="both")
    assert np.array_equal(v1.uv, vp.uv[rows], equal_nan=True) and np.array_equal(v1.valid, vp.valid[rows])


# ---------------------------------------------------------------- degeneracies (issue 12)
def _issue_rigs():
    pin = cd.PinholeCamera.from_fov(640, 480, 60.0)
    sphere = cd.CatadioptricCamera.looking_at_mirror(cd.QuadricMirror(1.0, 0.0, 1.0, -1.0, 0.0), pin,
                                                     (0.0, 0.8, -3.5), target=(0, 0, -1))
    parab = cd.CatadioptricCamera.looking_at_mirror(cd.QuadricMirror(0.0, 3.4, 33.2, 0.0, 33.2 / 3.4), pin,
                                                    (0.0, 0.0, 26.5), target=(0, 0, 0))
    return sphere, parab


OFFSETS = np.r_[0.0, np.logspace(-12, -9, 10), np.logspace(-8, -3, 6), 1e-12, 3e-11, 1e-9, 0.0]  # 21 points


@pytest.mark.parametrize("which", ["sphere", "paraboloid"])
def test_near_normal_incidence_down_to_the_normal_ray(which):
    """Points 0 to 1e-3 off the line through the camera and its own reflection: the sphere seen
    off-axis (the foot is where the line from the centre through the camera meets the sphere) and
    the paraboloid seen on its axis (the foot is the vertex at z_max exactly). Found alone and in a
    batch of 21, with the same bits."""
    sphere, parab = _issue_rigs()
    if which == "sphere":
        cam = sphere
        foot = cam.center / np.linalg.norm(cam.center)
    else:
        cam = parab
        foot = np.array([0.0, 0.0, cam.mirror.z_max])
    u = (cam.center - foot) / np.linalg.norm(cam.center - foot)
    perp = np.cross(u, [1.0, 0, 0]) if abs(u[0]) < 0.9 else np.cross(u, [0, 1.0, 0])
    perp /= np.linalg.norm(perp)
    P = foot + 2.0 * u + OFFSETS[:, None] * perp
    batch = cam.project(P)
    assert batch.valid[:, 0].all() and (batch.valid.sum(axis=1) == 1).all()
    # the reflection point moves with the offset; on the normal ray it is the foot itself
    assert np.linalg.norm(batch.mirror_points[OFFSETS == 0, 0] - foot, axis=-1).max() < 1e-12
    assert np.linalg.norm(batch.mirror_points[:, 0] - foot, axis=-1).max() < 1e-2
    for i, p in enumerate(P):
        one = cam.project(p)
        assert np.array_equal(one.valid, batch.valid[i]) and np.array_equal(one.uv, batch.uv[i], equal_nan=True)
    vp = cam.vanishing_points(u + OFFSETS[:, None] * perp)
    assert vp.valid[:, 0].all()
    assert np.linalg.norm(vp.mirror_points[OFFSETS == 0, 0] - foot, axis=-1).max() < 1e-12


@pytest.mark.parametrize("name", ["hyperboloid_9pct", "hyperboloid", "ellipsoid", "sphere", "paraboloid"])
def test_near_normal_incidence_on_the_presets(name):
    """Pixels 0 to 1e-2 px from the pixel where the camera sees itself, points along their rays at
    any depth (between the mirror and the camera, beyond it): every pixel comes back."""
    from fuzz_api import normal_pixels

    cam = preset(name, width=64, height=48)
    [uv0] = normal_pixels(cam)
    ang = np.linspace(0, 2 * np.pi, 7)
    off = np.r_[0.0, 1e-12, 1e-9, 1e-6, 1e-4, 1e-2, 1e-2]
    uv = uv0 + off[:, None] * np.stack([np.cos(ang), np.sin(ang)], -1)
    rays = cam.backproject(uv)
    assert rays.valid.all()
    dist = np.linalg.norm(cam.center - rays.origins, axis=1)
    for lam in np.r_[1e-3, 0.3, 0.999, 1.001, 3.0, 1e3][:, None] * dist[None]:
        P = rays.origins + lam[:, None] * rays.directions
        pr = cam.project(P)
        err = np.where(pr.valid, np.linalg.norm(pr.uv - uv[:, None], axis=-1), np.inf).min(axis=1)
        assert err.max() < 1e-7, (lam / dist, err)


def test_points_near_the_other_focus_alone_and_batched():
    """Near the second focus of the off-focus ellipsoid (up to four images each): the same bits alone
    and in a batch (it was up to 1.2e-11 px)."""
    cam = preset("ellipsoid")
    P = cam.mirror.foci[1] + np.random.default_rng(4).normal(size=(3000, 3)) * 0.002
    pr = cam.project(P)
    assert pr.valid.sum(axis=1).max() >= 3
    for i in range(0, 3000, 97):
        one = cam.project(P[i])
        assert np.array_equal(one.valid, pr.valid[i]) and np.array_equal(one.uv, pr.uv[i], equal_nan=True)


def test_two_solutions_at_one_height_in_the_plane_of_camera_and_axis():
    """A target in the plane of the camera and the axis, near the ellipsoid's other focus: one
    solution in that plane and a symmetric pair off it share one root of the octic (it lost the
    one in the plane)."""
    cam = preset("ellipsoid", width=64, height=48)
    c = cam.center
    P = np.array([-0.00044305, -0.00029537, 0.04543507])  # (x, y) along -c's azimuth
    assert abs(P[0] * c[1] - P[1] * c[0]) < 1e-9
    pr = cam.project(P)
    _match(pr.mirror_points, pr.valid, reflection_points(cam, P, 1.0, n_phi=1440, n_z=800), cam.mirror.scale)


def test_camera_within_1e_8_of_the_axis():
    """A one-sheet hyperboloid seen from 4.5e-9 m off its axis, a target nearly in the plane of the
    camera and the axis: the octic's branches cancel in G (lost before)."""
    m = cd.QuadricMirror(-2.5275695370604914, 0.0, 0.000694335268121173, -0.0031358961285384125,
                         0.04301951253574224)
    cam = cd.CatadioptricCamera.looking_at_mirror(m, cd.PinholeCamera.from_fov(64, 48, 90.0),
                                                  (-2.49706007e-09, -3.66523667e-09, -1.49352176e-01),
                                                  target=(0, 0, 0.5 * (m.z_min + m.z_max)))
    assert cam.solver.name == "general"
    P = np.array([-8.243041941436574e-05, -0.00012099308282118026, 0.2728609891364979])
    pr = cam.project(P)
    oracle = reflection_points(cam, P, 1.0, n_phi=1440, n_z=800)
    assert oracle and pr.valid.sum() == 2
    for r, v in oracle:
        assert v and np.min(np.linalg.norm(pr.mirror_points[pr.valid] - r, axis=-1)) < 1e-9 * m.scale


def test_target_on_the_axis_of_an_off_axis_hyperboloid():
    """A point on the axis below the camera reflects just above the vertex (z_min): it was lost
    (the branch screen rejected both branches of the symmetric configuration)."""
    cam = preset("hyperboloid", width=96, height=72)
    P = np.array([[0.0, 0.0, z] for z in (-5.0, -3.0, -1.0)])
    pr = cam.project(P)
    for i, p in enumerate(P):
        _match(pr.mirror_points[i], pr.valid[i], reflection_points(cam, p, 1.0), cam.mirror.scale)
    assert pr.valid[:, 0].all()


# ---------------------------------------------------------------- units and magnitudes (issue 12)
def _scaled(cam, k):
    m = cam.mirror
    return cd.CatadioptricCamera(cd.QuadricMirror(m.A, m.B * k, m.C * k * k, m.z_min * k, m.z_max * k),
                                 cam.pinhole, cam.center * k, cam.R_cam_from_mirror)


@pytest.mark.parametrize("name", preset_names())
def test_the_same_answers_in_any_length_unit(name):
    """Metres, millimetres and far beyond: the same solver, pixels, flags and rays (the paraboloid
    scaled by 1e9 turned rays by 2.3 degrees; scaled by 1e-10 a rig got the axial solver)."""
    cam = preset(name, width=160, height=120)
    rng = np.random.default_rng(6)
    uv = np.stack([rng.uniform(-0.5, 159.5, 400), rng.uniform(-0.5, 119.5, 400)], -1)
    r1 = cam.backproject(uv)
    ok = r1.valid
    P = r1.origins[ok] + rng.uniform(0.01, 10.0, (ok.sum(), 1)) * r1.directions[ok]
    S = rng.normal(size=(200, 3))
    p1, v1 = cam.project(P), cam.vanishing_points(S)
    for k in (1e3, 1e-3, 1e-10, 1e6, 1e9, 1e12):
        ck = _scaled(cam, k)
        assert ck.solver.name == cam.solver.name and ck.is_central == cam.is_central
        r2 = ck.backproject(uv)
        assert np.array_equal(r1.valid, r2.valid) and np.array_equal(r1.hit, r2.hit)
        assert np.nanmax(np.abs(r1.directions - r2.directions)) < 1e-12
        assert np.nanmax(np.abs(r1.origins * k - r2.origins)) < 1e-12 * k * cam.mirror.scale
        p2 = ck.project(P * k)
        assert np.array_equal(p1.valid, p2.valid) and np.nanmax(np.abs(p1.uv - p2.uv)) < 1e-8
        v2 = ck.vanishing_points(S)
        assert np.array_equal(v1.valid, v2.valid) and np.nanmax(np.abs(v1.uv - v2.uv)) < 1e-8


@pytest.mark.parametrize("name", ["sphere", "hyperboloid_9pct", "hyperboloid_central", "paraboloid"])
def test_directions_and_points_of_extreme_magnitude(name):
    """Directions of length 1e-300 to 1e300 have the vanishing points of their unit vectors; points
    1e10 to 1e300 mirror sizes away image next to them (they were lost beyond about 1e154)."""
    cam = preset(name)
    rng = np.random.default_rng(8)
    S = rng.normal(size=(40, 3))
    S /= np.linalg.norm(S, axis=1, keepdims=True)
    vp = cam.vanishing_points(S)
    rows = np.nonzero(vp.valid[:, 0])[0]
    assert len(rows) >= 5
    for k in (1e-300, 1e-162, 1e154, 1e300):
        vk = cam.vanishing_points(S * k)
        assert np.array_equal(vk.valid, vp.valid) and np.nanmax(np.abs(vk.uv - vp.uv)) < 1e-9
    q = rng.normal(size=(len(rows), 3)) * 0.5
    for lam in (1e10, 1e155, 1e300):
        pr = cam.project(q + lam * S[rows])
        d = np.where(pr.valid, np.linalg.norm(pr.uv - vp.uv[rows, :1], axis=-1), np.inf).min(axis=1)
        assert d.max() < 1e-3
    far = cam.backproject(np.array([[1e300, -1e300], [1e-300, 3.0]]))
    assert np.all(np.isfinite(far.directions[far.valid]))


def test_near_the_point_where_the_octic_vanishes():
    """A target 0.5 mm from the other focus of the off-focus ellipsoid: the octic is 1e-9 of its
    terms' size (it vanishes identically for a camera at one focus and a target at the other), so
    the fitted map's rounding moved two close roots off the axis (two of the four solutions lost);
    the octic is rebuilt from the target there."""
    cam = preset("ellipsoid", width=64, height=48)
    P = np.array([-0.0004806045841635881, -0.00031820964210288504, 0.04462549279773763])
    pr = cam.project(P)
    oracle = reflection_points(cam, P, 1.0, n_phi=1440, n_z=800)
    assert len(oracle) == 4
    _match(pr.mirror_points, pr.valid, oracle, cam.mirror.scale)


def test_three_solutions_near_a_cusp_in_the_plane_of_camera_and_axis():
    """A one-sheet hyperboloid (in units of 1e-9: a fuzz case), a target in the plane of the camera
    and the axis whose in-plane reflection point has an off-plane pair next to it: the octic holds
    the three in one cluster of roots and the in-plane one was lost; the plane's own 1-D problem
    finds it."""
    m = cd.QuadricMirror(-1.0084323646800242, 0.0, 8.165464392640903e-22, -2.5973730292871836e-11,
                         2.5186920007656107e-11)
    c = np.array([1.882903346225165e-12, -7.3113590722243e-12, -3.596514861751909e-10])
    cam = cd.CatadioptricCamera.looking_at_mirror(m, cd.PinholeCamera.from_fov(64, 48, 60.0), c,
                                                  target=(0, 0, 0.5 * (m.z_min + m.z_max)))
    P = np.array([-1.0495072673979045e-12, 4.0752620129113286e-12, 1.9574756842661715e-10])
    expected = [np.array([7.136488436470859e-12, -2.7711156600492346e-11, -1.5073384361378626e-12]),  # in the plane
                np.array([-7.126982437445064e-12, 2.7674244568143476e-11, -3.3214687334838176e-13])]
    pr = cam.project(P)
    found = pr.mirror_points[np.isfinite(pr.mirror_points[:, 0])]
    for r in expected:
        assert np.min(np.linalg.norm(found - r, axis=-1)) < 1e-8 * m.scale


@pytest.mark.parametrize("name", ORACLE_RIGS)
def test_images_continued_from_a_nearby_reflection_point_are_the_searched_ones(name):
    """``project_from``: Newton's method from the reflection point of a nearby point lands on the
    valid image of ``project`` that continues it (to 1e-9 of the mirror's scale); a start that is
    missing or far off, or a point no longer seen, is left to the search (``ok`` False)."""
    from catadioptric.linefit import project_with_jacobian
    from catadioptric.projection import project_from

    cam = preset(name, width=320, height=240)
    rng = np.random.default_rng(11)
    uv = np.stack([rng.uniform(0, 319, 3000), rng.uniform(0, 239, 3000)], -1)
    rays = cam.backproject(uv)
    ok = np.nonzero(rays.valid)[0][:400]
    lam = rng.uniform(0.5, 20.0, len(ok))
    P0 = rays.origins[ok] + lam[:, None] * rays.directions[ok]
    r0 = rays.origins[ok]
    P1 = P0 + rng.normal(size=P0.shape) * 1e-3 * lam[:, None]  # a step of an optimiser: about 0.06 deg
    uv1, r1, ok1 = project_from(cam, P1, r0)
    assert ok1.mean() > 0.95, ok1.mean()
    pr = cam.project(P1[ok1])
    d = np.linalg.norm(pr.mirror_points - r1[ok1][:, None, :], axis=-1)
    k = np.argmin(np.where(pr.valid, d, np.inf), axis=1)
    i = np.arange(len(k))
    assert np.all(pr.valid[i, k])
    L = cam.mirror.scale
    assert np.max(d[i, k]) < 1e-9 * L
    assert np.max(np.linalg.norm(pr.uv[i, k] - uv1[ok1], axis=-1)) < 1e-6
    # the same choice as the search for the image nearest the old pixel, row by row
    uv_s, _, vis_s = project_with_jacobian(cam, P1, uv[ok], jacobian=False)
    uv_w, G_w, vis_w = project_with_jacobian(cam, P1, uv[ok], start=r0)
    assert np.allclose(uv_w, uv_s, atol=1e-6, equal_nan=True) and np.array_equal(vis_w, vis_s)
    assert np.all(np.isfinite(G_w[vis_w]))
    # no start: left to the search; a start across the mirror: whatever it keeps is a valid image
    # within a quarter of the mirror's scale of the start, the rest left to the search
    _, _, ok_nan = project_from(cam, P1, np.full_like(r0, np.nan))
    assert not ok_nan.any()
    far = r0.copy()
    far[:, :2] *= -1.0
    _, r_far, ok_far = project_from(cam, P1, far)
    assert ok_far.mean() < 0.5
    if ok_far.any():
        pr = cam.project(P1[ok_far])
        d = np.linalg.norm(pr.mirror_points - r_far[ok_far][:, None, :], axis=-1)
        assert np.all(np.min(np.where(pr.valid, d, np.inf), axis=1) < 1e-9 * L)
        assert np.all(np.linalg.norm(r_far[ok_far] - far[ok_far], axis=1) <= 0.25 * L)


def test_project_from_refuses_a_start_per_point_of_the_wrong_length():
    from catadioptric.projection import project_from

    cam = preset("hyperboloid")
    with pytest.raises(cd.CatadioptricError, match=r"start: expected one reflection point per point \(2\), got 3"):
        project_from(cam, np.ones((2, 3)), np.ones((3, 3)))
