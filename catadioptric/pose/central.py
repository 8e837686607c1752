"""The translation direction from lines: where two lines meet.

Two views of a central camera see each line only through its interpretation plane, and two
planes always meet: lines alone say nothing about the translation. Two lines of different
families that meet in 3-D (the edges of one facade, a window's corner) do: the ray through
their meeting point is the intersection of their two planes, in each view, and that pair of
rays obeys the epipolar constraint ``t' . (R x_A x x_B) = 0``, with ``t'`` the displacement
between the two viewpoints (``t' = R c_A + t - c_B``). Pairs of lines that do not meet (most
pairs) give outliers: the direction ``t'`` comes from RANSAC over two correspondences, a
least-squares refinement on the inliers, and its sign from the side on which the points lie
(cheirality). It is a direction only: a central camera has no metric scale.

The same holds for a non-central rig with planes through the point ``c`` nearest all its rays:
the plane through ``c`` that holds each fitted line (which a near-central rig fixes far better
than the line's distance) meets the other line's plane along the ray from ``c`` through the
lines' meeting point, exactly. There it gives a robust start for the metric refinement and
tells rotation candidates apart whatever the rig's centrality.

A line's image covers half of its great circle (from one vanishing point to the other, through
the direction of the line's point nearest the viewpoint); the meeting ray of two lines must lie
on both halves, which orients it and rejects many pairs at once.
"""
from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations

import numpy as np

__all__ = ["CrossingFit", "translation_direction_from_crossings"]


@dataclass
class CrossingFit:
    """``t``: unit displacement ``R c_A + t - c_B`` between the centres ``c`` of the two views (frame
    B; the viewpoints of a central camera); ``cov (3, 3)`` (on the tangent
    plane of ``t``); ``cost``: truncated (MSAC) cost over all meeting rays, ``sum min(r^2 / sigma^2, c2)``
    (chi-square units, for ranking rotation candidates: a wrong rotation turns the true
    meeting points into outliers); ``n_crossings``: candidate meeting rays, ``n_inliers``; ``n_lines``:
    lines matched in both views; ``threshold_rad``: the inlier threshold."""

    t: np.ndarray
    cov: np.ndarray
    cost: float
    n_crossings: int
    n_inliers: int
    n_lines: int
    threshold_rad: float


def _rad_per_px(cam) -> float:
    """Median angle between the rays of neighbouring pixels (radians per pixel)."""
    pin = getattr(cam, "pinhole", None)
    w, h = (pin.width, pin.height) if pin is not None else (cam.width or 640, cam.height or 480)
    u, v = np.meshgrid(np.linspace(0, w - 2, 24), np.linspace(0, h - 2, 18))
    g = np.stack([u.ravel(), v.ravel()], 1)
    r0, r1 = cam.backproject(g), cam.backproject(g + [1.0, 0.0])
    ok = r0.valid & r1.valid
    if not ok.any():
        return 1e-3
    c = np.clip(np.sum(r0.directions[ok] * r1.directions[ok], 1), -1, 1)
    return float(np.median(np.arccos(c)))


def _half_circle_side(view, est, k):
    """Unit ``u`` in the line's plane, normal to its direction, on the side its pixels are seen."""
    n = est.normals[k]
    s = est.direction
    u = np.cross(n, s)
    u /= np.linalg.norm(u)
    r = view.cam.backproject(view.uv[est.lines[k]][est.inliers[k]])
    d = r.directions[r.valid]
    if len(d) and np.mean(d @ u) < 0:
        u = -u
    return u


def _meeting_rays(view, est_i, ki, est_j, kj):
    """The oriented ray where lines (est_i, ki) and (est_j, kj) meet, or None when their planes
    meet outside the seen half of either line."""
    x = np.cross(est_i.normals[ki], est_j.normals[kj])
    nx = np.linalg.norm(x)
    if nx < 1e-9:
        return None
    x /= nx
    ui, uj = _half_circle_side(view, est_i, ki), _half_circle_side(view, est_j, kj)
    if x @ ui < 0:
        x = -x
    if x @ uj <= 0:
        return None
    return x


def translation_direction_from_crossings(view_a, view_b, ea, eb, keys, R, *, sigma_px: float = 1.0, seed: int = 0,
                                         trials: int = 400, c2: float = 9.0):
    """The displacement direction between the centres of two views, given ``R``.

    ``ea``, ``eb``: ``{family: FamilyEstimate}`` of each view (``normals``: planes through the
    view's ``centre``); ``keys``:
    the families used; lines are matched by their ``line_id``. Returns a :class:`CrossingFit`,
    or None when fewer than two pairs of lines meet in both views."""
    ids_a = {}
    for key in keys:
        for k, i in enumerate(ea[key].lines):
            if view_a.line_id[i] is not None:
                ids_a[view_a.line_id[i]] = (key, k)
    matched = []
    for key in keys:
        for k, i in enumerate(eb[key].lines):
            lid = view_b.line_id[i]
            if lid is not None and lid in ids_a and ids_a[lid][0] == key:
                matched.append((key, ids_a[lid][1], k))
    xa, xb = [], []
    for (f1, a1, b1), (f2, a2, b2) in combinations(matched, 2):
        if f1 == f2:
            continue
        ra = _meeting_rays(view_a, ea[f1], a1, ea[f2], a2)
        rb = _meeting_rays(view_b, eb[f1], b1, eb[f2], b2)
        if ra is not None and rb is not None:
            xa.append(ra)
            xb.append(rb)
    if len(xa) < 2:
        return None
    xa, xb = np.array(xa), np.array(xb)
    Rxa = xa @ R.T
    A = np.cross(Rxa, xb)
    na = np.linalg.norm(A, axis=1)
    good = na > 1e-9
    A, Rxa, xb = A[good] / na[good, None], Rxa[good], xb[good]
    if len(A) < 2:
        return None
    thr = 3.0 * max(sigma_px, 0.3) * max(_rad_per_px(view_a.cam), _rad_per_px(view_b.cam)) * np.sqrt(2.0)
    rng = np.random.default_rng(seed)
    pairs = list(combinations(range(len(A)), 2))
    if len(pairs) > trials:
        pick = rng.choice(len(pairs), trials, replace=False)
        pairs = [pairs[i] for i in pick]
    P = np.array(pairs)
    T = np.cross(A[P[:, 0]], A[P[:, 1]])
    nt = np.linalg.norm(T, axis=1)
    T = T[nt > 1e-9] / nt[nt > 1e-9, None]
    if len(T) == 0:
        return None
    res = np.abs(T @ A.T)  # sine of the angle of each meeting ray to the epipolar plane
    score = np.sum(np.minimum(res**2 / thr**2, 1.0), axis=1)
    t = T[int(np.argmin(score))]
    for _ in range(5):  # least squares on the inliers
        inl = np.abs(A @ t) <= thr
        if inl.sum() < 2:
            break
        t_new = np.linalg.eigh(A[inl].T @ A[inl])[1][:, 0]
        t = t_new if t_new @ t >= 0 else -t_new
    inl = np.abs(A @ t) <= thr
    # cheirality: lambda R x_A + t = mu x_B with lambda, mu > 0 for the right sign
    votes = 0
    for k in np.nonzero(inl)[0]:
        M = np.stack([Rxa[k], -xb[k]], axis=1)
        lm = np.linalg.lstsq(M, -t, rcond=None)[0]
        votes += 1 if (lm[0] > 0 and lm[1] > 0) else (-1 if (lm[0] < 0 and lm[1] < 0) else 0)
    if votes < 0:
        t = -t
    sig_r = thr / 3.0
    r2 = (A @ t) ** 2 / sig_r**2
    cost = float(np.sum(np.minimum(r2, c2)))  # MSAC: an outlier costs c2, whatever its residual
    e1 = np.cross(t, [1.0, 0.0, 0.0] if abs(t[0]) < 0.8 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    E = np.stack([e1, np.cross(t, e1)], 1)
    J = A[inl] @ E
    cov = E @ np.linalg.pinv(J.T @ J) @ E.T * sig_r**2 if inl.sum() >= 2 else np.full((3, 3), np.nan)
    return CrossingFit(t=t, cov=cov, cost=cost, n_crossings=len(A), n_inliers=int(inl.sum()), n_lines=len(matched),
                       threshold_rad=float(thr))
