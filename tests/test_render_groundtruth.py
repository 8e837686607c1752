"""Ground truth of a view: exact line images, their labels in rendered images, vanishing
points and the ground plane's vanishing curve, the JSON/NPZ files and the preview."""
import io
import json

import numpy as np
import pytest

from catadioptric.render.groundtruth import (ground_truth, groundtruth_json, line_curves, line_curves_sampled,
                                             preview_image, read_npz, write_npz)
from catadioptric.render.mitsuba import render_mitsuba
from catadioptric.render.povray import render_povray
from catadioptric.render.testscene import street_scene, street_views
from catadioptric.render.tracer import trace_rays
from catadioptric.rigspec import load_rig

W, H = 160, 120
RADIUS = 0.3  # thick tubes: their images are several pixels wide


@pytest.fixture(scope="module", params=["hyperboloid_9pct", "sphere"])
def view(request):
    rig = request.param
    scene = street_scene(0, tube_radius=RADIUS)
    cam = load_rig(rig, width=W, height=H)
    pose = street_views(rig)[1][1]
    tr = trace_rays(scene, cam, pose)
    return rig, scene, cam, pose, tr, ground_truth(scene, cam, pose, view="v", traced=tr)


def _vertices(scene, gt):
    a = gt.arrays()
    seg = np.repeat(a["line_curve_segment"], np.diff(a["line_curve_offsets"]))
    ends = np.asarray(scene.segments)
    P_W = ends[seg, 0] + a["line_t"][:, None] * (ends[seg, 1] - ends[seg, 0])
    return a, seg, P_W


def test_line_vertices_are_exact_projections(view):
    rig, scene, cam, pose, tr, gt = view
    a, seg, P_W = _vertices(scene, gt)
    assert len(seg) > 300 and len(np.unique(seg)) > 10
    rays = cam.backproject(a["line_uv"])
    assert rays.valid.all()
    P = pose.to_mirror(P_W)
    w = P - rays.origins
    miss = np.linalg.norm(np.cross(w, rays.directions), axis=1) / np.linalg.norm(w, axis=1)
    assert miss.max() < 1e-9
    assert np.abs(rays.origins - a["line_mirror_points"]).max() < 1e-9 * cam.mirror.scale
    assert np.array_equal(a["line_in_image"], cam.pinhole.in_image(a["line_uv"]))


def test_core_segment_images_agree_with_independent_sampling(view):
    # the ground truth uses CatadioptricCamera.segment_image; our bisection sampler finds the same pieces
    rig, scene, cam, pose, tr, gt = view
    seg = pose.to_mirror(np.asarray(scene.segments))
    mine = line_curves_sampled(cam, seg[:, 0], seg[:, 1])
    assert [c.segment for c in mine] == [c.segment for c in gt.curves]
    for a, b in zip(mine, gt.curves):
        assert abs(a.t[0] - b.t[0]) < 1e-6 and abs(a.t[-1] - b.t[-1]) < 1e-6
        # the sampler's vertices lie on the core's polyline (within the chord error of 1-px steps)
        q0, q1 = b.uv[:-1], b.uv[1:]
        e = q1 - q0
        w = np.clip(np.einsum("pqk,qk->pq", a.uv[:, None] - q0[None], e) / np.maximum((e * e).sum(1), 1e-300), 0, 1)
        d = np.linalg.norm(a.uv[:, None] - (q0[None] + w[..., None] * e[None]), axis=-1).min(axis=1)
        assert d.max() < 0.02, (a.segment, d.max())


def test_line_curves_are_dense_polylines(view):
    rig, scene, cam, pose, tr, gt = view
    steps = np.concatenate([np.linalg.norm(np.diff(c.uv, axis=0), axis=1) for c in gt.curves if len(c.t) > 1])
    assert steps.max() <= 2.0 and np.mean(steps <= 1.0) > 0.99
    for c in gt.curves:
        assert np.all(np.diff(c.t) > 0)


def _tube_width_px(cam, pose, scene, seg, P_W, uv, r_M):
    """Image width of the tube at each vertex: the images of the two silhouette points P +- r m."""
    d = np.asarray(scene.segments)[seg, 1] - np.asarray(scene.segments)[seg, 0]
    P = pose.to_mirror(P_W)
    m = np.cross(pose.directions_to_mirror(d), P - r_M)
    m /= np.linalg.norm(m, axis=1, keepdims=True)
    ends = []
    for sgn in (1, -1):
        pr = cam.project(P + sgn * RADIUS * m)
        dist = np.where(pr.valid, np.linalg.norm(pr.uv - uv[:, None], axis=-1), np.inf)
        k = np.argmin(dist, axis=1)
        ends.append(pr.uv[np.arange(len(k)), k])
    return np.linalg.norm(ends[0] - ends[1], axis=1)


def test_line_pixels_carry_the_line_label(view):
    # the pixel under a line's traced image shows that line (where its tube is wide and unoccluded there)
    rig, scene, cam, pose, tr, gt = view
    a, seg, P_W = _vertices(scene, gt)
    L = np.linalg.norm(np.diff(np.asarray(scene.segments), axis=1)[:, 0], axis=1)[seg]
    vis = a["line_visible"]
    steady = vis & np.r_[False, vis[:-1]] & np.r_[vis[1:], False]
    steady &= np.minimum(a["line_t"], 1 - a["line_t"]) * L > 3 * RADIUS
    nearest = np.round(a["line_uv"]).astype(int)
    ok = steady & a["line_in_image"] & cam.backproject(nearest.astype(float)).valid
    want = np.asarray(scene.segment_label)[seg]
    # exactly on the curve, the traced label is the line's wherever the vertex is visible (away from
    # the segment's ends, where the tube stops short)
    assert np.array_equal(trace_rays(scene, cam, pose, a["line_uv"][ok], ties=False).labels, want[ok])
    # at the nearest pixel centre (up to 0.71 px away): always where the tube's image is wide, and
    # mostly elsewhere (an occluding edge or the tube's silhouette may pass between the two)
    width = _tube_width_px(cam, pose, scene, seg, P_W, a["line_uv"], a["line_mirror_points"])
    wide = ok & (width > 4.0)
    assert wide.sum() > 40 and ok.sum() > 300
    col = np.clip(nearest[:, 0], 0, W - 1)
    row = np.clip(nearest[:, 1], 0, H - 1)
    labels = {"tracer": tr.labels}
    for fn in (render_mitsuba, render_povray):
        labels[fn.__name__] = fn(scene, cam, pose, "draft", beauty=False).labels
    for name, lab in labels.items():
        hit = lab[row, col] == want
        assert hit[wide].all(), name
        assert hit[ok].mean() > 0.7, (name, hit[ok].mean())


def test_vanishing_points_and_ground_curve(view):
    rig, scene, cam, pose, tr, gt = view
    fam_W = np.asarray(scene.families)
    vp = gt.vp
    seen = 0
    for f in range(len(fam_W)):
        for k in range(vp["sign"].shape[1]):
            if not vp["visible"][f, k]:
                continue
            seen += 1
            ray = cam.backproject(vp["uv"][f, k])
            s_W = pose.directions_to_world(ray.directions)
            assert np.allclose(s_W, vp["sign"][f, k] * fam_W[f], atol=1e-9)
    assert seen >= 4
    a = gt.arrays()
    assert len(a["ground_curve_uv"]) > 100
    assert np.abs(a["ground_curve_directions_W"][:, 2]).max() < 1e-12
    d = pose.directions_to_world(cam.backproject(a["ground_curve_uv"]).directions)
    assert np.abs(d[:, 2]).max() < 1e-9


def test_files_are_strict_json_deterministic_npz_and_a_preview(view):
    rig, scene, cam, pose, tr, gt = view
    j = groundtruth_json(gt, scene)
    text = json.dumps(j, allow_nan=False)
    back = json.loads(text)
    assert back["format"] == "catadioptric-groundtruth/1" and len(back["lines"]) == len(scene.segments)
    assert sum(e["visible_vertices"] for e in back["lines"]) == int(gt.arrays()["line_visible"].sum())
    assert len(back["families"]) == len(scene.families)
    blob = write_npz(gt.arrays())
    assert blob == write_npz(gt.arrays())
    arrs = read_npz(io.BytesIO(blob))
    for k, v in gt.arrays().items():
        assert np.array_equal(arrs[k], v, equal_nan=v.dtype.kind == "f"), k
    beauty = np.full((H, W, 3), 40, np.uint8)
    pv = preview_image(beauty, gt, scene)
    assert pv.shape == (H * 4, W * 4, 3) and (pv != 40).any(axis=-1).mean() > 0.01


def test_segment_outside_the_view_has_no_image():
    cam = load_rig("hyperboloid", width=W, height=H)
    # straight up the axis above the mirror: no reflected ray goes there
    for fn in (line_curves, line_curves_sampled):
        assert fn(cam, np.array([[0.0, 0.0, 1.0]]), np.array([[0.0, 0.0, 5.0]])) == []
        # straight down the axis below the camera: seen through the middle of the mirror
        [c] = fn(cam, np.array([[0.0, 0.0, -5.0]]), np.array([[0.0, 0.0, -1.0]]))
        assert c.in_image.all() and np.linalg.norm(np.diff(c.uv, axis=0), axis=1).max() <= 1.0
