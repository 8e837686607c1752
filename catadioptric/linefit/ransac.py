"""Robust starting lines: MSAC over minimal sets of pixels, or the best linear candidate."""
from __future__ import annotations

import numpy as np

from .._checks import CatadioptricError
from .distances import Pixels, linear_distances, pixels_with_rays, score_lines
from .linear import (
    all_candidates,
    candidates_from_rays,
    plane_candidates,
    pushed_out,
    ray_frame,
)


def msac_line(cam, frame, px: Pixels, rng, thr, max_trials, sample_size=4, batch=64):
    """Best line ``(6,)`` over random sets (MSAC cost ``sum min(dist^2, thr^2)`` with the
    linearised image distance): each sample gives the two lines of the 4-point Pluecker
    solver and a near-central line from 3 more pixels. Then a local optimisation (every
    candidate from the inliers of the best). Returns ``(L, inlier mask, hypotheses)``."""
    M = len(px.uv)
    o, d = px.o, px.d

    def score(L):
        dist = linear_distances(px, L)
        return np.sum(np.minimum(dist**2, thr**2), axis=1), np.sum(dist <= thr, axis=1)

    best_L, best_cost, best_cnt = None, np.inf, 0
    L = all_candidates(cam, frame, o, d)
    if len(L):
        cost, cnt = score(L)
        j = int(np.argmin(cost))
        best_L, best_cost, best_cnt = L[j], cost[j], cnt[j]
    n_hyp = len(L)
    trials, needed = 0, max_trials
    while trials < needed:
        nb = int(min(batch, needed - trials))
        perm = np.argsort(rng.random((nb, M)), axis=1)
        idx = perm[:, :sample_size]
        L, ok = candidates_from_rays(frame, o[idx], d[idx])
        L, ok = L[:, :2], ok[:, :2]  # a minimal set: the two roots only
        idx3 = perm[:, sample_size:sample_size + 3] if M >= sample_size + 3 else perm[:, :3]
        Lp, okp = plane_candidates(frame, o[idx3], d[idx3], 1, 10.0 * cam.mirror.scale)
        L = np.concatenate([L[ok], Lp[okp]])
        L = pushed_out(frame, L)
        trials += nb
        if len(L) == 0:
            continue
        n_hyp += len(L)
        cost, cnt = score(L)
        j = int(np.argmin(cost))
        if cost[j] < best_cost:
            best_L, best_cost, best_cnt = L[j], cost[j], cnt[j]
        w = best_cnt / M
        if w >= 1:
            needed = trials
        elif w > 0:
            needed = min(max_trials, int(np.ceil(np.log(0.01) / np.log1p(-w**sample_size))))
    if best_L is None:
        raise CatadioptricError(f"uv: no line at least {frame.dmin:.3g} m (min_distance) from the rays' centre "
                                f"meets the pixels' rays")
    for _ in range(3):  # local optimisation
        inl = linear_distances(px, best_L[None])[0] <= thr
        if inl.sum() < 5:
            break
        L = all_candidates(cam, frame, o[inl], d[inl])
        if len(L) == 0:
            break
        n_hyp += len(L)
        cost, _ = score(L)
        j = int(np.argmin(cost))
        if cost[j] >= best_cost:
            break
        best_L, best_cost = L[j], cost[j]
    return best_L, linear_distances(px, best_L[None])[0] <= thr, n_hyp


def best_linear(cam, frame, px: Pixels):
    """The candidate from all pixels with the smallest rms image distance (first-order distances
    for all candidates, exact ones for the few within a factor 3 of the best)."""
    L = all_candidates(cam, frame, px.o, px.d)
    if len(L) == 0:
        raise CatadioptricError("uv: the linear solver found no line meeting the pixels' rays")
    lin = linear_distances(px, L)
    lin_rms = np.sqrt(np.mean(np.minimum(lin, 1e6) ** 2, axis=1))
    order = np.argsort(lin_rms)
    keep = order[: max(1, int(np.sum(lin_rms[order[:4]] <= 3.0 * lin_rms[order[0]] + 1e-9)))]
    if len(keep) == 1:
        return L[keep[0]], len(L)
    dist, _ = score_lines(cam, L[keep], px.uv, px.o, px.d, iters=1)
    rms = np.sqrt(np.mean(np.minimum(dist, 1e6) ** 2, axis=1))
    return L[keep[int(np.argmin(rms))]], len(L)


def prepare_pixels(cam, uv, name):
    """The valid-ray mask of pixels ``uv`` and their :class:`Pixels` (the valid ones); at least 5 must see
    the world."""
    px, valid = pixels_with_rays(cam, uv)
    if int(valid.sum()) < 5:
        raise CatadioptricError(
            f"{name}: expected at least 5 pixels that see the world through the mirror, got {int(valid.sum())} "
            f"of {len(uv)}")
    sel = lambda a: a[valid]
    return valid, Pixels(sel(px.uv), sel(px.o), sel(px.d), sel(px.Jo), sel(px.Jd))


def initial_line(cam, px: Pixels, *, ransac, rng, thr, max_trials, dmin=0.0):
    """A starting line ``s, q`` for pixels ``px``, its inlier mask and the number of hypotheses: MSAC when
    ``ransac``, else the best linear candidate."""
    frame = ray_frame(cam, px.o, px.d, dmin)
    if ransac:
        L, mask, n_hyp = msac_line(cam, frame, px, rng, thr, max_trials)
        if mask.sum() < 5:
            mask = np.ones(len(px.uv), dtype=bool)
    else:
        L, n_hyp = best_linear(cam, frame, px)
        mask = np.ones(len(px.uv), dtype=bool)
    s = L[:3]
    q = np.cross(s, L[3:])
    return s, q, mask, n_hyp


