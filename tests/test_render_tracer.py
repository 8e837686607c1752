"""The float64 label tracer: BVH against brute force, label conventions, ties, errors."""
import numpy as np
import pytest

import catadioptric as cd
from catadioptric.render.testscene import box_mesh, street_scene, street_views
from catadioptric.render.tracer import (LABEL_MIRROR_AGAIN, LABEL_NO_MIRROR, LABEL_SKY, TriangleBVH, scene_bvh,
                                        trace_labels, trace_rays)
from catadioptric.rigs import preset
from catadioptric.scenes import Scene, SceneObject


def brute_hits(o, d, tri):
    """Distances ``(rays, triangles)`` of every ray to every triangle (inf where it misses), float64."""
    v0, e1, e2 = tri[:, 0], tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    p = np.cross(d[:, None], e2[None])
    det = np.einsum("tk,rtk->rt", e1, p)
    s = o[:, None] - v0[None]
    with np.errstate(divide="ignore", invalid="ignore"):
        u = np.einsum("rtk,rtk->rt", s, p) / det
        q = np.cross(s, e1[None])
        v = np.einsum("rk,rtk->rt", d, q) / det
        t = np.einsum("tk,rtk->rt", e2, q) / det
        ok = (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0)
    return np.where(ok, t, np.inf)


def brute_force(o, d, tri):
    """Nearest hit of every ray against every triangle (float64, no acceleration)."""
    t = brute_hits(o, d, tri)
    return t.min(axis=1), np.where(np.isfinite(t.min(axis=1)), t.argmin(axis=1), -1)


@pytest.fixture(scope="module")
def street():
    return street_scene(0)


def test_bvh_equals_brute_force(street):
    verts = np.concatenate([o.vertices for o in street.objects])
    offs = np.cumsum([0] + [len(o.vertices) for o in street.objects])
    faces = np.concatenate([o.faces + k for o, k in zip(street.objects, offs)])
    labels = np.concatenate([np.full(len(o.faces), o.label) for o in street.objects])
    bvh = TriangleBVH(verts, faces, labels)
    rng = np.random.default_rng(1)
    # origins in the street, outside every closed mesh (from inside a building, its bottom face and
    # the ground coincide: no first hit is defined there)
    o = rng.uniform([-30, -6.5, 0.5], [30, 6.5, 6], (3000, 3))
    d = rng.normal(size=(3000, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    hits = bvh.intersect(o, d)
    t_ref, i_ref = brute_force(o, d, verts[faces])
    assert np.array_equal(np.isfinite(hits.t), np.isfinite(t_ref))
    f = np.isfinite(t_ref)
    assert np.allclose(hits.t[f], t_ref[f], rtol=1e-12, atol=0)
    assert np.array_equal(bvh.labels_of(hits)[f], labels[i_ref[f]])
    # the triangle reported is a nearest one (ties on shared edges may pick either)
    i = bvh.original_index(hits.triangle)[f]
    tri = verts[faces][i]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    t_plane = np.einsum("ij,ij->i", tri[:, 0] - o[f], n) / np.einsum("ij,ij->i", d[f], n)
    assert np.allclose(t_plane, t_ref[f], rtol=1e-9, atol=0)


def test_bvh_windows_and_excluded_labels(street):
    verts = np.concatenate([o.vertices for o in street.objects])
    offs = np.cumsum([0] + [len(o.vertices) for o in street.objects])
    faces = np.concatenate([o.faces + k for o, k in zip(street.objects, offs)])
    labels = np.concatenate([np.full(len(o.faces), o.label) for o in street.objects])
    bvh = TriangleBVH(verts, faces, labels)
    rng = np.random.default_rng(2)
    o = rng.uniform([-30, -6.5, 0.5], [30, 6.5, 6], (2000, 3))
    d = rng.normal(size=(2000, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    lo, hi = rng.uniform(0, 10, 2000), rng.uniform(10, 40, 2000)
    ex = rng.integers(0, 5, 2000)  # labels 1..4 excluded on some rays, 0 excludes nothing
    hits = bvh.intersect(o, d, t_min=lo, t_max=hi, exclude_labels=ex)
    t = brute_hits(o, d, verts[faces])
    t[(labels[None] == ex[:, None]) | (t <= lo[:, None]) | (t >= hi[:, None])] = np.inf
    ref = t.min(axis=1)
    assert np.array_equal(np.isfinite(hits.t), np.isfinite(ref))
    f = np.isfinite(ref)
    assert np.allclose(hits.t[f], ref[f], rtol=1e-12, atol=0) and f.sum() > 300
    assert not np.any(bvh.labels_of(hits)[f] == ex[f])


def test_pixel_rays_follow_the_mirror(street):
    cam = preset("hyperboloid_9pct", width=64, height=48)
    name, pose = street_views("hyperboloid_9pct")[0]
    tr = trace_rays(street, cam, pose)
    rays = cam.backproject(cam.pinhole.pixel_grid())
    assert np.array_equal(tr.labels == LABEL_NO_MIRROR, ~rays.hit)
    ok = rays.valid
    # hits lie on the reflected rays, in W
    P = tr.origins_W[ok] + tr.t[ok][:, None] * tr.directions_W[ok]
    hit = np.isfinite(tr.t[ok])
    P_M = pose.to_mirror(P[hit])
    o_M, d_M = rays.origins[ok][hit], rays.directions[ok][hit]
    w = P_M - o_M
    assert np.max(np.linalg.norm(np.cross(w, d_M), axis=1) / np.linalg.norm(w, axis=1)) < 1e-12
    assert np.array_equal(tr.labels[ok] == LABEL_SKY, ~np.isfinite(tr.t[ok]))
    assert np.array_equal(trace_labels(street, cam, pose), tr.labels)


def test_reflected_ray_meeting_the_mirror_again_is_minus_two():
    # inside a sphere: most reflected rays meet the sphere again, some leave through the hole
    m = cd.QuadricMirror.sphere(0.05, z_min=-0.05, z_max=0.03)
    cam = cd.CatadioptricCamera.looking_at_mirror(m, cd.PinholeCamera.from_fov(40, 30, 100.0), [0.0, 0.01, 0.0],
                                                  target=(0, 0, -0.05))
    pose = cd.RigPose.from_mirror_in_world(np.diag([1.0, -1, -1]), [0, 0, 2.0])
    lab = trace_labels(street_scene(0), cam, pose)
    rays = cam.backproject(cam.pinhole.pixel_grid())
    assert np.array_equal(lab == LABEL_MIRROR_AGAIN, rays.hit & ~rays.valid)
    assert (lab == LABEL_MIRROR_AGAIN).sum() > 100 and (lab > 0).sum() > 100


def _two_boxes(gap):
    """A red box and a blue box side by side along x, ``gap`` apart (0: faces coplanar and touching)."""
    a = box_mesh([-2, -1, 0], [0, 1, 1])
    b = box_mesh([gap, -1, 0], [2 + gap, 1, 1])
    c = box_mesh([-3, -3, 2], [3, 3, 2.5])  # a slab above: rays from below end on it
    objs = [SceneObject("a", 1, *a, (1, 0, 0)), SceneObject("b", 2, *b, (0, 0, 1)),
            SceneObject("roof", 3, *c, (0.5, 0.5, 0.5))]
    return Scene(objs, np.zeros((0, 2, 3)), np.zeros(0, np.int64), np.zeros((0, 3)), np.zeros(0, np.int64))


def test_coplanar_overlap_is_flagged_ambiguous():
    # two squares in the same plane overlapping: the first surface along a ray is not defined
    sq = lambda x0, x1: (np.array([[x0, -1, 1.0], [x1, -1, 1.0], [x1, 1, 1.0], [x0, 1, 1.0]]),
                         np.array([[0, 1, 2], [0, 2, 3]]))
    objs = [SceneObject("a", 1, *sq(-1.0, 0.5), (1, 0, 0)), SceneObject("b", 2, *sq(-0.5, 1.0), (0, 0, 1))]
    scene = Scene(objs, np.zeros((0, 2, 3)), np.zeros(0, np.int64), np.zeros((0, 3)), np.zeros(0, np.int64))
    cam = preset("paraboloid", width=80, height=60)
    # the rig upside down 0.5 m below the squares (its reflected rays go mostly along -z_M)
    pose = cd.RigPose.from_mirror_in_world(np.diag([1.0, -1, -1]), [0.0, 0.0, 0.5])
    tr = trace_rays(scene, cam, pose)
    P = tr.origins_W + tr.t[..., None] * tr.directions_W
    both = np.isfinite(tr.t) & (np.abs(P[..., 0]) < 0.49) & (np.abs(P[..., 1]) < 0.99)
    only = np.isfinite(tr.t) & ((np.abs(P[..., 0]) > 0.51) | (np.abs(P[..., 1]) > 1.0))
    assert both.sum() > 20 and only.sum() > 20
    assert tr.ambiguous[both].all()
    assert not tr.ambiguous[only].any()
    # touching but not overlapping boxes are not ties
    tr2 = trace_rays(_two_boxes(0.0), cam, cd.RigPose.from_mirror_in_world(np.eye(3), [0.0, 0.0, 1.6]))
    assert {1, 2, 3} <= set(np.unique(tr2.labels).tolist())
    assert not tr2.ambiguous.any()


def test_bvh_errors():
    with pytest.raises(cd.CatadioptricError, match=r"faces: expected vertex indices in \[0, 3\), got range \[0, 3\]"):
        TriangleBVH(np.eye(3), np.array([[0, 1, 3]]))
    with pytest.raises(cd.CatadioptricError, match=r"faces: expected an integer array of shape \(F, 3\)"):
        TriangleBVH(np.eye(3), np.array([[0.0, 1.0, 2.0]]))
    bvh = TriangleBVH(np.eye(3), np.array([[0, 1, 2]]))
    with pytest.raises(cd.CatadioptricError, match=r"origins, directions: expected the same shape"):
        bvh.intersect(np.zeros((2, 3)), np.ones((3, 3)))
    with pytest.raises(cd.CatadioptricError, match=r"directions: expected finite values, got nan"):
        bvh.intersect(np.zeros((1, 3)), np.array([[np.nan, 0, 1]]))
    bad = Scene([SceneObject("x", 0, np.eye(3), np.array([[0, 1, 2]]), (1, 1, 1))], np.zeros((0, 2, 3)),
                np.zeros(0, np.int64), np.zeros((0, 3)), np.zeros(0, np.int64))
    with pytest.raises(cd.CatadioptricError, match=r"scene.objects\[0\].label: expected a positive label"):
        scene_bvh(bad)


def test_exact_ties_go_to_the_first_triangle_whatever_the_batch():
    """Two copies of one triangle with different labels: every ray hits both at exactly the same
    distance; the first of the input triangles wins, traced alone or among other rays."""
    tri = np.array([[0.0, 0.0, 5.0], [4.0, 0.0, 5.0], [0.0, 4.0, 5.0]])
    ev, ef = box_mesh([10.0, 10.0, 0.0], [11.0, 11.0, 1.0])
    for order, want in (((1, 2), 1), ((2, 1), 2)):
        verts = np.concatenate([tri, tri, ev])
        faces = np.concatenate([[[0, 1, 2], [3, 4, 5]], ef + 6])
        labels = np.r_[order, np.full(len(ef), 7)]
        bvh = TriangleBVH(verts, faces, labels)
        rng = np.random.default_rng(3)
        o = np.c_[rng.uniform(0.2, 1.5, (500, 2)), np.zeros(500)]
        d = np.tile([0.0, 0.0, 1.0], (500, 1))
        alone = [bvh.labels_of(bvh.intersect(o[i:i + 1], d[i:i + 1]))[0] for i in range(0, 500, 50)]
        batch = bvh.labels_of(bvh.intersect(o, d))
        assert np.all(batch == want) and alone == [want] * 10


def test_pixel_rays_are_the_backprojection_shared_per_rig():
    from catadioptric.render.tracer import pixel_rays

    cam = preset("sphere", width=40, height=30)
    rays = pixel_rays(cam)
    want = cam.backproject(cam.pinhole.pixel_grid())
    for k in ("origins", "directions", "valid", "hit"):
        assert np.array_equal(getattr(rays, k), getattr(want, k), equal_nan=k in ("origins", "directions"))
        assert not getattr(rays, k).flags.writeable
    assert pixel_rays(preset("sphere", width=40, height=30)) is rays  # the same rig: computed once
    other = pixel_rays(preset("sphere", width=20, height=30))
    assert other is not rays and other.valid.shape == (30, 20)
