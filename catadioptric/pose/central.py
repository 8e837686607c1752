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

import functools
import weakref
from dataclasses import dataclass

import numpy as np

from .rotation import skew

__all__ = ["MeetingRays", "meeting_rays", "CrossingFit", "translation_direction_from_crossings", "Parallax", "parallax",
           "PARALLAX_P", "Twins", "rotation_twins", "rotation_twins_any_family", "arc_overlap",
           "arc_on_plane",
           "rad_per_px", "sides", "meeting", "translation_costs", "truncated_residuals2", "residuals2", "residual_weights"]


@dataclass
class CrossingFit:
    """``t``: unit displacement ``R c_A + t - c_B`` between the centres ``c`` of the two views (frame
    B; the viewpoints of a central camera); ``cov (3, 3)`` (on the tangent
    plane of ``t``); ``cost``: truncated (MSAC) cost over all meeting rays, ``sum min(r^2 / sigma^2, c2)``
    (chi-square units, for ranking rotation candidates: a wrong rotation turns the true
    meeting points into outliers); ``n_crossings``: candidate meeting rays, ``n_inliers``; ``n_lines``:
    lines matched in both views; ``threshold_rad``: the inlier threshold; ``inliers (K,)``: which
    of the meeting rays are inliers."""

    t: np.ndarray
    cov: np.ndarray
    cost: float
    n_crossings: int
    n_inliers: int
    n_lines: int
    threshold_rad: float
    inliers: np.ndarray | None = None


#: each camera's angle per pixel, found once (the cameras are frozen; the image path's line matching
#: asks it of every family assignment, which cost 3 % of a pair without a motion prior)
_RAD_PER_PX: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def rad_per_px(cam) -> float:
    """Median angle between the rays of neighbouring pixels (radians per pixel); computed once per
    camera object."""
    try:
        return _RAD_PER_PX[cam]
    except (KeyError, TypeError):  # not yet, or a camera that cannot be weakly referenced
        pass
    value = _rad_per_px(cam)
    try:
        _RAD_PER_PX[cam] = value
    except TypeError:
        pass
    return value


def _rad_per_px(cam) -> float:
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
    ``n_lines``: lines matched in both views; ``rad_per_px``: the coarser view's angle per pixel;
    ``cov_a``, ``cov_b (K, 3, 3)``: each ray's covariance, propagated from its two planes' fits
    (None when the fits carry none); ``pairs``: per ray, the ``line_id`` of its two lines. Most
    pairs of lines do not meet in 3-D: their rays are outliers."""

    xa: np.ndarray
    xb: np.ndarray
    n_lines: int
    rad_per_px: float
    cov_a: np.ndarray | None = None
    cov_b: np.ndarray | None = None
    pairs: list | None = None


def sides(view, est):
    """Per line of a family: unit ``u`` in its plane, normal to its direction, on the side its
    pixels are seen (a line's image is the half of its great circle around ``u``). Computed once per
    estimate (``est.seen_sides``; independent of the direction's sign): the matching asks again for
    every family assignment."""
    if est.seen_sides is not None:
        return est.seen_sides
    s = est.direction
    u = np.cross(est.normals, s)
    u /= np.maximum(np.linalg.norm(u, axis=1, keepdims=True), 1e-300)
    # every line's inlier pixels back-projected at once
    uv = [np.asarray(view.uv[line], float).reshape(-1, 2)[est.inliers[k]] for k, line in enumerate(est.lines)]
    owner = np.repeat(np.arange(len(uv)), [len(x) for x in uv])
    if len(owner):
        r = view.cam.backproject(np.concatenate(uv))
        k = owner[r.valid]
        dot = np.bincount(k, np.sum(r.directions[r.valid] * u[k], axis=1), len(uv))
        u[dot < 0] = -u[dot < 0]
    est.seen_sides = u
    return u


def meeting(n_i, u_i, n_j, u_j):
    """The oriented rays where the planes of lines i and j meet on the seen half of both (NaN rows
    where they do not)."""
    x = np.cross(n_i, n_j)
    nx = np.linalg.norm(x, axis=-1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        x = x / nx
    x = np.where(np.sum(x * u_i, -1, keepdims=True) < 0, -x, x)
    ok = (nx[..., 0] > 1e-9) & (np.sum(x * u_j, -1) > 0)
    return np.where(ok[..., None], x, np.nan)


def _meeting_cov(x, n_i, C_i, n_j, C_j):
    """Covariance ``(K, 3, 3)`` of the unit ray ``x = +-unit(n_i x n_j)`` from those of the two normals:
    ``dx = P (dn_i x n_j + n_i x dn_j) / |n_i x n_j|``, ``P`` the projection normal to ``x``."""
    s = np.linalg.norm(np.cross(n_i, n_j), axis=-1)[:, None, None]
    P = np.eye(3) - x[:, :, None] * x[:, None, :]
    Ji = -P @ skew(n_j) / s
    Jj = P @ skew(n_i) / s
    return Ji @ C_i @ Ji.transpose(0, 2, 1) + Jj @ C_j @ Jj.transpose(0, 2, 1)


def meeting_rays(view_a, view_b, ea, eb, keys) -> MeetingRays | None:
    """The meeting rays of every pair of lines of different families matched in both views (by
    ``line_id``), or None when there are fewer than two."""
    rows = {"A": [], "B": []}
    for view, est, side in ((view_a, ea, "A"), (view_b, eb, "B")):
        for key in keys:
            e = est[key]
            u = sides(view, e)
            C = e.normal_covs if e.normal_covs is not None else np.full((len(e.lines), 3, 3), np.nan)
            for k, i in enumerate(e.lines):
                lid = view.line_id[i]
                if lid is not None:
                    rows[side].append((lid, key, e.normals[k], u[k], C[k]))
    b_of = {r[0]: r for r in rows["B"]}
    matched = [(ra, b_of[ra[0]]) for ra in rows["A"] if ra[0] in b_of and b_of[ra[0]][1] == ra[1]]
    if len(matched) < 2:
        return None
    fam = np.array([keys.index(m[0][1]) for m in matched])
    nA = np.array([m[0][2] for m in matched])
    uA = np.array([m[0][3] for m in matched])
    nB = np.array([m[1][2] for m in matched])
    uB = np.array([m[1][3] for m in matched])
    CA = np.array([m[0][4] for m in matched])
    CB = np.array([m[1][4] for m in matched])
    i, j = np.triu_indices(len(matched), 1)
    keep = fam[i] != fam[j]
    i, j = i[keep], j[keep]
    xa = meeting(nA[i], uA[i], nA[j], uA[j])
    xb = meeting(nB[i], uB[i], nB[j], uB[j])
    ok = np.all(np.isfinite(xa), 1) & np.all(np.isfinite(xb), 1)
    if ok.sum() < 2:
        return None
    i, j, xa, xb = i[ok], j[ok], xa[ok], xb[ok]
    cov_a = _meeting_cov(xa, nA[i], CA[i], nA[j], CA[j])
    cov_b = _meeting_cov(xb, nB[i], CB[i], nB[j], CB[j])
    has_cov = bool(np.all(np.isfinite(cov_a)) and np.all(np.isfinite(cov_b)))
    ids = [m[0][0] for m in matched]
    return MeetingRays(xa, xb, len(matched), max(rad_per_px(view_a.cam), rad_per_px(view_b.cam)),
                       cov_a if has_cov else None, cov_b if has_cov else None,
                       [(ids[a], ids[b]) for a, b in zip(i, j)])


def _both_ahead(p, q, T):
    """Whether each pair of rays ``p, q (K, 3)`` (unit) meets in front of both centres for the
    translations ``T (H, 3)``: the depths ``(lam, mu)`` of ``lam p + T = mu q`` in least squares both
    positive, ``(H, K)``; and the rays' angle cosine ``(K,)``. The depths' common denominator
    ``1 - (p.q)^2`` is positive, so their signs are their numerators' (no division)."""
    pq = np.sum(p * q, axis=-1)
    pt, qt = T @ p.T, T @ q.T
    return ((pq * qt - pt) > 0) & ((qt - pq * pt) > 0), pq


def _cheirality_violation(p, q, T):
    """How far ``(H, K)`` (radians) each pair of rays ``p, q (K, 3)`` is from meeting in front of both
    centres, for unit displacements ``T (H, 3)`` (``c_A - c_B``): 0 when it does. In the epipolar
    plane, with ``theta`` the angle of a ray from ``T``, the rays meet in front of both exactly when
    they lie on one side of the baseline and ``theta_p >= theta_q`` (the angle they make at the
    point, their parallax); otherwise the violation is the smallest turn of the rays that makes it
    so: ``theta_q - theta_p`` on one side, and, on opposite sides (the "twisted pair" of a
    half-turn about the baseline), the turn that brings both onto the baseline,
    ``min(theta_p + theta_q, 2 pi - theta_p - theta_q)``. Unlike a test of the depths' signs, the
    violation is an angle: it is compared with the rays' noise, so that rays nearly parallel (far
    points) vote only as far as their parallax is measurable, never as a blanket exemption."""
    return _violation_of(T @ p.T, T @ q.T, np.sum(p * q, axis=-1)[None, :])


def _violation_of(cp, cq, pq):
    """:func:`_cheirality_violation` from the cosines ``cp = T.p``, ``cq = T.q`` and ``pq = p.q``
    (arrays that broadcast together; elementwise, so any subset of them gives its own values)."""
    th_p, th_q = np.arccos(np.clip(cp, -1.0, 1.0)), np.arccos(np.clip(cq, -1.0, 1.0))
    # same side of the baseline: (T x p) . (T x q) = p.q - (T.p)(T.q) > 0
    same = pq - cp * cq >= 0
    return np.where(same, np.maximum(th_q - th_p, 0.0), np.minimum(th_p + th_q, 2 * np.pi - th_p - th_q))


def translation_costs(A, p, q, T, thr, c2, W=None, ang=None, min_parallax=None):
    """Truncated cost ``(H,)`` and inlier masks ``(H, K)`` of translations ``T (H, 3)``: a meeting ray is
    an inlier when it is within ``thr`` of its epipolar plane and within ``thr`` of meeting in
    front of both centres (:func:`_cheirality_violation`). With ``W (K, 3, 3)`` and ``ang (K,)``
    (:func:`residual_weights`), each ray has its own: the residual's variance ``T' W_k T`` and
    three times ``ang_k`` for the cheirality. ``min_parallax`` (radians): instead, the depths'
    signs decide, and rays more nearly parallel than this are exempt (the rule of the matching
    of detected lines, pose/matching.py, whose meeting points carry offsets their fits do not
    know of)."""
    r2, inl = truncated_residuals2(A, p, q, T, thr, c2, W=W, ang=ang, min_parallax=min_parallax)
    return np.sum(r2, axis=1), inl


def truncated_residuals2(A, p, q, T, thr, c2, W=None, ang=None, min_parallax=None):
    """The terms of :func:`translation_costs`: squared residuals ``(H, K)`` (:func:`residuals2`), ``c2``
    for the rays that are not inliers, and the inlier masks ``(H, K)``."""
    r2 = residuals2(A, T, thr, W)
    if min_parallax is None:
        # the violation only where the residual passes (elementwise: the same values as over all)
        at = np.flatnonzero(r2 <= c2)
        k = at % r2.shape[1]  # each entry's ray
        cp, cq = (T @ p.T).ravel()[at], (T @ q.T).ravel()[at]
        ahead = np.zeros(r2.shape, dtype=bool)
        ahead.ravel()[at] = _violation_of(cp, cq, np.sum(p * q, axis=-1)[k]) <= (thr if W is None else 3.0 * ang[k])
    else:
        both, pq = _both_ahead(p, q, T)
        ahead = both | (pq > np.cos(min_parallax))[None, :]
    inl = (r2 <= c2) & ahead
    return np.where(inl, r2, c2), inl


def residuals2(A, T, thr, W=None):
    """Squared epipolar residuals ``(H, K)`` of meeting rays (normals ``A (K, 3)`` of their epipolar
    planes) for translations ``T (H, 3)``, in units of their standard deviation: ``thr / 3`` for
    all, or ``sqrt(T' W_k T)`` per ray (:func:`residual_weights`)."""
    if W is None:
        return (T @ A.T) ** 2 / (thr / 3.0) ** 2
    return (T @ A.T) ** 2 / np.einsum("hi,kij,hj->hk", T, W, T)


def residual_weights(p, q, cov_p, cov_q, floor):
    """Per meeting ray, ``W (K, 3, 3)`` such that the variance of its epipolar residual
    ``r = T . unit(p x q)`` is ``T' W T`` (first order in the rays' covariances ``cov_p``,
    ``cov_q``; ``floor``: an angle added in quadrature, for what the fits' covariances leave
    out), and ``ang (K,)``: the rays' own angular standard deviation."""
    s2 = np.sum(np.cross(p, q) ** 2, axis=1)[:, None, None]
    Sq, Sp = skew(q), skew(p)
    W = (Sq.transpose(0, 2, 1) @ cov_p @ Sq + Sp.transpose(0, 2, 1) @ cov_q @ Sp) / s2
    W = W + floor**2 * np.eye(3)
    ang = np.sqrt(np.trace(cov_p, axis1=1, axis2=2) + np.trace(cov_q, axis1=1, axis2=2) + floor**2)
    return W, ang


@functools.lru_cache(maxsize=16)
def _pair_samples(seed, trials: int, usable: bytes) -> np.ndarray:
    """``trials`` pairs ``(trials, 2)`` of distinct usable rays (``usable``: their indices' bytes),
    drawn from ``seed``; the same draws for the same arguments, kept (read-only) for the next
    call: a pose's rotation candidates ask for them again with the same rays."""
    P = _draw_pairs(np.random.default_rng(seed), np.frombuffer(usable, dtype=np.intp), trials)
    P.flags.writeable = False
    return P


def _draw_pairs(rng, idx, trials):
    return np.array([rng.choice(idx, 2, replace=False) for _ in range(trials)])


def translation_direction_from_crossings(rays: MeetingRays | None, R, *, sigma_px: float = 1.0, seed: int = 0,
                                         trials: int = 300, c2: float = 9.0) -> CrossingFit | None:
    """The displacement direction between the centres of two views, given ``R``, from the rays
    where lines meet (:func:`meeting_rays`). Each ray's residual is weighed by its own variance,
    propagated from the fits of its two lines' planes in both views (a crossing of two long,
    well-fitted lines at a wide angle is placed to a fraction of a pixel; two nearly parallel
    planes place it poorly), with a floor of a tenth of ``max(0.5, sigma_px / 2)`` pixels; rays
    with no covariance share a threshold of three times ``max(0.5, sigma_px / 2)`` pixels. A
    hypothesis' inliers must also meet in front of both centres, within their noise. Returns a
    :class:`CrossingFit`, or None when no two rays are usable."""
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
    W = ang = None
    if rays.cov_a is not None:
        W, ang = residual_weights(p, q, R @ rays.cov_a @ R.T, rays.cov_b, 0.1 * thr / 3.0)
    idx = np.flatnonzero(use)
    if len(idx) <= 2:
        P = idx[None]
    elif isinstance(seed, (int, np.integer)):
        P = _pair_samples(int(seed), trials, idx.tobytes())
    else:
        P = _draw_pairs(np.random.default_rng(seed), idx, trials)
    T = np.cross(A[P[:, 0]], A[P[:, 1]])
    nt = np.linalg.norm(T, axis=1)
    T = T[nt > 1e-9] / nt[nt > 1e-9, None]
    if len(T) == 0:
        return None
    T = np.concatenate([T, -T])  # the sign is a hypothesis too (the depths decide)
    cost, _ = translation_costs(A, p, q, T, thr, c2, W, ang)
    t = T[int(np.argmin(cost))]
    # least squares on the inliers, keeping the side; the inlier test then follows the inliers' own
    # spread, never looser than at the start (pairs of lines that do not meet but pass close, or
    # poorly placed crossings of nearly parallel planes, must not bias the direction)
    shrink = 1.0
    for _ in range(8):
        if W is None:
            _, inl = translation_costs(A, p, q, t[None], thr * shrink, c2)
            wk = np.ones(len(A))
        else:
            _, inl = translation_costs(A, p, q, t[None], thr, c2, W * shrink**2, ang)
            wk = 1.0 / np.einsum("i,kij,j->k", t, W, t)
        if inl[0].sum() < 2:
            break
        Ai = A[inl[0]] * np.sqrt(wk[inl[0]])[:, None]
        t_new = np.linalg.eigh(Ai.T @ Ai)[1][:, 0]
        t = t_new if t_new @ t >= 0 else -t_new
        z = np.abs(A[inl[0]] @ t) * np.sqrt(wk[inl[0]]) * (1.0 if W is not None else 3.0 / thr)
        shrink = min(1.0, max(1.4826 * float(np.median(z)), 1e-12))
    cost, inl = translation_costs(A, p, q, t[None], thr, c2, W, ang)
    inl = inl[0]
    wk = (3.0 / thr) ** 2 * np.ones(len(A)) if W is None else 1.0 / np.einsum("i,kij,j->k", t, W, t)
    e1 = np.cross(t, [1.0, 0.0, 0.0] if abs(t[0]) < 0.8 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    E = np.stack([e1, np.cross(t, e1)], 1)
    J = (A[inl] @ E) * np.sqrt(wk[inl])[:, None]
    cov = E @ np.linalg.pinv(J.T @ J) @ E.T if inl.sum() >= 2 else np.full((3, 3), np.nan)
    return CrossingFit(t=t, cov=cov, cost=float(cost[0]), n_crossings=len(A), n_inliers=int(inl.sum()),
                       n_lines=rays.n_lines, threshold_rad=float(thr), inliers=inl)


@dataclass
class Parallax:
    """Whether two central views show parallax under ``R``: ``chi2`` of the inlier meeting rays'
    angles between ``R x_A`` and ``x_B`` (each over its deviation), ``dof`` (two per ray),
    ``p_value`` of ``chi2`` under no motion, ``observable``: the translation is seen (``p_value``
    below :data:`PARALLAX_P`), ``n_rays``: the rays tested, ``median_deg``: their median angle."""

    chi2: float
    dof: int
    p_value: float
    observable: bool
    n_rays: int
    median_deg: float


#: a translation is reported as seen when no motion explains the meeting rays with a p-value below this
PARALLAX_P = 1e-3


def parallax(rays: MeetingRays | None, R, fit: CrossingFit | None) -> Parallax | None:
    """Does the translation show at all? A camera turned in place (on a tripod, or not moved) or
    moved by much less than its distance to the lines sees every meeting point along the same
    ray in both views, up to ``R``: the direction of ``t`` is then noise, and reporting it would
    be a wild answer. The test: the meeting rays that the crossing fit took as inliers (``fit``),
    their angles between ``R x_A`` and ``x_B``, each over its deviation (propagated from the
    planes' fits, at least a third of the fit's inlier threshold, as the fit itself weighs them),
    summed as a chi-square with two degrees of freedom per ray; no parallax when its p-value is at
    least :data:`PARALLAX_P`. None when there is nothing to test."""
    from scipy.stats import chi2 as chi2_dist

    if rays is None or fit is None or fit.inliers is None or not np.any(fit.inliers):
        return None
    k = np.flatnonzero(fit.inliers)
    p = rays.xa[k] @ np.asarray(R, float).T
    q = rays.xb[k]
    ang = np.arctan2(np.linalg.norm(np.cross(p, q), axis=1), np.sum(p * q, axis=1))
    sd = np.full(len(k), fit.threshold_rad / 3.0)
    if rays.cov_a is not None and rays.cov_b is not None:
        ca = np.asarray(R) @ rays.cov_a[k] @ np.asarray(R).T
        own = np.sqrt(0.5 * (np.trace(ca, axis1=1, axis2=2) + np.trace(rays.cov_b[k], axis1=1, axis2=2)))
        sd = np.maximum(sd, own)
    c2 = float(np.sum((ang / sd) ** 2))
    dof = 2 * len(k)
    pv = float(chi2_dist.sf(c2, dof))
    return Parallax(c2, dof, pv, pv < PARALLAX_P, len(k), float(np.degrees(np.median(ang))))


@dataclass
class Twins:
    """Lines of view A seen again in view B as they were, up to ``R`` (a camera turned in place):
    ``pairs``: ``(family, line of A, line of B)``; ``lines_a``: the lines of A's matched families
    tested."""

    pairs: list
    lines_a: int


def rotation_twins(view_a, view_b, ea, eb, keys, R, *, chi2_max: float = 9.21, floor_rad: float = 0.0,
                   overlap: float = 0.5) -> Twins:
    """The lines of A that B sees unchanged under ``R`` alone: a line of B of the same family whose
    interpretation plane is ``R`` times the A line's (the angle between the normals, sign-free,
    within ``chi2_max`` of their combined deviation (2 degrees of freedom; at least ``floor_rad``),
    and whose arc on that plane overlaps the rotated arc of A's by ``overlap`` of the shorter (the same
    segment where it was, not another line of the family in the same plane by chance). A camera
    that did not move sees nearly every line of the scene's still part so; a moving one, only
    lines far enough for the baseline not to show."""
    R = np.asarray(R, float)
    pairs, tested = [], 0
    for k in keys:
        if k not in ea or k not in eb:
            continue
        A, B = ea[k], eb[k]
        nA = A.normals @ R.T
        tested += len(A.lines)
        ang = np.arccos(np.clip(np.abs(nA @ B.normals.T), 0.0, 1.0))
        CA = A.normal_covs if A.normal_covs is not None else np.zeros((len(A.lines), 3, 3))
        CB = B.normal_covs if B.normal_covs is not None else np.zeros((len(B.lines), 3, 3))
        var_a = 0.5 * np.trace(CA, axis1=1, axis2=2)
        var_b = 0.5 * np.trace(CB, axis1=1, axis2=2)
        arcs_b = [_arc(d, B.normals[m]) for m, d in enumerate(_arc_rays(view_b, B))]
        rays_a = None  # A's lines back-projected once, when the first is tried
        used = set()
        for i in np.argsort(ang.min(axis=1)):
            var = var_a[i] + var_b + floor_rad**2
            ok = np.flatnonzero((ang[i] ** 2 <= chi2_max * var) & (var > 0))
            for m in ok[np.argsort(ang[i, ok])]:
                if m in used:
                    continue
                if rays_a is None:
                    rays_a = _arc_rays(view_a, A)
                ra = _arc(rays_a[i], B.normals[m], R)
                if ra is not None and arcs_b[m] is not None and arc_overlap(ra, arcs_b[m]) >= overlap:
                    pairs.append((k, A.lines[i], B.lines[m]))
                    used.add(m)
                    break
    return Twins(pairs, tested)


def _arc_rays(view, est):
    """Per line of ``est``, the directions ``(M_k, 3)`` of the rays of its inlier pixels that see the
    world (one back-projection for all: each row's ray is the one it gets alone)."""
    uvs = [view.uv[line][inl] for line, inl in zip(est.lines, est.inliers)]
    r = view.cam.backproject(np.concatenate(uvs) if uvs else np.zeros((0, 2)))
    cuts = np.cumsum([len(u) for u in uvs])[:-1]
    return [d[ok] for d, ok in zip(np.split(r.directions, cuts), np.split(r.valid, cuts))]


def _arc(d, n, R=None):
    """The interval of angles ``(lo, hi)`` that a line's rays ``d`` (:func:`_arc_rays`) cover on the
    great circle of the plane with normal ``n`` (rotated by ``R`` first), or None."""
    if len(d) < 2:
        return None
    return arc_on_plane(d if R is None else d @ R.T, n)


def arc_on_plane(d, n):
    """The arc ``(lo, hi, e1, e2)`` that rays ``d (M, 3)`` (two or more) cover on the great circle of
    the plane with unit normal ``n``: angles from the first ray's projection ``e1``, ``e2 = n x e1``
    (for :func:`arc_overlap`)."""
    e1 = d[0] - (d[0] @ n) * n
    e1 /= max(np.linalg.norm(e1), 1e-300)
    e2 = np.cross(n, e1)
    phi = np.arctan2(d @ e2, d @ e1)  # relative to the first ray: a segment spans less than a half-turn
    return float(phi.min()), float(phi.max()), e1, e2


def arc_overlap(a, b) -> float:
    """The overlap of two arcs (each ``(lo, hi, e1, e2)`` in its own basis, on one plane) over the shorter."""
    lo_a, hi_a, e1a, e2a = a
    lo_b, hi_b, e1b, e2b = b
    # the angle of b's basis in a's
    off = np.arctan2(e1b @ e2a, e1b @ e1a)
    lo_b, hi_b = lo_b + off, hi_b + off
    # bring b near a (angles modulo a full turn)
    shift = 2 * np.pi * np.round(((lo_b + hi_b) - (lo_a + hi_a)) / (4 * np.pi))
    lo_b, hi_b = lo_b - shift, hi_b - shift
    inter = min(hi_a, hi_b) - max(lo_a, lo_b)
    shorter = min(hi_a - lo_a, hi_b - lo_b)
    return float(inter / shorter) if shorter > 0 else 0.0


def rotation_twins_any_family(view_a, view_b, ea, eb, R) -> int:
    """:func:`rotation_twins` over every pair of families (``ea``, ``eb``: each view's own
    :class:`~catadioptric.pose.families.FamilyEstimate` dicts, keyed independently): the lines of A
    seen again unchanged in B under ``R``, whatever family each was put in. The count a rotation
    earns as the motion of a camera turned in place."""
    n = 0
    for fa in ea.values():
        for fb in eb.values():
            n += len(rotation_twins(view_a, view_b, {0: fa}, {0: fb}, [0], R).pairs)
    return n
