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

import numpy as np

__all__ = ["MeetingRays", "meeting_rays", "CrossingFit", "translation_direction_from_crossings"]


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


@dataclass
class MeetingRays:
    """Where pairs of lines of different families meet, seen from each view's centre: unit rays
    ``xa (K, 3)`` (frame A) and ``xb (K, 3)`` (frame B), oriented towards the meeting point;
    ``n_lines``: lines matched in both views; ``rad_per_px``: the coarser view's angle per pixel.
    Most pairs of lines do not meet in 3-D: their rays are outliers."""

    xa: np.ndarray
    xb: np.ndarray
    n_lines: int
    rad_per_px: float


def _sides(view, est):
    """Per line of a family: unit ``u`` in its plane, normal to its direction, on the side its
    pixels are seen (a line's image is the half of its great circle around ``u``)."""
    s = est.direction
    u = np.cross(est.normals, s)
    u /= np.maximum(np.linalg.norm(u, axis=1, keepdims=True), 1e-300)
    for k, line in enumerate(est.lines):
        r = view.cam.backproject(view.uv[line][est.inliers[k]])
        d = r.directions[r.valid]
        if len(d) and np.mean(d @ u[k]) < 0:
            u[k] = -u[k]
    return u


def _meeting(n_i, u_i, n_j, u_j):
    """The oriented rays where the planes of lines i and j meet on the seen half of both (NaN rows
    where they do not)."""
    x = np.cross(n_i, n_j)
    nx = np.linalg.norm(x, axis=-1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        x = x / nx
    x = np.where(np.sum(x * u_i, -1, keepdims=True) < 0, -x, x)
    ok = (nx[..., 0] > 1e-9) & (np.sum(x * u_j, -1) > 0)
    return np.where(ok[..., None], x, np.nan)


def meeting_rays(view_a, view_b, ea, eb, keys) -> MeetingRays | None:
    """The meeting rays of every pair of lines of different families matched in both views (by
    ``line_id``), or None when there are fewer than two."""
    rows = {"A": [], "B": []}
    for view, est, side in ((view_a, ea, "A"), (view_b, eb, "B")):
        for key in keys:
            e = est[key]
            u = _sides(view, e)
            for k, i in enumerate(e.lines):
                lid = view.line_id[i]
                if lid is not None:
                    rows[side].append((lid, key, e.normals[k], u[k]))
    b_of = {r[0]: r for r in rows["B"]}
    matched = [(ra, b_of[ra[0]]) for ra in rows["A"] if ra[0] in b_of and b_of[ra[0]][1] == ra[1]]
    if len(matched) < 2:
        return None
    fam = np.array([keys.index(m[0][1]) for m in matched])
    nA = np.array([m[0][2] for m in matched])
    uA = np.array([m[0][3] for m in matched])
    nB = np.array([m[1][2] for m in matched])
    uB = np.array([m[1][3] for m in matched])
    i, j = np.triu_indices(len(matched), 1)
    keep = fam[i] != fam[j]
    i, j = i[keep], j[keep]
    xa = _meeting(nA[i], uA[i], nA[j], uA[j])
    xb = _meeting(nB[i], uB[i], nB[j], uB[j])
    ok = np.all(np.isfinite(xa), 1) & np.all(np.isfinite(xb), 1)
    if ok.sum() < 2:
        return None
    return MeetingRays(xa[ok], xb[ok], len(matched), max(_rad_per_px(view_a.cam), _rad_per_px(view_b.cam)))


def _depths(p, q, T):
    """Depths ``(lam, mu)`` of ``lam p + T = mu q`` in least squares, for rays ``p, q (K, 3)`` (unit)
    and translations ``T (H, 3)``: ``(H, K)`` each, and the rays' angle cosine ``(K,)``."""
    pq = np.sum(p * q, axis=-1)
    det = np.maximum(1.0 - pq**2, 1e-300)
    pt, qt = T @ p.T, T @ q.T
    lam = (-pt + pq * qt) / det
    mu = (qt - pq * pt) / det
    return lam, mu, pq


def _costs(A, p, q, T, thr, min_parallax, c2):
    """Truncated cost ``(H,)`` and inlier masks ``(H, K)`` of translations ``T (H, 3)``: a meeting ray is
    an inlier when it is within ``thr`` of its epipolar plane and both depths are positive (or the
    two rays are too nearly parallel for the depths to say anything)."""
    r2 = (T @ A.T) ** 2 / (thr / 3.0) ** 2
    lam, mu, pq = _depths(p, q, T)
    far = pq > np.cos(min_parallax)
    ahead = ((lam > 0) & (mu > 0)) | far[None, :]
    inl = (r2 <= c2) & ahead
    return np.sum(np.where(inl, r2, c2), axis=1), inl


def translation_direction_from_crossings(rays: MeetingRays | None, R, *, sigma_px: float = 1.0, seed: int = 0,
                                         trials: int = 300, c2: float = 9.0) -> CrossingFit | None:
    """The displacement direction between the centres of two views, given ``R``, from the rays
    where lines meet (:func:`meeting_rays`). The inlier threshold is three times
    ``max(0.5, sigma_px / 2)`` pixels (a meeting point is the crossing of two fitted curves,
    better placed than a pixel) in angle; a hypothesis' inliers must also lie in front of
    both centres. Returns a :class:`CrossingFit`, or None when no two rays are usable."""
    if rays is None:
        return None
    p = rays.xa @ R.T
    q = rays.xb
    A = np.cross(p, q)
    na = np.linalg.norm(A, axis=1)
    use = na > 1e-12
    A = A / np.maximum(na, 1e-300)[:, None]
    if use.sum() < 2:
        return None
    thr = 3.0 * max(0.5, 0.5 * sigma_px) * np.sqrt(2.0) * rays.rad_per_px
    min_parallax = 3.0 * thr
    rng = np.random.default_rng(seed)
    idx = np.flatnonzero(use)
    P = np.array([rng.choice(idx, 2, replace=False) for _ in range(trials)]) if len(idx) > 2 else idx[None]
    T = np.cross(A[P[:, 0]], A[P[:, 1]])
    nt = np.linalg.norm(T, axis=1)
    T = T[nt > 1e-9] / nt[nt > 1e-9, None]
    if len(T) == 0:
        return None
    T = np.concatenate([T, -T])  # the sign is a hypothesis too (the depths decide)
    cost, _ = _costs(A, p, q, T, thr, min_parallax, c2)
    t = T[int(np.argmin(cost))]
    thr_fit = thr
    for _ in range(8):  # least squares on the inliers, keeping the side; the threshold then follows the
        _, inl = _costs(A, p, q, t[None], thr_fit, min_parallax, c2)  # inliers' own spread (pairs of
        if inl[0].sum() < 2:  # lines that do not meet but pass close must not bias the direction)
            break
        t_new = np.linalg.eigh(A[inl[0]].T @ A[inl[0]])[1][:, 0]
        t = t_new if t_new @ t >= 0 else -t_new
        r = np.abs(A[inl[0]] @ t)
        thr_fit = min(thr, max(3.0 * 1.4826 * float(np.median(r)), 1e-12))
    cost, inl = _costs(A, p, q, t[None], thr, min_parallax, c2)
    inl = inl[0]
    sig_r = thr / 3.0
    e1 = np.cross(t, [1.0, 0.0, 0.0] if abs(t[0]) < 0.8 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    E = np.stack([e1, np.cross(t, e1)], 1)
    J = A[inl] @ E
    cov = E @ np.linalg.pinv(J.T @ J) @ E.T * sig_r**2 if inl.sum() >= 2 else np.full((3, 3), np.nan)
    return CrossingFit(t=t, cov=cov, cost=float(cost[0]), n_crossings=len(A), n_inliers=int(inl.sum()),
                       n_lines=rays.n_lines, threshold_rad=float(thr))
