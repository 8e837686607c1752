"""The scene's scale in the two-view refinement of a non-central rig: where it starts, and whether
the pixels fix it at all.

A non-central rig tells a line's distance only through the spread of its reflected rays (millimetres
to centimetres against lines metres away), so scaling the whole scene (the baseline and every line
together) changes the pixels little: for a rig near the central configuration, by less than their
noise. The refinement's cost is then flat along the scale, with shallow minima in the lines'
distances, and where the free refinement stops along that valley moves the rotation by tenths of a
degree (docs/relative_pose.md, "The scale: far unless the pixels tell it").

* :func:`scale_by_search`: the starting length of the translation, from the matched lines'
  pixels.
* :func:`refine_far_or_free`: the refinement twice, with the scene held far away (near the
  central limit of the rig: the baseline ``far`` mirror sizes long and every line with it) and
  with the scale free (:func:`far_and_free_fits`); the free fit is the answer only where the
  pixels tell the scale: it explains them better (:func:`common_gap`: both fits scored on every
  pixel with one loss, the free one better by more than ``tau``, a likelihood ratio with one
  degree of freedom) *and* its own covariance places the scene short of infinity (the baseline's
  length more than ``1 / max_scale_std`` deviations from zero, a Wald test at the same level);
  otherwise the far fit, scaled to the free fit's length. The answer says which
  (:attr:`~catadioptric.pose.bundle.TwoViewFit.scale_held`).
"""
from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field, replace

import numpy as np

from .._checks import CatadioptricError, as_count, as_scalar
from .bundle import TwoViewData, TwoViewFit, TwoViewOptions, TwoViewStart, refine_two_view
from .translation import triangulate_lines

__all__ = ["FAR", "TAU", "MAX_SCALE_STD", "ScaleOptions", "scale_by_search", "refine_far_or_free", "far_and_free_fits",
           "far_start", "common_gap", "pixel_distances"]

FAR = 1e4  # the held baseline, in mirror sizes (QuadricMirror.scale): 500-750 m for the presets' mirrors
TAU = 6.63  # chi-square of one degree of freedom at 99 %: what the free scale must gain to be kept
# the free fit's baseline length over its deviation must exceed sqrt(TAU) (normal, two-sided 99 %): the
# largest relative deviation of a length the pixels tell
MAX_SCALE_STD = 1.0 / np.sqrt(TAU)


@dataclass(frozen=True, kw_only=True)
class ScaleOptions:
    """How :func:`refine_far_or_free` chooses between the free fit and the far one."""

    #: the far fit's baseline, in mirror sizes (the larger mirror's ``QuadricMirror.scale``)
    far: float = FAR
    #: what the free fit must gain on common ground (:func:`common_gap`, chi-square units) to be kept
    tau: float = TAU
    #: the largest relative deviation of the free fit's baseline length for it to be kept
    max_scale_std: float = MAX_SCALE_STD
    #: the options of both refinements (:class:`~catadioptric.pose.bundle.TwoViewOptions`); their
    #: ``hold_scale`` and ``release_scale`` are set by :func:`refine_far_or_free` itself
    refine: TwoViewOptions = field(default_factory=TwoViewOptions)
    #: the two refinements run side by side in this many threads (2; the compiled kernels release
    #: the GIL): the same answers, sooner on a machine with a core to spare; 1: one after the other,
    #: for a process among others that already keep every core busy
    threads: int = 2


def scale_by_search(va, vb, lines, dirs, R, t_dir, offset, sigma, n_pixels=12):
    """The length ``alpha`` of ``t = alpha t_dir + offset`` at which the matched lines, triangulated
    from both views, best fit their pixels (a truncated sum of squared pixel distances, on a few
    pixels per line): a coarse search over 0.25 to 64 metres in octaves, then a parabola in
    ``log alpha`` through the best and its neighbours. ``va``, ``vb``: the views
    (:class:`~catadioptric.pose.families.ViewLines`); ``lines``: per matched line ``(family
    index, uv_A, uv_B)``; ``dirs``: the families' directions in A. A near-central rig hardly tells
    the lengths apart: the search then ends at a bound of its range, and
    :func:`refine_far_or_free` decides whether the pixels fix the scale."""
    from ..linefit.distances import closest_depths, depth_refine

    def few(uv):
        return uv[np.unique(np.round(np.linspace(0, len(uv) - 1, min(n_pixels, len(uv)))).astype(int))]

    sub = [(f, few(ua), few(ub)) for f, ua, ub in lines]
    fam = np.array([f for f, _, _ in sub], dtype=int)
    uv_a = np.concatenate([u for _, u, _ in sub])
    uv_b = np.concatenate([u for _, _, u in sub])
    own_a = np.repeat(np.arange(len(sub)), [len(u) for _, u, _ in sub])
    own_b = np.repeat(np.arange(len(sub)), [len(u) for _, _, u in sub])
    ra, rb = va.cam.backproject(uv_a), vb.cam.backproject(uv_b)
    # every length of the search at once: line j at the k-th length is line k L + j
    logs = np.log(0.25) + np.log(2.0) * np.arange(9)
    ts = np.exp(logs)[:, None] * t_dir + offset  # (K, 3)
    K, L = len(ts), len(sub)
    oa, da, la = ra.origins[ra.valid], ra.directions[ra.valid], own_a[ra.valid]
    ob, db, lb = rb.origins[rb.valid], rb.directions[rb.valid] @ R, own_b[rb.valid]
    o = np.concatenate([np.tile(oa, (K, 1)), ((ob[None] - ts[:, None]) @ R).reshape(-1, 3)])
    d = np.concatenate([np.tile(da, (K, 1)), np.tile(db, (K, 1))])
    line = np.concatenate([(np.arange(K)[:, None] * L + la).ravel(), (np.arange(K)[:, None] * L + lb).ravel()])
    s_kl = np.tile(dirs[fam], (K, 1))
    q, _ = triangulate_lines(s_kl, o, d, line)
    cap = (3.0 * sigma) ** 2
    costs = np.zeros(K)
    for cam, uv, own, q_v, s_v in ((va.cam, uv_a, own_a, q, s_kl),
                                   (vb.cam, uv_b, own_b, q.reshape(K, L, 3) @ R.T + ts[:, None], s_kl @ R.T)):
        idx = (np.arange(K)[:, None] * L + own).ravel()  # each pixel at each length
        qq, ss = q_v.reshape(-1, 3)[idx], s_v.reshape(-1, 3)[idx]
        uvk = np.tile(uv, (K, 1))
        r = cam.backproject(uvk)
        lam0 = closest_depths(qq, ss, np.nan_to_num(r.origins), np.nan_to_num(r.directions))
        _, dist, _, _ = depth_refine(cam, qq, ss, uvk, lam0, iters=2)
        loss = np.minimum(np.where(np.isfinite(dist), dist, np.inf) ** 2, cap)
        costs += loss.reshape(K, -1).sum(axis=1)
    k = int(np.argmin(costs))
    if 0 < k < len(logs) - 1:
        c0, c1, c2 = costs[k - 1:k + 2]
        den = c0 - 2.0 * c1 + c2
        if den > 0:
            return float(np.exp(logs[k] + 0.5 * np.log(2.0) * (c0 - c2) / den))
    return float(np.exp(logs[k]))


def _baseline(fit, ca, cb):
    """The fit's baseline between the views' centres, its length, and the relative deviation of
    that length (from the fit's translation covariance)."""
    b = fit.R @ ca + fit.t - cb
    k = float(np.linalg.norm(b))
    if k == 0.0:
        return b, k, float("inf")
    u = b / k
    return b, k, float(np.sqrt(max(u @ fit.cov[3:, 3:] @ u, 0.0)) / k)


def _held_at_length(held, free, ca, cb):
    """The far fit scaled about view A's centre to the free fit's baseline length: rotation,
    directions and the scene's shape from the far fit, its size from the free fit. Covariance:
    the far fit's, its translation scaled with the scene, the baseline's length with the free
    fit's deviation."""
    b, k, _ = _baseline(held, ca, cb)
    _, k_free, _ = _baseline(free, ca, cb)
    r = k_free / k
    t = r * b - held.R @ ca + cb
    s = held.directions[held.line_family]
    q = ca + r * (held.points - ca)
    q = q - np.sum(q * s, axis=1, keepdims=True) * s  # each line's point nearest A's origin
    cov = held.cov.copy()
    cov[3:, :] *= r
    cov[:, 3:] *= r
    u = b / k
    P = np.eye(3) - np.outer(u, u)
    cov[3:, 3:] = P @ cov[3:, 3:] @ P + np.outer(u, u) * float(u @ free.cov[3:, 3:] @ u)
    cov[:3, 3:] = cov[:3, 3:] @ P
    cov[3:, :3] = cov[:3, 3:].T
    return replace(held, t=t, points=q, cov=cov)


def refine_far_or_free(data: TwoViewData, start: TwoViewStart, options: ScaleOptions = ScaleOptions()) -> TwoViewFit:
    """:func:`~catadioptric.pose.bundle.refine_two_view` with the scene held far unless the pixels
    fix its scale.

    ``data`` and ``start`` as for :func:`~catadioptric.pose.bundle.refine_two_view` (``data.centres``:
    ``(c_A, c_B)``, required here); ``options``: :class:`ScaleOptions` (``far``, ``tau``,
    ``max_scale_std`` below; ``refine``: the refinements' options, except ``hold_scale`` and
    ``release_scale``, which must keep their defaults). Two fits (:func:`far_and_free_fits`):

    * free: from ``start.t`` and ``start.points`` as given;
    * far: the start scaled about the centres (the baseline between them ``far`` times the larger
      mirror's size, every line with it; not shrunk when it is already longer) and the scale held
      there. The rig then sees every line nearly as from its central limit: the fit has the
      unknowns of the central approximation, with the rig's exact rays.

    The pixels tell the scale when the free fit explains them better than the far one by more than
    ``tau`` on common ground (:func:`common_gap`: every pixel given, one truncated quadratic loss,
    the pixels' noise as the free fit estimates it, or ``pixel_sigma``) and its baseline's length
    has a relative deviation below ``max_scale_std`` (its own covariance; default
    ``1 / sqrt(tau)``: the inverse of the length, zero for the far fit's scene at infinity, is
    then more than ``sqrt(tau)`` deviations from zero): the free fit is then the answer. A gap
    with the length unknown is not the scale's doing: the free fit has stopped in another minimum
    of its lines, which on the relative-pose benchmark gave the worse rotation more often than not
    (docs/relative_pose.md, "The scale: far unless the pixels tell it"). Otherwise the answer is
    the far fit scaled to the free fit's length: its rotation,
    family directions and the scene's shape, the free fit's size, whose deviation (in the
    covariance, along the baseline) says how poorly the pixels know it. The fit records the choice
    (``scale_held``), the gap (``far_gap``, far minus free) and the free fit's relative deviation
    of its baseline's length (``scale_std``).

    With exact pixels the far fit misses them by the rig's non-centrality and the free fit is
    kept. With noisy pixels both fits can stop in different local minima of a cost that is nearly
    flat along the scale: the gap is then a likelihood ratio between two minima rather than a
    nested test, and the free fit it keeps is not always the better rotation (docs/relative_pose.md,
    "The scale: far unless the pixels tell it", has the figures)."""
    far = as_scalar(options.far, "far", positive=True)
    tau = as_scalar(options.tau, "tau")
    if tau < 0:
        raise CatadioptricError(f"tau: expected a cost difference of at least 0, got {tau!r}")
    max_scale_std = as_scalar(options.max_scale_std, "max_scale_std", positive=True)
    refine, default = options.refine, TwoViewOptions()
    for k in ("hold_scale", "release_scale"):
        if getattr(refine, k) != getattr(default, k):
            raise CatadioptricError(f"options.refine.{k}: set by refine_far_or_free itself, expected the default "
                                    f"{getattr(default, k)!r}, got {getattr(refine, k)!r}")
    if data.centres is None:
        raise CatadioptricError("data.centres: expected (c_A, c_B), required by refine_far_or_free, got None")
    threads = as_count(options.threads, "threads", minimum=1, maximum=2)
    free, held = far_and_free_fits(data, start, refine, far=far, threads=threads)
    ca, cb = (np.asarray(c, float) for c in data.centres)
    _, _, std = _baseline(free, ca, cb)
    if held is None:
        return replace(free, scale_held=False, far_gap=float("inf"), scale_std=std)
    gap = common_gap(free, held, data.cam_a, data.cam_b, data.uv_a, data.owner_a, data.uv_b, data.owner_b,
                     cap=refine.inlier_sigmas, sigma=refine.pixel_sigma)
    if gap > tau and std < max_scale_std:
        return replace(free, scale_held=False, far_gap=gap, scale_std=std)
    return replace(_held_at_length(held, free, ca, cb), scale_held=True, far_gap=gap, scale_std=std)


def far_and_free_fits(data: TwoViewData, start: TwoViewStart, options: TwoViewOptions = TwoViewOptions(), *,
                      far: float = FAR, threads: int = 2) -> tuple[TwoViewFit, TwoViewFit | None]:
    """The two refinements :func:`refine_far_or_free` chooses between, ``(free, far)``: free from
    the start given; far from the start scaled about the centres (``data.centres``, required) until
    the baseline is ``far`` times the larger mirror's size (not shrunk when already longer), every
    line with it, and the scale held there. ``options``: those of both refinements (the far one's
    ``hold_scale`` and ``release_scale`` set here). The far fit is None when the start or the free
    fit has no baseline to scale (the two views' centres meet). ``threads``: 2, the two fits side by
    side (each is independent of the other: the same answers to the bit as one after the other);
    1, one after the other."""
    R0 = np.asarray(start.R, float)
    ca, cb = (np.asarray(c, float) for c in data.centres)
    data = replace(data, centres=(ca, cb))
    free_start = replace(start, R=R0)
    if float(np.linalg.norm(R0 @ ca + np.asarray(start.t, float) - cb)) == 0.0:
        return refine_two_view(data, free_start, options), None
    t_far, points_far = far_start(data.cam_a, data.cam_b, R0, start.t, start.points, centres=(ca, cb), far=far)
    far_args = (data, TwoViewStart(R0, t_far, start.directions, points_far),
                replace(options, hold_scale=True, release_scale=0.0))
    if threads > 1:
        with ThreadPoolExecutor(1) as pool:
            held_future = pool.submit(refine_two_view, *far_args)
            free = refine_two_view(data, free_start, options)
            held = held_future.result()
    else:
        free = refine_two_view(data, free_start, options)
        held = refine_two_view(*far_args)
    if float(np.linalg.norm(free.R @ ca + free.t - cb)) == 0.0:
        return free, None
    return free, held


def far_start(cam_a, cam_b, R, t, points, *, centres, far: float = FAR):
    """A two-view state scaled about the views' centres until the baseline between them is ``far``
    times the larger mirror's size (not shrunk when already longer), every line with it:
    ``(t, points)`` at that scale, the rotation unchanged. The baseline must not be zero."""
    ca, cb = (np.asarray(c, float) for c in centres)
    base = R @ ca + np.asarray(t, float) - cb
    f = max(1.0, far * max(cam_a.mirror.scale, cam_b.mirror.scale) / float(np.linalg.norm(base)))
    return f * base - R @ ca + cb, ca + f * (np.asarray(points, float) - ca)


def pixel_distances(fit: TwoViewFit, cam_a, cam_b, uv_a, owner_a, uv_b, owner_b) -> np.ndarray:
    """Every pixel's distance to the image of its line in a two-view fit, ``(M_A + M_B,)`` (A's
    pixels, then B's; inf where the line has no image near the pixel)."""
    from ..linefit.distances import closest_depths, depth_refine

    s = fit.directions[fit.line_family]
    out = []
    for cam, uv, own, R, t in ((cam_a, uv_a, owner_a, np.eye(3), np.zeros(3)), (cam_b, uv_b, owner_b, fit.R, fit.t)):
        uv = np.asarray(uv, float).reshape(-1, 2)
        own = np.asarray(own, int).reshape(-1)
        q, d = fit.points[own] @ R.T + t, s[own] @ R.T
        r = cam.backproject(uv)
        lam0 = closest_depths(q, d, np.nan_to_num(r.origins), np.nan_to_num(r.directions))
        _, dist, _, _ = depth_refine(cam, q, d, uv, lam0, iters=5)
        out.append(np.where(r.valid & np.isfinite(dist), dist, np.inf))
    return np.concatenate(out)


def common_gap(free: TwoViewFit, held: TwoViewFit, cam_a, cam_b, uv_a, owner_a, uv_b, owner_b, *, cap: float = 3.5,
               sigma: float | None = None) -> float:
    """How much better the free fit explains the pixels than the far one, on common ground: over
    every pixel given, ``sum min((d / sigma)^2, cap^2)`` of the far fit minus that of the free fit
    (chi-square units, a truncated quadratic as in MSAC), ``sigma`` the pixels' noise (given, or
    the free fit's estimate). Both fits are scored on the same pixels with the same loss, whichever
    pixels each kept as its inliers."""
    sig = float(sigma) if sigma is not None else float(free.sigma)
    if not np.isfinite(sig) or sig <= 0:
        sig = float(held.sigma) if np.isfinite(held.sigma) and held.sigma > 0 else 1.0
    cost = [float(np.sum(np.minimum((pixel_distances(f, cam_a, cam_b, uv_a, owner_a, uv_b, owner_b) / sig) ** 2,
                                    cap ** 2))) for f in (free, held)]
    return cost[1] - cost[0]
