"""Vanishing points, directions from vanishing points and vanishing curves."""
import numpy as np
import pytest
from hypothesis import given, strategies as st

import catadioptric as cd
from catadioptric.rigs import preset
from catadioptric.solvers import select_solver
from catadioptric.vanishing import paper_directions_from_mirror_points

from oracle import reflection_points
from steps import max_step_excess

# sphere, ellipsoid, hyperboloid 9 % of the focal distance off the focus, hyperboloid at the focus
RIGS = ["sphere", "ellipsoid", "hyperboloid_9pct", "hyperboloid_central"]


def _degenerate(cam):
    c = cam.center
    az = np.arctan2(c[0], c[1]) if np.hypot(c[0], c[1]) > 0 else 0.0
    e1 = np.array([np.cos(az), -np.sin(az), 0.0])
    return np.array([e1, -e1, [0, 0, 1.0], [0, 0, -1.0], [1.0, 0, 0], [0, -1.0, 0], [0.0, 0.6, -0.8]])


@pytest.mark.parametrize("name", RIGS)
def test_vanishing_points_match_oracle(name):
    cam = preset(name, width=320, height=240)
    rng = np.random.default_rng(7)
    S = np.concatenate([rng.normal(size=(6, 3)), _degenerate(cam)])
    vp = cam.vanishing_points(S, which="both")
    L = cam.mirror.scale
    for i, s in enumerate(S):
        for sign in (+1, -1):
            oracle = reflection_points(cam, s, 0.0, sign=sign)
            sel = vp.sign[i] == sign
            ours = vp.mirror_points[i][sel]
            assert len(ours) == len(oracle), (s, sign, ours, oracle)
            for r, visible in oracle:
                d = np.linalg.norm(ours - r, axis=-1)
                k = int(np.argmin(d))
                assert d[k] <= 1e-9 * L
                assert vp.visible[i][sel][k] == visible
    assert np.all(vp.valid == (vp.visible & (vp.sign > 0)))


@pytest.mark.parametrize("name", RIGS)
def test_far_points_converge_to_the_plus_s_vanishing_point(name):
    cam = preset(name)
    rng = np.random.default_rng(3)
    S = rng.normal(size=(40, 3))
    S /= np.linalg.norm(S, axis=1, keepdims=True)
    vp = cam.vanishing_points(S)
    rows = np.nonzero(vp.valid[:, 0])[0]
    assert len(rows) >= 5
    q = rng.normal(size=(len(rows), 3)) * 0.5
    errs = []
    for lam in (1e2, 1e4, 1e6):
        pr = cam.project(q + lam * S[rows])
        d = np.linalg.norm(pr.uv - vp.uv[rows, :1], axis=-1)
        errs.append(np.where(pr.valid, d, np.inf).min(axis=1))
    errs = np.array(errs)
    assert np.all(errs[2] < 1e-3)  # pixels: the image of q + lambda s reaches the +s point
    assert np.all(errs[2] <= errs[1] + 1e-9) and np.all(errs[1] <= errs[0] + 1e-9)


@pytest.mark.parametrize("name", RIGS)
def test_directions_from_vanishing_points_round_trip(name):
    cam = preset(name)
    rng = np.random.default_rng(11)
    S = rng.normal(size=(200, 3))
    S /= np.linalg.norm(S, axis=1, keepdims=True)
    vp = cam.vanishing_points(S)
    ok = vp.valid[:, 0]
    d = cam.directions_from_vanishing_points(vp.uv[ok, 0])
    assert np.max(np.linalg.norm(d - S[ok], axis=-1)) < 1e-9  # oriented: +s, not -s
    outside = cam.directions_from_vanishing_points(np.array([[0.0, 0.0]]))
    assert np.all(np.isnan(outside))


def test_paper_direction_system_is_lossy():
    """The paper's Sec. 2.3 system returns two directions (+-s1) and no orientation; only one
    of them has the vanishing point it started from."""
    cam = preset("hyperboloid_9pct")
    rng = np.random.default_rng(2)
    S = rng.normal(size=(50, 3))
    S /= np.linalg.norm(S, axis=1, keepdims=True)
    vp = cam.vanishing_points(S)
    ok = np.nonzero(vp.valid[:, 0] & (np.abs(S[:, 0]) > 0.2))[0]
    cand = paper_directions_from_mirror_points(cam, vp.mirror_points[ok, 0])  # (n, 2, 3)
    # one candidate is +-s ...
    err = np.minimum(np.linalg.norm(cand - S[ok, None], axis=-1), np.linalg.norm(cand + S[ok, None], axis=-1))
    assert np.all(err.min(axis=1) < 1e-6)
    # ... the other is a different direction whose vanishing points are elsewhere
    other = cand[np.arange(len(ok)), np.argmax(err, axis=1)]
    assert np.all(err.max(axis=1) > 0.1)
    vo = cam.vanishing_points(np.concatenate([other, -other]), which="+s")
    r0 = np.concatenate([vp.mirror_points[ok, 0]] * 2)
    d = np.linalg.norm(vo.mirror_points - r0[:, None], axis=-1)
    assert np.all(np.nan_to_num(d, nan=np.inf).min(axis=1) > 1e-6)


@pytest.mark.parametrize("name,normal", [("hyperboloid_9pct", [0.05, 0.05, 0.997]), ("sphere", [0.3, 0.1, 1.0]),
                                         ("ellipsoid", [1.0, 0.2, 0.1]), ("hyperboloid_central", [0, 1.0, 0.2])])
def test_vanishing_curve(name, normal):
    cam = preset(name)
    n = np.array(normal) / np.linalg.norm(normal)
    curves = cam.vanishing_curve(n)
    assert curves
    for c in curves:
        assert max_step_excess(c.uv, cam.pinhole.width, cam.pinhole.height) <= 1e-9
        # every vertex is the vanishing point of a direction in the plane: n . d(r) = 0
        d = cam.directions_from_vanishing_points(c.uv)
        assert np.max(np.abs(d @ n)) < 1e-9
        assert np.all(cam.mirror.in_patch(c.mirror_points, 1e-12))
    # vanishing points of directions in the plane lie on the curve
    e1 = np.cross(n, [1.0, 0, 0] if abs(n[0]) < 0.9 else [0, 1.0, 0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(n, e1)
    th = np.random.default_rng(0).uniform(0, 2 * np.pi, 50)
    vp = cam.vanishing_points(np.cos(th)[:, None] * e1 + np.sin(th)[:, None] * e2)
    pts = vp.uv[vp.valid]
    allv = np.concatenate([c.uv for c in curves])
    dist = np.min(np.linalg.norm(pts[:, None] - allv[None], axis=-1), axis=1)
    assert np.all(dist <= 0.5 + 1e-9)


def test_vanishing_curve_of_a_partly_visible_plane_has_ends():
    cam = preset("ellipsoid")
    curves = cam.vanishing_curve([1.0, 0.0, 0.0])
    open_ = [c for c in curves if not c.closed]
    for c in open_:  # the ends lie on the patch boundary or where visibility ends
        assert len(c.uv) >= 2


def test_vanishing_point_input_errors():
    cam = preset("sphere")
    with pytest.raises(cd.CatadioptricError, match=r"directions: expected non-zero vectors, got a zero vector at flat index 1"):
        cam.vanishing_points(np.array([[1.0, 0, 0], [0, 0, 0]]))
    with pytest.raises(cd.CatadioptricError, match=r"which: expected '\+s' or 'both', got 'all'"):
        cam.vanishing_points(np.array([1.0, 0, 0]), which="all")
    with pytest.raises(cd.CatadioptricError, match=r"normal: expected a non-zero 3-vector, got \[0.0, 0.0, 0.0\]"):
        cam.vanishing_curve([0.0, 0.0, 0.0])


# ------------------------------------------------------- special solvers vs general ones
def _same_solutions(a, b, tol):
    for i in range(a.points.shape[0]):
        pa = a.points[i][a.found[i]]
        pb = b.points[i][b.found[i]]
        assert len(pa) == len(pb)
        for p in pa:
            assert np.min(np.linalg.norm(pb - p, axis=-1)) <= tol


@pytest.mark.parametrize("w", [0.0, 1.0])
def test_special_solvers_agree_with_general_ones(w):
    rng = np.random.default_rng(4)
    T = rng.normal(size=(60, 3)) * (0.3 if w else 1.0)
    # sphere (degree 4) vs the general octic, off-axis camera
    cam = preset("sphere")
    m = cam.mirror
    a = select_solver(m, cam.center).solve(T, w, backward=True)
    b = select_solver(m, cam.center, force="general").solve(T, w, backward=True)
    assert select_solver(m, cam.center).name == "sphere"
    _same_solutions(a, b, 1e-9 * m.scale)
    # central (degree 2), paraboloid (5), cone (2) vs the general axial sextic
    for name, special in [("hyperboloid_central", "central"), ("ellipsoid_central", "central"),
                          ("paraboloid", "paraboloid_axial"), ("cone", "cone_axial"), ("sphere_axial", "sphere")]:
        cam = preset(name)
        m = cam.mirror
        s1 = cam.solver
        assert s1.name == special
        s2 = select_solver(m, cam.center, force="axial")
        _same_solutions(s1.solve(T, w, backward=True), s2.solve(T, w, backward=True), 1e-9 * m.scale)
    # cylinder (degree 2) vs the sextic
    m = cd.QuadricMirror.cylinder(0.02, z_min=-0.03, z_max=0.03)
    c = np.array([0.0, 0.0, 0.2])
    assert select_solver(m, c).name == "cylinder_axial"
    _same_solutions(select_solver(m, c).solve(T, w, backward=True),
                    select_solver(m, c, force="axial").solve(T, w, backward=True), 1e-9 * m.scale)
    # the general octic on a nearly axial camera approaches the axial sextic
    cam = preset("hyperboloid_central")
    m = cam.mirror
    near = cam.center + np.array([1e-9, 0.0, 0.0])
    _same_solutions(select_solver(m, near).solve(T, w, backward=True),
                    select_solver(m, cam.center, force="axial").solve(T, w, backward=True), 1e-6 * m.scale)


@given(st.floats(-1, 1), st.floats(-1, 1), st.floats(-1, 1))
def test_property_vanishing_points_obey_reflection(sx, sy, sz):
    s = np.array([sx, sy, sz])
    if np.linalg.norm(s) < 1e-3:
        return
    for name in ("hyperboloid_9pct", "sphere", "ellipsoid"):
        cam = preset(name)
        vp = cam.vanishing_points(s, which="both")
        r = vp.mirror_points[vp.sign != 0]
        sg = vp.sign[vp.sign != 0]
        n = cam.mirror.normal(r)
        n /= np.linalg.norm(n, axis=-1, keepdims=True)
        i = (r - cam.center) / np.linalg.norm(r - cam.center, axis=-1, keepdims=True)
        d = i - 2 * np.sum(i * n, -1, keepdims=True) * n
        assert np.allclose(d, sg[:, None] * s / np.linalg.norm(s), atol=1e-9)


@pytest.mark.parametrize("name", ["hyperboloid_9pct", "sphere", "ellipsoid", "paraboloid", "hyperboloid_central"])
def test_very_far_points_keep_their_image(name):
    """Points up to 1e12 m away are still projected (a regression: far points lost their image
    when the target's homogeneous weight became tiny), next to the +s vanishing point."""
    cam = preset(name)
    rng = np.random.default_rng(3)
    S = rng.normal(size=(200, 3))
    S /= np.linalg.norm(S, axis=1, keepdims=True)
    vp = cam.vanishing_points(S)
    ok = vp.valid[:, 0]
    q = rng.normal(size=(200, 3))
    for lam in (3e4, 1e7, 1e12):
        pr = cam.project(q + lam * S)
        d = np.where(pr.valid, np.linalg.norm(pr.uv - vp.uv[:, :1], axis=-1), np.inf).min(axis=1)
        assert np.all(d[ok] < 1.0 + 1e4 / lam)


@pytest.mark.parametrize("name", ["hyperboloid_9pct", "sphere", "ellipsoid"])
def test_minus_s_points_are_the_plus_s_points_of_the_opposite_direction(name):
    cam = preset(name)
    S = np.random.default_rng(6).normal(size=(100, 3))
    both = cam.vanishing_points(S, which="both").opposite()
    neg = cam.vanishing_points(-S)
    assert np.array_equal(both.valid, neg.valid)
    assert np.allclose(np.nan_to_num(both.uv, nan=-1), np.nan_to_num(neg.uv, nan=-1), atol=1e-9)


@pytest.mark.parametrize("k", [1.0, 1e-3, 1e3, 7.3])
@pytest.mark.parametrize("upper", [True, False])
def test_the_axis_of_a_central_rig_vanishes_at_the_image_centre(k, upper):
    """A central hyperbolic rig whose patch starts at the vertex, looking along the axis: the axis
    direction's vanishing point is the vertex's pixel, the image centre (it was lost: the vertex
    rounds to either side of z_min)."""
    a, c, span = 0.03 * k, 0.04 * k, 0.035 * k
    if upper:
        m = cd.QuadricMirror.hyperboloid(a, c, z_min=c, z_max=c + span)
        F, axis = m.foci[0], np.array([0.0, 0.0, -1.0])
    else:
        m = cd.QuadricMirror.hyperboloid(a, c, z_min=-c - span, z_max=-c)
        F, axis = m.foci[1], np.array([0.0, 0.0, 1.0])
    cam = cd.CatadioptricCamera.looking_at_mirror(m, cd.PinholeCamera.from_fov(640, 480, 60.0), F,
                                                  target=(0, 0, 0.5 * (m.z_min + m.z_max)))
    assert cam.is_central
    vp = cam.vanishing_points(np.array([axis, -axis]))
    assert vp.valid[0, 0] and not vp.valid[1].any()
    assert np.allclose(vp.uv[0, 0], [319.5, 239.5], atol=1e-9)
    assert abs(vp.mirror_points[0, 0, 2] - (m.z_min if upper else m.z_max)) < 1e-12 * m.scale
    assert np.allclose(cam.directions_from_vanishing_points(vp.uv[0, 0]), axis, atol=1e-12)
