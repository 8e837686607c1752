"""PoseLib's point-based relative pose beside the label path, on the same view pairs and noise.

    catadioptric validate peers --data DATASET --views A B --noise 0 2 --draws 5 --out DIR [--label-path]
    catadioptric validate peers --spec validate/relative_pose.toml --only PAIRS --data WORK --out DIR ...

What a user would otherwise reach for is a point-based relative pose from PoseLib (the optional
extra ``peers``: ``pip install 'catadioptric[peers]'``). The peers are given the lines the label
path is given, as points: exact correspondences on the labelled 3-D lines that both views see
(:func:`point_pairs`; which point of a line matches which is more than the label path knows),
Gaussian pixel noise drawn as the label path draws its own
(:func:`catadioptric.validate.relative_pose.noise_rng`), and each noisy pixel back-projected by the
exact camera (origins and unit directions in the view's mirror frame):

* **central**: PoseLib's 5-point solver (``poselib.relpose_5pt``) on the rays' directions (their
  origins dropped: the rig taken as central);
* **generalized**: PoseLib's 6-point generalized solver (``poselib.gen_relpose_6pt``) on the rays
  with their origins: rotation and a metric translation (for a non-central rig; a central rig's rays
  share one origin and leave it nothing to find).

Each solver runs in an MSAC loop (:func:`ransac`) with PoseLib's own options and rules
(``poselib.RansacOptions()``: at least 1000 iterations, success probability 0.9999, the dynamic
trial count times 3, a local refinement of each new best model with a truncated loss over 25
iterations), then PoseLib's refinement (``poselib.refine_generalized_relative_pose``, its Cauchy
loss, at the threshold) over the inliers. Every error is the Sampson error of the epipolar constraint in
each ray's own tangent plane: each ray is a camera of its own, centred on its origin and looking
along it, that sees its point at the principal point, so the error is an angle (radians; in pixels
over the rig's angle per pixel). The threshold is ``max(1, 3 noise)`` pixels.

Why not PoseLib's front doors ``estimate_relative_pose`` and ``estimate_generalized_relative_pose``
(docs/peers.md): the first takes pixels through one pinhole-type camera per view and works in its
normalised image plane, where a ray more than 90 degrees off the camera's axis is the same point
as its opposite (a catadioptric view spans 360 degrees of azimuth); the second samples five points
seen by one camera pair and one by another (``gen_relpose_5p1pt``), which needs a rig of a few
cameras with many points each: with one ray per camera it never finds such a pair and does not
return. Their minimal solvers and their refinement take rays as they are.

Frames: ``x_B = R x_A + t`` between the mirror frames (PoseLib's ``x2 = R x1 + t``), the truth
``R_gt = R_B R_A^T``, ``t_gt = t_B - R_gt t_A`` (:func:`catadioptric.validate.relative_pose.evaluate_pair`).
The central peer's translation is a direction, compared with the direction between the two views'
ray centres (:func:`catadioptric.pose.families.rays_centre`), as the label path's central baseline.
"""
from __future__ import annotations

import sys
import time
from dataclasses import dataclass

import numpy as np

from .._checks import CatadioptricError

__all__ = ["PointPairs", "point_pairs", "PeerFit", "ransac", "central_peer", "generalized_peer", "evaluate_peers",
           "summarise", "evaluate_benchmark_peers", "threshold_px", "require_poselib", "methods_of", "SPACING_PX", "THRESHOLD_FLOOR_PX",
           "THRESHOLD_SIGMAS", "PEERS", "versus_peers"]

#: spacing of the points along each line, in pixels of arc (the mean of the two views'): 430 points
#: on the demo pair (urban_street, views A and B), as many as issue 41 measured the peers on
SPACING_PX = 7.3
#: the RANSAC threshold: ``max(THRESHOLD_FLOOR_PX, THRESHOLD_SIGMAS * noise)`` pixels (the floor is
#: PoseLib's default ``max_epipolar_error``)
THRESHOLD_FLOOR_PX = 1.0
THRESHOLD_SIGMAS = 3.0
#: the peers, in the report's order
PEERS = ("central", "generalized")
#: fine sampling of each line before the points are picked: at most this many pixels between samples
_FINE_PX = 0.5


def threshold_px(noise_px: float) -> float:
    """The RANSAC inlier threshold (pixels) at ``noise_px`` of Gaussian noise per coordinate."""
    return max(THRESHOLD_FLOOR_PX, THRESHOLD_SIGMAS * float(noise_px))


# --------------------------------------------------------------------------- points on the lines
@dataclass
class PointPairs:
    """Exact point correspondences of a view pair: ``X_W (N, 3)`` on the labelled lines, their
    pixels ``uv_a``, ``uv_b (N, 2)`` (exact forward projections), the ``segment`` and ``family`` of
    each; ``lines``: the lines that gave at least one point; ``spacing_px``."""

    X_W: np.ndarray
    uv_a: np.ndarray
    uv_b: np.ndarray
    segment: np.ndarray
    family: np.ndarray
    lines: int
    spacing_px: float


def _seen(view, X_W, label):
    """Pixels of the world points ``X_W`` in ``view`` and where the line ``label`` shows there: the
    first image of each point on the image, its label within one pixel (the occluded are not)."""
    from ..observations import label_near

    pr = view["camera"].project(view["pose"].to_mirror(X_W))
    uv = pr.uv[:, 0]
    ok = pr.in_image[:, 0].copy()
    if ok.any():
        ok[ok] = label_near(view["labels"], uv[ok], label)
    return uv, ok


def _arc(uv, ok):
    """Pixel steps between consecutive samples (0 where either is not seen)."""
    step = np.linalg.norm(np.diff(uv, axis=0), axis=1)
    return np.where(ok[1:] & ok[:-1], np.nan_to_num(step), 0.0)


def point_pairs(va, vb, *, spacing: float = SPACING_PX, min_pixels: int = 30) -> PointPairs:
    """Exact point correspondences on the labelled lines both views ``va``, ``vb`` see (dataset
    views): each line with at least ``min_pixels`` pixels in both (as the label path's lines,
    :func:`catadioptric.observations.line_pixels`) is sampled finely along its 3-D segment,
    each sample projected into both views by the exact camera and kept where the line shows in both
    (on the image, its label within one pixel); along each run kept, one point every ``spacing``
    pixels of arc (the mean of the two views'), the first half a spacing in."""
    from ..observations import line_pixels

    if not (np.isfinite(spacing) and spacing > 0):
        raise CatadioptricError(f"spacing: expected a positive number of pixels, got {spacing!r}")
    la, lb = (line_pixels(v, min_pixels=min_pixels) for v in (va, vb))
    lab_a = dict(zip(la.segment, la.label))
    lab_b = dict(zip(lb.segment, lb.label))
    fam = dict(zip(la.segment, la.family))
    ends = {int(ln["index"]): np.asarray(ln["ends_W"], float) for ln in va["lines"]}
    X, UA, UB, SEG, FAM = [], [], [], [], []
    for s in sorted(set(lab_a) & set(lab_b)):
        e = ends[s]
        n = 257
        for _ in range(2):  # a coarse pass measures the arc, a fine one samples it
            t = np.linspace(0.0, 1.0, n)
            P = e[0] + t[:, None] * (e[1] - e[0])
            ua, oka = _seen(va, P, lab_a[s])
            ub, okb = _seen(vb, P, lab_b[s])
            arc = max(_arc(ua, oka).sum(), _arc(ub, okb).sum())
            n_fine = int(np.clip(np.ceil(arc / _FINE_PX) + 1, 257, 65537))
            if n_fine <= n:
                break
            n = n_fine
        both = oka & okb
        step = 0.5 * (_arc(ua, both) + _arc(ub, both))
        edges = np.flatnonzero(np.diff(np.r_[0, both.astype(np.int8), 0]))
        for a, b in zip(edges[::2], edges[1::2]):
            s_run = np.r_[0.0, np.cumsum(step[a:b - 1])]
            k = a + np.searchsorted(s_run, np.arange(0.5 * spacing, s_run[-1], spacing))
            k = np.unique(np.clip(k, a, b - 1))
            X.append(P[k])
            UA.append(ua[k])
            UB.append(ub[k])
            SEG.append(np.full(len(k), s))
            FAM.append(np.full(len(k), fam[s]))
    if not X:
        return PointPairs(np.zeros((0, 3)), np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0, int), np.zeros(0, int),
                          0, float(spacing))
    seg = np.concatenate(SEG).astype(int)
    return PointPairs(np.concatenate(X), np.concatenate(UA), np.concatenate(UB), seg,
                      np.concatenate(FAM).astype(int), int(len(np.unique(seg))), float(spacing))


# --------------------------------------------------------------------------- the peers
@dataclass
class PeerFit:
    """A peer's answer: ``R``, ``t`` (``x_B = R x_A + t``; a direction for the central peer),
    ``inliers`` (of ``points``) within the threshold after the RANSAC, its ``iterations``, the final
    refinement's ``refine_iterations``, the threshold ``threshold_rad``."""

    R: np.ndarray
    t: np.ndarray
    inliers: int
    points: int
    iterations: int
    refine_iterations: int
    threshold_rad: float


def _ray_frames(d):
    """Rotations ``(N, 3, 3)`` whose third row is each unit ray ``d``: a camera looking along it."""
    a = np.where(np.abs(d[:, [0]]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    x = np.cross(a, d)
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    return np.stack([x, np.cross(d, x), d], axis=1)


class _Rays:
    """The rays of both views as PoseLib's generalized cameras: one camera per ray (centred on its
    origin, looking along it, focal 1, its point at the principal point), one match per ray."""

    def __init__(self, poselib, oa, da, ob, db):
        self.poselib = poselib
        self.oa, self.da, self.ob, self.db = oa, da, ob, db
        self.n = len(da)
        self.ext_a = self._cameras(oa, da)
        self.ext_b = self._cameras(ob, db)
        self.cams = [poselib.Camera("SIMPLE_PINHOLE", [1.0, 0.0, 0.0], 0, 0)] * self.n
        self.matches = []
        for i in range(self.n):
            m = poselib.PairwiseMatches()
            m.cam_id1 = m.cam_id2 = i
            m.x1 = m.x2 = np.zeros((1, 2))
            self.matches.append(m)

    def _cameras(self, o, d):
        out = []
        for R, c in zip(_ray_frames(d), o):
            p = self.poselib.CameraPose()
            p.R = R
            p.t = -R @ c
            out.append(p)
        return out

    def errors2(self, Rs, ts) -> np.ndarray:
        """Squared Sampson errors ``(M, N)`` (radians squared) of models ``Rs (M, 3, 3)``, ``ts (M, 3)``:
        for rays ``(o_a, d_a)``, ``(o_b, d_b)`` and ``b = R o_a + t - o_b``, ``d_a' = R d_a``, the
        residual ``r = d_b . (b x d_a')`` over the gradient's norm in the two rays' tangent planes,
        ``2|b|^2 - (b.d_a')^2 - (b.d_b)^2 - 2 r^2``."""
        da = np.einsum("mij,nj->mni", Rs, self.da)
        b = np.einsum("mij,nj->mni", Rs, self.oa) + ts[:, None, :] - self.ob[None]
        r = np.einsum("ni,mni->mn", self.db, np.cross(b, da))
        bb = np.einsum("mni,mni->mn", b, b)
        den = 2.0 * bb - np.einsum("mni,mni->mn", b, da) ** 2 - np.einsum("mni,ni->mn", b, self.db) ** 2 - 2.0 * r * r
        return r * r / np.maximum(den, 1e-300)

    def refine(self, R, t, keep, bundle: dict):
        """PoseLib's generalized refinement of ``(R, t)`` over the rays ``keep`` (a mask)."""
        p = self.poselib.CameraPose()
        p.R = R
        p.t = t
        ms = [m for m, k in zip(self.matches, keep) if k]
        q, info = self.poselib.refine_generalized_relative_pose(ms, p, self.ext_a, self.cams, self.ext_b, self.cams,
                                                               bundle)
        return np.array(q.R), np.array(q.t).ravel(), info


def ransac(rays: _Rays, solve, size: int, threshold: float, rng, options: dict | None = None):
    """MSAC over minimal samples of ``size`` rays, PoseLib's rules (``poselib.RansacOptions``, module
    docstring): ``solve(idx)`` gives the models (PoseLib ``CameraPose``) of a sample; each new best
    model is refined locally (truncated loss at ``threshold``, 25 iterations, over the rays within
    ``sqrt(5)`` thresholds) and kept if that scores better. Returns ``(R, t, errors2, iterations)``."""
    opt = rays.poselib.RansacOptions(dict(options or {}))
    thr2 = threshold * threshold
    best = None
    best_score = np.inf
    dyn = float(opt["max_iterations"])
    it = 0
    while it < opt["max_iterations"]:
        if it > opt["min_iterations"] and it > dyn:
            break
        it += 1
        models = solve(rng.choice(rays.n, size, replace=False))
        if not models:
            continue
        Rs = np.array([m.R for m in models])
        ts = np.array([np.asarray(m.t).ravel() for m in models])
        e2 = rays.errors2(Rs, ts)
        score = np.minimum(e2, thr2).sum(axis=1)
        j = int(np.argmin(score))
        if score[j] >= best_score:
            continue
        R, t, e, s = Rs[j], ts[j], e2[j], score[j]
        near = e < 5.0 * thr2
        if near.sum() > size:
            R2, t2, _ = rays.refine(R, t, near, {"loss_type": "TRUNCATED", "loss_scale": threshold,
                                                 "max_iterations": 25})
            e_r = rays.errors2(R2[None], t2[None])[0]
            s_r = np.minimum(e_r, thr2).sum()
            if s_r < s:
                R, t, e, s = R2, t2, e_r, s_r
        best, best_score = (R, t, e), s
        w = float(np.mean(e < thr2))
        if w >= 1.0:
            dyn = 0.0
        elif w > 0.0:
            dyn = np.log(1.0 - opt["success_prob"]) / np.log(1.0 - w ** size) * opt["dyn_num_trials_mult"]
    if best is None:
        raise CatadioptricError(f"the RANSAC found no model in {it} samples of {size} of {rays.n} rays")
    return (*best, it)


def _fit(rays: _Rays, solve, size, threshold, loss, rng, options):
    R, t, e2, iterations = ransac(rays, solve, size, threshold, rng, options)
    inl = e2 < threshold * threshold
    refine_iterations = 0
    if inl.sum() > size:  # PoseLib's final refinement: its default loss (Cauchy), at the threshold by default
        R, t, info = rays.refine(R, t, inl, {"loss_scale": threshold if loss is None else loss})
        refine_iterations = int(info.get("iterations", 0))
    return PeerFit(R, t, int(inl.sum()), rays.n, int(iterations), refine_iterations, float(threshold))


def require_poselib():
    """PoseLib, or one line naming the extra that installs it."""
    from .._extras import require

    return require("poselib", "catadioptric validate peers")


def central_peer(da, db, *, threshold: float, rng, loss: float | None = None, options: dict | None = None) -> PeerFit:
    """The central peer: ``poselib.relpose_5pt`` on the unit rays ``da``, ``db (N, 3)`` of the two
    views in an MSAC (:func:`ransac`), then PoseLib's refinement; ``threshold`` and ``loss`` (the
    refinement's Cauchy scale, default the threshold) in radians. ``t`` is a direction."""
    pl = require_poselib()
    da, db = np.asarray(da, float), np.asarray(db, float)
    z = np.zeros_like(da)
    rays = _Rays(pl, z, da, z, db)
    fit = _fit(rays, lambda i: pl.relpose_5pt(da[i], db[i]), 5, threshold, loss, rng, options)
    fit.t = fit.t / np.linalg.norm(fit.t)
    return fit


def generalized_peer(oa, da, ob, db, *, threshold: float, rng, loss: float | None = None,
                     options: dict | None = None) -> PeerFit:
    """The generalized peer: ``poselib.gen_relpose_6pt`` on the rays (origins ``oa``, ``ob`` and unit
    directions ``da``, ``db``, each ``(N, 3)``, in the views' mirror frames) in an MSAC
    (:func:`ransac`), then PoseLib's refinement (:func:`central_peer`'s ``threshold`` and ``loss``);
    ``t`` is metric (the rays' units)."""
    pl = require_poselib()
    oa, da, ob, db = (np.asarray(x, float) for x in (oa, da, ob, db))
    rays = _Rays(pl, oa, da, ob, db)
    return _fit(rays, lambda i: pl.gen_relpose_6pt(oa[i], da[i], ob[i], db[i]), 6, threshold, loss, rng, options)


# --------------------------------------------------------------------------- one dataset pair
def _record(fit: PeerFit, R_gt, t_ref, metric: bool, seconds: float, rad_px: float) -> dict:
    from .relative_pose import angle_between_deg
    from ..pose import rotation_angle_deg

    out = {"R": fit.R, "t": fit.t, "rotation_error_deg": rotation_angle_deg(fit.R @ R_gt.T),
           "translation_direction_error_deg": angle_between_deg(fit.t, t_ref), "translation_error_m": None,
           "length_ratio": None, "seconds": seconds, "inliers": fit.inliers, "points": fit.points,
           "iterations": fit.iterations, "refine_iterations": fit.refine_iterations,
           "threshold_px": fit.threshold_rad / rad_px}
    if metric:
        out["translation_error_m"] = float(np.linalg.norm(fit.t - t_ref))
        out["length_ratio"] = float(np.linalg.norm(fit.t) / np.linalg.norm(t_ref))
    return out


def _label_record(d: dict) -> dict:
    """The label path's draw (:func:`.relative_pose.evaluate_pair`) in the peers' terms."""
    from .relative_pose import length_observable

    if "error" in d:
        return {"error": d["error"], "seconds": d.get("seconds")}
    return {"rotation_error_deg": None if d["ambiguous"] else d["rotation_error_deg"], "ambiguous": d["ambiguous"],
            "translation_direction_error_deg": d["translation_direction_error_deg"],
            "translation_error_m": d["translation_error_m"] if length_observable(d) else None,
            "seconds": d["seconds"]}


def evaluate_peers(dataset, names, *, noise_levels=(2.0,), draws: int = 1, seed=0, spacing: float = SPACING_PX,
                   min_pixels: int = 30, ransac_options: dict | None = None, loss_px: float | None = None,
                   label_path: bool = False) -> dict:
    """The PoseLib peers on the view pair ``names = (A, B)`` of ``dataset`` (a folder or a
    :class:`catadioptric.Dataset`): the points of :func:`point_pairs`, ``draws`` noise draws per
    level above 0 and one at 0 (the label path's seeds, :func:`.relative_pose.noise_rng`), each peer
    timed from the noisy pixels (back-projection, RANSAC, refinement); ``ransac_options``: PoseLib's
    (``poselib.RansacOptions``), ``loss_px``: the refinement's Cauchy scale (default the threshold,
    :func:`threshold_px`). ``label_path``: also the label
    path on the same pair, levels and draws (:func:`.relative_pose.evaluate_pair`, exact model).
    Returns the report dict."""
    from threadpoolctl import threadpool_limits

    from ..dataset import Dataset

    require_poselib()  # a missing extra fails before anything is computed
    if not (isinstance(draws, (int, np.integer)) and draws >= 1):
        raise CatadioptricError(f"draws: expected a positive integer, got {draws!r}")
    noise_levels = [float(x) for x in np.atleast_1d(noise_levels)]
    if any(not np.isfinite(x) or x < 0 for x in noise_levels):
        raise CatadioptricError(f"noise: expected non-negative pixel noise levels, got {noise_levels}")
    ds = dataset if isinstance(dataset, Dataset) else Dataset(dataset)
    ds.view_pair(names)  # two different views of the dataset, or one line saying what is wrong
    with threadpool_limits(1):
        return _evaluate(ds, list(names), noise_levels, draws, seed, spacing, min_pixels, ransac_options, loss_px,
                         label_path)


def _evaluate(ds, names, noise_levels, draws, seed, spacing, min_pixels, ransac_options, loss_px, label_path):
    from ..pose.central import rad_per_px
    from ..pose.families import is_central, rays_centre
    from .relative_pose import evaluate_pair, noise_rng

    pl = require_poselib()
    va, vb = ds[names[0]], ds[names[1]]
    pa, pb = va["pose"], vb["pose"]
    R_gt = pb.R @ pa.R.T
    t_gt = pb.t - R_gt @ pa.t
    cams = (va["camera"], vb["camera"])
    t0 = time.perf_counter()
    pts = point_pairs(va, vb, spacing=spacing, min_pixels=min_pixels)
    sample_s = time.perf_counter() - t0
    if len(pts.X_W) < 12:
        raise CatadioptricError(f"views {names[0]} and {names[1]}: {len(pts.X_W)} points on lines both see "
                                f"(at least 12 needed; --spacing {spacing:g} px sets how many)")
    central_rig = all(is_central(c) for c in cams)
    ca, cb = (rays_centre(c) for c in cams)
    t_centres = R_gt @ ca + t_gt - cb  # the central peer's translation: between the views' ray centres
    rad_px = 0.5 * (rad_per_px(cams[0]) + rad_per_px(cams[1]))
    out = {"views": names, "R_gt": R_gt, "t_gt": t_gt, "baseline_m": float(np.linalg.norm(t_gt)),
           "rig": cams[0].to_dict(), "central_rig": central_rig, "poselib": pl.__version__,
           "points": {"count": len(pts.X_W), "lines": pts.lines, "spacing_px": pts.spacing_px,
                      "per_family": {str(f): int(np.sum(pts.family == f)) for f in np.unique(pts.family)},
                      "seconds": sample_s},
           "rad_per_px": rad_px, "min_pixels": min_pixels, "ransac": pl.RansacOptions(dict(ransac_options or {})),
           "threshold": {"floor_px": THRESHOLD_FLOOR_PX, "sigmas": THRESHOLD_SIGMAS}, "loss_px": loss_px,
           "label_path": bool(label_path), "draws": []}
    for noise in noise_levels:
        for k in range(draws if noise > 0 else 1):
            draw_seed, rng = noise_rng(seed, noise, k)
            uv = [u + rng.normal(0.0, noise, u.shape) if noise > 0 else u.copy() for u in (pts.uv_a, pts.uv_b)]
            rec = {"noise_px": noise, "draw": k, "seed": draw_seed}
            thr = threshold_px(noise) * rad_px
            loss = None if loss_px is None else loss_px * rad_px
            for peer in PEERS:
                if peer == "generalized" and central_rig:
                    rec[peer] = {"skipped": "a central rig: its rays share one origin (no scale to find; the "
                                            "6-point solver is degenerate)"}
                    continue
                t0 = time.perf_counter()
                ra, rb = (c.backproject(u) for c, u in zip(cams, uv))
                ok = ra.valid & rb.valid
                try:
                    if peer == "central":
                        fit = central_peer(ra.directions[ok], rb.directions[ok], threshold=thr, loss=loss,
                                           rng=np.random.default_rng([*draw_seed, 5]), options=ransac_options)
                    else:
                        fit = generalized_peer(ra.origins[ok], ra.directions[ok], rb.origins[ok], rb.directions[ok],
                                               threshold=thr, loss=loss, rng=np.random.default_rng([*draw_seed, 6]),
                                               options=ransac_options)
                except CatadioptricError as exc:
                    rec[peer] = {"error": str(exc), "seconds": time.perf_counter() - t0}
                    continue
                sec = time.perf_counter() - t0
                rec[peer] = _record(fit, R_gt, t_centres if peer == "central" else t_gt, peer == "generalized",
                                    sec, rad_px)
            out["draws"].append(rec)
    if label_path:
        # one thread, as each peer: the seconds compare the methods, not the threads they take
        res = evaluate_pair(ds, names, noise_levels=noise_levels, draws=draws, seed=seed, min_pixels=min_pixels,
                            central=False, threads=1)
        by = {(d["noise_px"], d["draw"]): d for d in res["draws"]}
        for rec in out["draws"]:
            d = by.get((rec["noise_px"], rec["draw"]))
            if d is not None:
                rec["label_path"] = _label_record(d)
        out["label_path_pixels"] = int(sum(s["pixels"] for s in res["seen"].values()))
    out["summary"] = summarise(out["draws"], methods_of(out))
    return out


def methods_of(res: dict) -> tuple:
    """The methods a peers result holds: the peers, and the label path when it ran."""
    return (*PEERS, "label_path") if res["label_path"] else PEERS


def summarise(draws: list, methods=PEERS) -> dict:
    """Per noise level (``"2"``) and method, over the draws: how many, how many answered, and the
    median, quartiles and worst of the rotation error, the median and quartiles of the translation
    direction error, of the metric translation error and length ratio (the generalized peer), of the
    seconds and of the inliers."""
    out = {}
    for noise in sorted({d["noise_px"] for d in draws}):
        ds = [d for d in draws if d["noise_px"] == noise]
        row = {}
        for m in methods:
            recs = [d[m] for d in ds if m in d and "error" not in d[m] and "skipped" not in d[m]]

            def q(key):
                v = [r[key] for r in recs if r.get(key) is not None]
                return [float(x) for x in np.quantile(v, [0.5, 0.25, 0.75])] if v else [None] * 3

            rot = [r["rotation_error_deg"] for r in recs if r.get("rotation_error_deg") is not None]
            row[m] = {"draws": len(ds), "answered": len(rot), "skipped": sum("skipped" in d.get(m, {}) for d in ds),
                      "failed": sum("error" in d.get(m, {}) for d in ds),
                      "rotation_deg": q("rotation_error_deg"), "rotation_max_deg": max(rot, default=None),
                      "translation_direction_deg": q("translation_direction_error_deg"),
                      "translation_m": q("translation_error_m"), "length_ratio": q("length_ratio"),
                      "seconds": q("seconds"), "inliers": q("inliers")}
        out[f"{noise:g}"] = row
    return out


def versus_peers(pairs: list) -> dict:
    """The label path's rotation error against each peer's on the same pairs (``pairs``: results of
    :func:`evaluate_peers` with the label path), per noise level (``"2"``) and peer: the difference
    of their medians, label path minus peer (degrees), with its 95 % bootstrap interval resampling
    the pairs (:func:`catadioptric.validate.benchmark_report.median_difference_interval`); ``verdict``
    ``"lower"``: the label path's median error is below the peer's beyond the pairs' chance,
    ``"higher"``: above, ``"unresolved"``: the pairs do not tell. Peers that did not run (skipped) are
    left out."""
    from .benchmark_report import median_difference_interval

    def errors(r, noise, m):
        return [d[m].get("rotation_error_deg") for d in r["draws"] if d["noise_px"] == noise and m in d]

    out = {}
    for noise in sorted({d["noise_px"] for r in pairs for d in r["draws"]}):
        row = {}
        for m in PEERS:
            if all("skipped" in d.get(m, {"skipped": 1}) for r in pairs for d in r["draws"]):
                continue
            row[m] = median_difference_interval([errors(r, noise, "label_path") for r in pairs],
                                                [errors(r, noise, m) for r in pairs])
        out[f"{noise:g}"] = row
    return out


# --------------------------------------------------------------------------- the benchmark's pairs
def _pair_task(item):
    key, folder, names, kw = item
    return key, evaluate_peers(folder, names, **kw)


def evaluate_benchmark_peers(spec: dict, data: str, *, only=None, workers: int = 1, progress: bool = True,
                             **kw) -> dict:
    """The peers on the relative-pose benchmark's pairs (``spec``: :func:`catadioptric.validate.
    benchmark_spec.load_benchmark_spec`), or those of ``only`` (``(configuration, pair index)``
    tuples): each rendered into ``data`` as the benchmark renders it (resuming;
    :func:`catadioptric.validate.benchmark.render_benchmark`), then :func:`evaluate_peers` with the
    benchmark's seed of the pair (``[spec seed, pair index]``, as its label path) and ``kw``, on
    ``workers`` processes. Returns the report dict: every pair's result and, per configuration,
    :func:`summarise` over its pairs' draws."""
    from .benchmark import dataset_folder, render_benchmark
    from .benchmark_spec import pairs_of

    require_poselib()
    chosen = [(c, p) for c in spec["configs"] for p in pairs_of(spec, c) if only is None or (c["name"], p.index) in only]
    render_benchmark(spec, data, workers=workers, progress=progress, only={(c["name"], p.index) for c, p in chosen})
    tasks = [((c["name"], p.index), dataset_folder(data, c["name"], p.renderer), list(p.names),
              kw | {"seed": [spec["seed"], p.index]}) for c, p in chosen]
    t0 = time.perf_counter()
    results = {}

    def done(key, res):
        results[key] = res
        if progress:
            print(f"peers: {key[0]}:{key[1]} ({len(results)} of {len(tasks)}, {time.perf_counter() - t0:.0f} s)",
                  file=sys.stderr)

    if workers <= 1 or len(tasks) <= 1:
        for item in tasks:
            done(*_pair_task(item))
    else:
        from .._pool import imap_spawn

        for key, res in imap_spawn(_pair_task, tasks, workers):
            done(key, res)
    pairs = [results[(c["name"], p.index)] | {"config": c["name"], "rig": c["rig"], "pair": p.index,
                                              "renderer": p.renderer} for c, p in chosen]
    methods = (*PEERS, "label_path") if kw.get("label_path") else PEERS
    configs = {}
    for c in spec["configs"]:
        mine = [r for r in pairs if r["config"] == c["name"]]
        if mine:
            configs[c["name"]] = {"rig": c["rig"], "pairs": [r["pair"] for r in mine],
                                  "central_rig": mine[0]["central_rig"],
                                  "points": [float(x) for x in np.quantile([r["points"]["count"] for r in mine],
                                                                           [0.5, 0.25, 0.75])],
                                  "summary": summarise([d for r in mine for d in r["draws"]], methods)}
            if kw.get("label_path"):
                configs[c["name"]]["versus"] = versus_peers(mine)
    return {"spec": spec["name"], "resolution": spec["resolution"], "seed": spec["seed"],
            "pairs_chosen": [f"{c['name']}:{p.index}" for c, p in chosen], "label_path": bool(kw.get("label_path")),
            "workers": workers, "seconds": time.perf_counter() - t0, "configs": configs, "pairs": pairs}
