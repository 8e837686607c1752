"""Ground truth of one view, computed by our float64 code (never read back from a renderer).

* the label image (:func:`catadioptric.render.tracer.trace_rays`);
* the image of every line segment: the exact image pieces of
  :meth:`CatadioptricCamera.segment_image` (every vertex an exact forward projection,
  neighbours at most ``max_step_px`` apart), each vertex with its parameter ``t`` on the
  segment, its mirror point and two flags: ``in_image`` and ``visible`` (the reflected
  ray from the mirror point reaches the segment without another scene object in the way,
  traced in float64). :func:`line_curves_sampled` is an independent implementation (exact
  projections of samples refined by bisection) that the tests compare with it;
* each family's vanishing points, of ``+s`` and of ``-s``, with their visibility
  (:meth:`CatadioptricCamera.vanishing_points`, exact);
* the vanishing curve of the ground plane (the horizontal plane of W,
  :meth:`CatadioptricCamera.vanishing_curve`);
* a preview PNG drawing all of these over the beauty image.
"""
from __future__ import annotations

import io
import zipfile
from dataclasses import dataclass

import numpy as np

from .._checks import CatadioptricError
from .._io import jsonable
from .tracer import TracedRays, scene_bvh, trace_rays

__all__ = ["GroundTruth", "ground_truth", "line_curves", "line_curves_sampled", "write_npz", "read_npz",
           "preview_image", "groundtruth_json", "FORMAT"]

FORMAT = "catadioptric-groundtruth/1"


# ------------------------------------------------------------------ line images
@dataclass
class Curve:
    """One connected image piece of a segment: ``t (M,)`` on the segment (0 at its first end,
    1 at its second), ``uv (M, 2)``, ``mirror_points (M, 3)`` in M, ``in_image (M,)``."""

    segment: int
    t: np.ndarray
    uv: np.ndarray
    mirror_points: np.ndarray
    in_image: np.ndarray
    visible: np.ndarray = None


def _project(cam, pts):
    pr = cam.project(pts)
    return pr.uv, pr.mirror_points, pr.valid, pr.in_image


def _far_apart(uv1, v1, uv2, v2, max_step_px):
    """For pairs of samples (rows): True where a valid image of one has no valid image of the
    other within ``max_step_px`` (valid entries come first: only the first columns matter)."""
    kc = max(int(v1.sum(axis=1).max(initial=0)), int(v2.sum(axis=1).max(initial=0)), 1)
    uv1, v1, uv2, v2 = uv1[:, :kc], v1[:, :kc], uv2[:, :kc], v2[:, :kc]
    d = np.linalg.norm(uv1[:, :, None, :] - uv2[:, None, :, :], axis=-1)
    d = np.where(v1[:, :, None] & v2[:, None, :], d, np.inf)
    return np.any(v1 & (d.min(axis=2) > max_step_px), axis=1) | np.any(v2 & (d.min(axis=1) > max_step_px), axis=1)


def line_curves(cam, a_M, b_M, *, max_step_px: float = 1.0) -> list[Curve]:
    """Exact image polylines of the segments ``a_M (L, 3)`` -> ``b_M (L, 3)`` (mirror frame), from
    the geometry core's :meth:`CatadioptricCamera.segment_image`."""
    a = np.asarray(a_M, dtype=float).reshape(-1, 3)
    b = np.asarray(b_M, dtype=float).reshape(-1, 3)
    if len(a) == 0:
        return []
    L = np.linalg.norm(b - a, axis=1)
    out = []
    for i, img in enumerate(cam.segment_image(a, b, max_step_px=max_step_px)):
        for p in img.pieces:
            t = np.clip(np.asarray(p.params, dtype=float) / L[i], 0.0, 1.0)
            uv, r = np.asarray(p.uv, float), np.asarray(p.mirror_points, float)
            if len(t) > 1 and t[0] > t[-1]:  # vertices in increasing t
                t, uv, r = t[::-1], uv[::-1], r[::-1]
            out.append(Curve(i, t, uv, r, cam.pinhole.in_image(uv)))
    out.sort(key=lambda c: (c.segment, c.t[0]))
    return out


def line_curves_sampled(cam, a_M, b_M, *, max_step_px: float = 1.0, n_start: int = 33, max_rounds: int = 40,
                        min_dt: float = 1e-9) -> list[Curve]:
    """Exact image polylines of the segments ``a_M (L, 3)`` -> ``b_M (L, 3)`` (mirror frame),
    computed independently of :meth:`CatadioptricCamera.segment_image`.

    Every vertex is an exact forward projection; samples are refined (bisection, all
    segments batched, only the intervals still too coarse) where neighbouring images are
    more than ``max_step_px`` apart or where the number of observable images changes (the
    ends of each piece, down to ``min_dt``), then chained to the nearest image of the next
    sample.
    """
    a = np.asarray(a_M, dtype=float).reshape(-1, 3)
    b = np.asarray(b_M, dtype=float).reshape(-1, 3)
    L = len(a)
    if L == 0:
        return []
    seg = np.repeat(np.arange(L), n_start)
    t = np.tile(np.linspace(0.0, 1.0, n_start), L)
    uv, r, valid, inimg = _project(cam, a[seg] + t[:, None] * (b - a)[seg])
    left = np.flatnonzero(seg[1:] == seg[:-1])
    right = left + 1
    for _ in range(max_rounds):
        need = _far_apart(uv[left], valid[left], uv[right], valid[right], max_step_px)
        need &= t[right] - t[left] > min_dt
        if not np.any(need):
            break
        lo, hi = left[need], right[need]
        tm = 0.5 * (t[lo] + t[hi])
        sm = seg[lo]
        uvm, rm, vm, im = _project(cam, a[sm] + tm[:, None] * (b - a)[sm])
        mid = len(t) + np.arange(len(tm))
        seg, t = np.concatenate([seg, sm]), np.concatenate([t, tm])
        uv, r = np.concatenate([uv, uvm]), np.concatenate([r, rm])
        valid, inimg = np.concatenate([valid, vm]), np.concatenate([inimg, im])
        # only the two halves of each refined interval are looked at again
        left, right = np.concatenate([lo, mid]), np.concatenate([mid, hi])
    order = np.lexsort((t, seg))
    return _chain(seg[order], t[order], uv[order], r[order], valid[order], inimg[order], 2.0 * max_step_px)


def _chain(seg, t, uv, r, valid, inimg, max_link) -> list[Curve]:
    """Link each valid image to the nearest valid image of the next sample of the same segment."""
    n = len(seg)
    K = max(int(valid.sum(axis=1).max(initial=0)), 1)  # valid entries come first
    uv, r, valid, inimg = uv[:, :K], r[:, :K], valid[:, :K], inimg[:, :K]
    nxt = np.full((n, K), -1, dtype=np.int64)
    has_pred = np.zeros((n, K), bool)
    same = np.r_[seg[1:] == seg[:-1], False]
    d = np.full((n, K, K), np.inf)
    d[:-1] = np.linalg.norm(uv[:-1, :, None, :] - uv[1:, None, :, :], axis=-1)
    d[:-1] = np.where(valid[:-1, :, None] & valid[1:, None, :] & same[:-1, None, None], d[:-1], np.inf)
    # greedy matching per interval: the closest pairs first (K is small)
    for _ in range(K):
        flat = d.reshape(n, -1)
        j = np.argmin(flat, axis=1)
        best = flat[np.arange(n), j]
        ok = best <= max_link
        if not np.any(ok):
            break
        rows = np.nonzero(ok)[0]
        k1, k2 = j[rows] // K, j[rows] % K
        nxt[rows, k1] = k2
        has_pred[rows + 1, k2] = True
        d[rows, k1, :] = np.inf
        d[rows, :, k2] = np.inf
    curves = []
    for i0, k0 in np.argwhere(valid & ~has_pred):
        idx_i, idx_k = [i0], [k0]
        i, k = i0, k0
        while nxt[i, k] >= 0:
            k = nxt[i, k]
            i += 1
            idx_i.append(i)
            idx_k.append(k)
        ii, kk = np.array(idx_i), np.array(idx_k)
        curves.append(Curve(int(seg[i0]), t[ii], uv[ii, kk], r[ii, kk], inimg[ii, kk]))
    curves.sort(key=lambda c: (c.segment, c.t[0]))
    return curves


def _visibility(scene, pose, curves: list[Curve], seg_W, radius, labels) -> None:
    """Set ``visible`` on every curve vertex: the reflected ray from its mirror point reaches the
    segment point before any other triangle (a tube of the segment's own label may be hit first)."""
    if not curves:
        return
    bvh = scene_bvh(scene)
    r_M = np.concatenate([c.mirror_points for c in curves])
    sid = np.concatenate([np.full(len(c.t), c.segment) for c in curves])
    tt = np.concatenate([c.t for c in curves])
    P = seg_W[sid, 0] + tt[:, None] * (seg_W[sid, 1] - seg_W[sid, 0])
    o = (r_M - pose.t) @ pose.R
    v = P - o
    dist = np.linalg.norm(v, axis=1)
    tol = np.maximum(radius[sid], 1e-9 * dist) * (1 + 1e-9)
    # only what lies before the point (minus the tolerance) can hide it
    hits = bvh.intersect(o, v / dist[:, None], t_max=dist - tol)
    hit_label = bvh.labels_of(hits)
    own = (labels[sid] > 0) & (hit_label == labels[sid])
    vis = ~np.isfinite(hits.t) | own
    k = 0
    for c in curves:
        c.visible = vis[k:k + len(c.t)]
        k += len(c.t)


def _segment_radius(scene) -> np.ndarray:
    """The tube radius of each segment: ``scene.segment_radius`` when given, else measured on the
    segment's tube mesh (largest distance of its vertices from the axis), else 0."""
    L = len(scene.segments)
    given = getattr(scene, "segment_radius", None)
    if given is not None:
        out = np.asarray(given, dtype=float)
        if out.shape != (L,):
            raise CatadioptricError(f"scene.segment_radius: expected shape ({L},), got {out.shape}")
        return out
    out = np.zeros(L)
    by_label = {int(o.label): o for o in scene.objects}
    for i, (lab, (a, b)) in enumerate(zip(scene.segment_label, scene.segments)):
        o = by_label.get(int(lab))
        if o is None or int(lab) == 0:
            continue
        u = (b - a) / np.linalg.norm(b - a)
        w = o.vertices - a
        out[i] = float(np.max(np.linalg.norm(w - (w @ u)[:, None] * u, axis=1)))
    return out


# ----------------------------------------------------------------- ground truth
@dataclass
class GroundTruth:
    view: str
    camera: dict
    pose: dict
    labels: np.ndarray
    curves: list
    vp: dict          # arrays over families: uv (F, K, 2), mirror_points, sign, visible, in_image
    ground_curve: list
    ambiguous: np.ndarray = None  # (H, W) pixels whose first surface ties with another label's
    line_images: str = "core"

    def arrays(self) -> dict:
        """The arrays of groundtruth.npz (see docs/formats.md, "Datasets")."""
        c = self.curves
        off = np.cumsum([0] + [len(x.t) for x in c]).astype(np.int64)
        cat = lambda f, tail: (np.concatenate([getattr(x, f) for x in c]) if c else np.zeros((0,) + tail))
        g = self.ground_curve
        goff = np.cumsum([0] + [len(x.uv) for x in g]).astype(np.int64)
        gcat = lambda f: np.concatenate([getattr(x, f) for x in g]) if g else np.zeros((0, 2 if f == "uv" else 3))
        return {
            "label_ambiguous": (np.zeros(self.labels.shape, bool) if self.ambiguous is None
                                else np.asarray(self.ambiguous, bool)),
            "line_curve_offsets": off,
            "line_curve_segment": np.array([x.segment for x in c], dtype=np.int64),
            "line_t": cat("t", ()).astype(np.float64),
            "line_uv": cat("uv", (2,)).astype(np.float64),
            "line_mirror_points": cat("mirror_points", (3,)).astype(np.float64),
            "line_in_image": cat("in_image", ()).astype(bool),
            "line_visible": cat("visible", ()).astype(bool),
            "vp_uv": self.vp["uv"],
            "vp_mirror_points": self.vp["mirror_points"],
            "vp_sign": self.vp["sign"].astype(np.int8),
            "vp_visible": self.vp["visible"],
            "vp_in_image": self.vp["in_image"],
            "ground_curve_offsets": goff,
            "ground_curve_closed": np.array([x.closed for x in g], dtype=bool),
            "ground_curve_uv": gcat("uv"),
            "ground_curve_mirror_points": gcat("mirror_points"),
            "ground_curve_directions_W": gcat("directions") @ np.asarray(self.pose["R"]) if g else np.zeros((0, 3)),
        }


def _vp_arrays(cam, dirs_M) -> dict:
    if len(dirs_M) == 0:
        z = np.zeros((0, 1))
        return {"uv": np.zeros((0, 1, 2)), "mirror_points": np.zeros((0, 1, 3)), "sign": z.astype(np.int8),
                "visible": z.astype(bool), "in_image": z.astype(bool)}
    vp = cam.vanishing_points(dirs_M, which="both")
    return {"uv": vp.uv, "mirror_points": vp.mirror_points, "sign": vp.sign, "visible": vp.visible,
            "in_image": vp.in_image}


LINE_IMAGES = {"core": line_curves, "sampled": line_curves_sampled}


def ground_truth(scene, cam, pose, *, view: str = "view", traced: TracedRays | None = None,
                 max_step_px: float = 1.0, line_images: str = "core") -> GroundTruth:
    """All the ground truth of one view (see the module docstring).

    ``line_images``: ``"core"`` (:meth:`CatadioptricCamera.segment_image`, the default) or
    ``"sampled"`` (:func:`line_curves_sampled`: the same curves to within the chord error of
    1-pixel steps on the scenes of the tests, about 20 times faster)."""
    if line_images not in LINE_IMAGES:
        raise CatadioptricError(f"line_images: expected one of {sorted(LINE_IMAGES)}, got {line_images!r}")
    if traced is None:
        traced = trace_rays(scene, cam, pose)
    seg_W = np.asarray(scene.segments, dtype=float).reshape(-1, 2, 3)
    seg_M = seg_W @ pose.R.T + pose.t
    curves = LINE_IMAGES[line_images](cam, seg_M[:, 0], seg_M[:, 1], max_step_px=max_step_px)
    _visibility(scene, pose, curves, seg_W, _segment_radius(scene), np.asarray(scene.segment_label, np.int64))
    fam_M = np.asarray(scene.families, dtype=float).reshape(-1, 3) @ pose.R.T
    vp = _vp_arrays(cam, fam_M)
    ground = cam.vanishing_curve(pose.R @ np.array([0.0, 0.0, 1.0]), max_step_px=max_step_px)
    return GroundTruth(view, cam.to_dict(), pose.to_dict(), traced.labels, curves, vp, ground, traced.ambiguous,
                       line_images)


def groundtruth_json(gt: GroundTruth, scene, extra: dict | None = None) -> dict:
    """The JSON part of a view's ground truth (the arrays go to groundtruth.npz)."""
    labels, counts = np.unique(gt.labels, return_counts=True)
    fam = np.asarray(scene.families, dtype=float).reshape(-1, 3)
    R = np.asarray(gt.pose["R"])
    arr = gt.arrays()
    off = arr["line_curve_offsets"]
    per_seg = {}
    for ci, s in enumerate(arr["line_curve_segment"]):
        a, b = off[ci], off[ci + 1]
        e = per_seg.setdefault(int(s), {"curves": 0, "vertices": 0, "visible_vertices": 0, "in_image_vertices": 0})
        e["curves"] += 1
        e["vertices"] += int(b - a)
        e["visible_vertices"] += int(arr["line_visible"][a:b].sum())
        e["in_image_vertices"] += int(arr["line_in_image"][a:b].sum())
    fams = []
    for f in range(len(fam)):
        pts = []
        for k in range(gt.vp["sign"].shape[1]):
            sg = int(gt.vp["sign"][f, k])
            if sg == 0:
                continue
            pts.append({"sign": sg, "uv": gt.vp["uv"][f, k].tolist(), "mirror_point": gt.vp["mirror_points"][f, k].tolist(),
                        "visible": bool(gt.vp["visible"][f, k]), "in_image": bool(gt.vp["in_image"][f, k])})
        fams.append({"index": f, "direction_W": fam[f].tolist(), "direction_M": (R @ fam[f]).tolist(),
                     "vanishing_points": pts})
    lines = []
    for i, (s, f, lab) in enumerate(zip(np.asarray(scene.segments), scene.segment_family, scene.segment_label)):
        lines.append({"index": i, "family": int(f), "label": int(lab), "ends_W": np.asarray(s).tolist(),
                      **per_seg.get(i, {"curves": 0, "vertices": 0, "visible_vertices": 0, "in_image_vertices": 0})})
    out = {
        "format": FORMAT,
        "view": gt.view,
        "camera": gt.camera,
        "pose": gt.pose,
        "labels": {"file": "labels.png", "counts": {str(int(k)): int(c) for k, c in zip(labels, counts)},
                   "ambiguous_pixels": int(arr["label_ambiguous"].sum())},
        "objects": [{"label": int(o.label), "name": o.name, "kind": o.kind} for o in scene.objects],
        "families": fams,
        "lines": lines,
        "line_images": gt.line_images,
        "ground_plane": {"normal_W": [0.0, 0.0, 1.0], "curves": len(gt.ground_curve),
                         "closed": [bool(c.closed) for c in gt.ground_curve],
                         "vertices": [int(len(c.uv)) for c in gt.ground_curve]},
        "arrays": {"file": "groundtruth.npz", "names": sorted(arr)},
    }
    if extra:
        out.update(extra)
    return jsonable(out)


# ------------------------------------------------------------------------- npz
def write_npz(arrays: dict) -> bytes:
    """Byte-deterministic .npz (numpy's savez stamps the current time into the zip)."""
    from numpy.lib import format as npformat

    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", compression=zipfile.ZIP_DEFLATED) as z:
        for name in sorted(arrays):
            b = io.BytesIO()
            npformat.write_array(b, np.ascontiguousarray(arrays[name]), allow_pickle=False)
            info = zipfile.ZipInfo(name + ".npy", date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = 0o644 << 16
            z.writestr(info, b.getvalue())
    return buf.getvalue()


def read_npz(path) -> dict:
    with np.load(path, allow_pickle=False) as z:
        return {k: z[k] for k in z.files}


# ----------------------------------------------------------------------- preview
_PALETTE = [(230, 25, 75), (60, 180, 75), (255, 225, 25), (0, 130, 200), (245, 130, 48), (145, 30, 180),
            (70, 240, 240), (240, 50, 230), (210, 245, 60), (250, 190, 212), (0, 128, 128), (220, 190, 255)]


def preview_image(beauty: np.ndarray, gt: GroundTruth, scene) -> np.ndarray:
    """RGB uint8 preview: the beauty image (upscaled to about 640 px wide) with each line's
    image (family colours; thin where hidden), each family's vanishing points (filled disc:
    ``+s``, ring: ``-s``; visible ones only) and the ground plane's vanishing curve (white)."""
    import cv2

    H, W = beauty.shape[:2]
    s = int(min(4, max(1, round(640 / W))))
    img = cv2.resize(np.ascontiguousarray(beauty[..., ::-1]), (W * s, H * s), interpolation=cv2.INTER_NEAREST)
    SH = 4  # fixed-point bits of cv2 coordinates

    def pts(uv):
        return np.round(((uv + 0.5) * s - 0.5) * (1 << SH)).astype(np.int32).reshape(-1, 1, 2)

    fam = np.asarray(scene.segment_family)
    for c in gt.ground_curve:
        if len(c.uv) > 1:
            cv2.polylines(img, [pts(c.uv)], bool(c.closed), (0, 0, 0), 3, cv2.LINE_AA, SH)
            cv2.polylines(img, [pts(c.uv)], bool(c.closed), (255, 255, 255), 1, cv2.LINE_AA, SH)
    for c in gt.curves:
        col = _PALETTE[int(fam[c.segment]) % len(_PALETTE)][::-1]
        vis = c.visible if c.visible is not None else np.ones(len(c.t), bool)
        # draw runs of equal visibility
        edges = np.flatnonzero(np.diff(vis.astype(np.int8))) + 1
        for a, b in zip(np.r_[0, edges], np.r_[edges, len(vis)]):
            seg = c.uv[max(a - 1, 0):b] if a > 0 else c.uv[a:b]
            if len(seg) > 1:
                cv2.polylines(img, [pts(seg)], False, col if vis[a] else tuple(x // 3 for x in col),
                              2 if vis[a] else 1, cv2.LINE_AA, SH)
    F, K = gt.vp["sign"].shape
    for f in range(F):
        col = _PALETTE[f % len(_PALETTE)][::-1]
        for k in range(K):
            if not gt.vp["visible"][f, k]:
                continue
            p = pts(gt.vp["uv"][f, k][None])[0, 0]
            rad = 6 << SH
            if gt.vp["sign"][f, k] > 0:
                cv2.circle(img, tuple(int(x) for x in p), rad, col, -1, cv2.LINE_AA, SH)
                cv2.circle(img, tuple(int(x) for x in p), rad, (0, 0, 0), 1, cv2.LINE_AA, SH)
            else:
                cv2.circle(img, tuple(int(x) for x in p), rad, col, 2, cv2.LINE_AA, SH)
    return np.ascontiguousarray(img[..., ::-1])
