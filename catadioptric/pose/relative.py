"""Relative pose of two views of one rig (or two rigs) from the pixels of families of parallel
lines: rotation and, for a non-central rig, metric translation, with covariance and an explicit
verdict when the answer is ambiguous.

Steps (docs/relative_pose.md):

1. each view fits its families (:func:`~catadioptric.pose.families.fit_view_families`): a
   direction with covariance per family, and each line (a 3-D line for a non-central rig, an
   interpretation plane for a central one);
2. the families seen in both views give rotation candidates, one per sign pattern that a
   rotation can fit (:func:`~catadioptric.pose.signs.sign_candidates`); with the ends matched
   (``ends``) the signs are known and there is one candidate;
3. non-central rigs: for each candidate, a linear translation from the lines matched across
   the views (:func:`~catadioptric.pose.translation.relative_translation_from_lines`, both
   ways), then rotation, translation, directions and lines refined jointly on the pixels of
   both views (:func:`~catadioptric.pose.bundle.refine_two_view`); central rigs: the
   translation direction from the points where lines of two families meet
   (:func:`~catadioptric.pose.central.translation_direction_from_crossings`);
4. the candidates are ranked by that two-view cost. The best is the answer when its margin
   over the second (a log-likelihood ratio, chi-square units) is at least ``decisive``;
   otherwise the result is ``ambiguous`` and lists every candidate.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .._checks import CatadioptricError, as_scalar
from .bundle import TwoViewFit, refine_two_view
from .central import translation_direction_from_crossings
from .families import FamilyEstimate, ViewLines, fit_view_families, is_central
from .rotation import rotation_angle_deg
from .signs import sign_candidates
from .translation import relative_translation_from_lines

__all__ = ["Candidate", "RelativePose", "relative_pose"]


@dataclass
class Candidate:
    """One answer: ``signs`` (``{family: +1/-1}``, ``b_f ~ sign R a_f``), ``R``, ``t`` (metres;
    a unit vector for a central model; None when not estimated), ``cost`` (the two-view cost
    used for ranking, chi-square units; the direction cost when nothing else is available),
    ``direction_cost`` (directions alone), ``fit``: the two-view refinement (non-central) or
    the crossing fit (central), ``cov (6, 6)`` of ``(w, t)`` or None."""

    signs: dict
    R: np.ndarray
    t: np.ndarray | None
    cost: float
    direction_cost: float
    cov: np.ndarray | None = None
    fit: object = None

    def summary(self) -> dict:
        return {"signs": {str(k): int(v) for k, v in self.signs.items()}, "R": self.R, "t": self.t,
                "cost": self.cost, "direction_cost": self.direction_cost}


@dataclass
class RelativePose:
    """The relative pose ``x_B = R x_A + t`` between the mirror frames of views A and B.

    ``t`` in metres when ``metric`` (a non-central rig), a unit vector otherwise (the
    direction between the viewpoints), None when it could not be estimated; ``cov (6, 6)``:
    covariance of ``(w, t)`` (left rotation vector, translation) or None. ``ambiguous``: the
    best candidate does not beat the second by ``decisive``; ``margin``: that difference
    (inf with one candidate); ``candidates``: every candidate, best first. ``families``: the
    family keys used; ``lines_matched``: lines seen in both views and used; ``model``:
    ``"non-central"`` or ``"central"``; ``sigma_px``: pixel noise estimate; ``estimates``:
    the per-view :class:`FamilyEstimate` dicts; ``notes``: what was dropped and why."""

    R: np.ndarray
    t: np.ndarray | None
    cov: np.ndarray | None
    metric: bool
    ambiguous: bool
    margin: float
    candidates: list
    families: list
    lines_matched: int
    model: str
    sigma_px: float
    estimates: tuple = field(repr=False, default=())
    notes: list = field(default_factory=list)

    @property
    def rotation_std_deg(self) -> float:
        """Root of the trace of the rotation covariance, in degrees."""
        if self.cov is None:
            return float("nan")
        return float(np.degrees(np.sqrt(max(np.trace(self.cov[:3, :3]), 0.0))))

    @property
    def translation_std(self) -> float:
        """Root of the trace of the translation covariance (metres, or unit-vector units)."""
        if self.cov is None:
            return float("nan")
        return float(np.sqrt(max(np.trace(self.cov[3:, 3:]), 0.0)))


def _subsample(mask, k):
    idx = np.nonzero(mask)[0]
    if k is None or len(idx) <= k:
        return idx
    return idx[np.round(np.linspace(0, len(idx) - 1, k)).astype(int)]


def _triangulate(s, o, d):
    """The point (normal to ``s``) of the line along unit ``s`` that best meets rays ``o, d``."""
    e1 = np.cross(s, [1.0, 0.0, 0.0] if abs(s[0]) < 0.8 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(s, e1)
    # reciprocal product of the line (s, x e1' + y e2') with the ray (d, o x d), e' spanning m
    m1, m2 = np.cross(e1, s), np.cross(e2, s)  # moments of unit offsets along e1, e2
    A = np.stack([d @ m1, d @ m2], axis=1)
    rhs = -(np.cross(o, d) @ s)
    sine = np.maximum(np.linalg.norm(np.cross(d, s), axis=1), 1e-9)
    xy = np.linalg.lstsq(A / sine[:, None], rhs / sine, rcond=None)[0]
    return xy[0] * e1 + xy[1] * e2


def _pixels_of(view, est: FamilyEstimate, k, max_pixels):
    line = est.lines[k]
    idx = _subsample(est.inliers[k], max_pixels)
    return view.uv[line][idx]


def _scale_along(t_dir, offset, R, La, Lb, rays_a, ra_own, rays_b, rb_own):
    """The length ``alpha`` of ``t = alpha t_dir + offset`` that the single-view lines suggest: the
    weighted median over the rays of both views of each ray's own solution (robust to the
    lines whose distance a near-central rig barely sees)."""
    from .translation import _rows_a_to_b, _rows_b_to_a

    c1, d1 = _rows_a_to_b(R, La, rays_b, rb_own)
    c2, d2 = _rows_b_to_a(R, Lb, rays_a, ra_own)
    c, d = np.concatenate([c1, c2]), np.concatenate([d1, d2])
    k = c @ t_dir
    ok = np.isfinite(k) & np.isfinite(d) & (np.abs(k) > 1e-9)
    if ok.sum() < 3:
        return None
    alpha = (d[ok] - c[ok] @ offset) / k[ok]
    w = k[ok] ** 2
    order = np.argsort(alpha)
    cw = np.cumsum(w[order])
    return float(alpha[order][np.searchsorted(cw, 0.5 * cw[-1])])


def _noncentral_candidate(cand, keys, va, vb, ea, eb, crossing, *, max_pixels, sigma_cost, pixel_sigma):
    """Starting translation and two-view refinement of one rotation candidate."""
    R = cand.R
    signs = dict(zip(keys, cand.signs))
    fam_index = {k: i for i, k in enumerate(keys)}
    dirs_a = np.array([ea[k].direction for k in keys])
    # lines: matched ones (pixels in both views), then those seen in one view only
    lines, uv_a, own_a, uv_b, own_b = [], [], [], [], []
    La, Lb, rays_a, ra_own, rays_b, rb_own = [], [], [], [], [], []
    for key in keys:
        A_ids = {va.line_id[i]: k for k, i in enumerate(ea[key].lines) if va.line_id[i] is not None}
        B_ids = {vb.line_id[i]: k for k, i in enumerate(eb[key].lines) if vb.line_id[i] is not None}
        matched = [lid for lid in A_ids if lid in B_ids]
        entries = [(A_ids[lid], B_ids[lid]) for lid in matched]
        entries += [(k, None) for k in range(len(ea[key].lines)) if va.line_id[ea[key].lines[k]] not in matched]
        entries += [(None, k) for k in range(len(eb[key].lines)) if vb.line_id[eb[key].lines[k]] not in matched]
        for ka, kb in entries:
            li = len(lines)
            pa = _pixels_of(va, ea[key], ka, max_pixels) if ka is not None else np.zeros((0, 2))
            pb = _pixels_of(vb, eb[key], kb, max_pixels) if kb is not None else np.zeros((0, 2))
            lines.append((key, ka, kb))
            uv_a.append(pa)
            own_a.append(np.full(len(pa), li))
            uv_b.append(pb)
            own_b.append(np.full(len(pb), li))
            if ka is not None and kb is not None:
                La.append(ea[key].pluecker[ka])
                Lb.append(eb[key].pluecker[kb] * signs[key])
                m = len(La) - 1
                rA, rB = va.cam.backproject(pa), vb.cam.backproject(pb)
                rays_a.append(np.concatenate([rA.directions, np.cross(rA.origins, rA.directions)], 1)[rA.valid])
                ra_own.append(np.full(int(rA.valid.sum()), m))
                rays_b.append(np.concatenate([rB.directions, np.cross(rB.origins, rB.directions)], 1)[rB.valid])
                rb_own.append(np.full(int(rB.valid.sum()), m))
    n_matched = len(La)
    if n_matched < 2:
        return None, n_matched
    ray_args = (np.array(La), np.array(Lb), np.concatenate(rays_a), np.concatenate(ra_own), np.concatenate(rays_b),
                np.concatenate(rb_own))
    if crossing is not None:
        # direction between the rays' centres from where lines meet; length from the lines' depths
        ca, cb = ea[keys[0]].centre, eb[keys[0]].centre
        offset = cb - R @ ca
        alpha = _scale_along(crossing.t, offset, R, *ray_args)
        alpha = 1.0 if alpha is None or not np.isfinite(alpha) else float(np.clip(alpha, 0.05, 1e3))
        t0 = alpha * crossing.t + offset
    else:
        t0, _ = relative_translation_from_lines(R, *ray_args)
    # starting line points in A: matched lines triangulated from both views' rays with (R, t0)
    pts, fams = [], []
    for li, (key, ka, kb) in enumerate(lines):
        s = ea[key].direction
        o_parts, d_parts = [], []
        if len(uv_a[li]):
            r = va.cam.backproject(uv_a[li])
            o_parts.append(r.origins[r.valid])
            d_parts.append(r.directions[r.valid])
        if len(uv_b[li]):
            r = vb.cam.backproject(uv_b[li])
            o_parts.append((r.origins[r.valid] - t0) @ R)
            d_parts.append(r.directions[r.valid] @ R)
        o, d = np.concatenate(o_parts), np.concatenate(d_parts)
        if ka is not None and kb is None:
            Lp = ea[key].pluecker[ka]
            q = np.cross(Lp[:3], Lp[3:])
        elif kb is not None and ka is None:
            Lp = eb[key].pluecker[kb]
            q = (np.cross(Lp[:3], Lp[3:]) - t0) @ R
        else:
            q = _triangulate(s, o, d)
        pts.append(q)
        fams.append(fam_index[key])
    fit = refine_two_view(va.cam, vb.cam, R, t0, dirs_a, np.array(pts), np.array(fams),
                          np.concatenate(uv_a), np.concatenate(own_a), np.concatenate(uv_b), np.concatenate(own_b),
                          sigma_cost=sigma_cost, pixel_sigma=pixel_sigma)
    return fit, n_matched


def relative_pose(view_a: ViewLines, view_b: ViewLines, *, ends: dict | None = None, seed=0, f_scale: float = 1.0,
                  pixel_sigma: float | None = None, decisive: float = 25.0, max_pixels: int | None = 60,
                  min_families: int = 2) -> RelativePose:
    """The relative pose ``x_B = R x_A + t`` of two views from the lines they see.

    ``view_a``, ``view_b``: :class:`ViewLines`. ``ends``: ``{family: (hint_a, hint_b)}``, for
    each family a direction in each view's mirror frame pointing to the same end (matched
    vanishing points, e.g. ``cam.directions_from_vanishing_points``); then the signs are
    known and nothing is searched. ``f_scale``: pixel scale of the robust losses;
    ``pixel_sigma``: known pixel noise (default: estimated). ``decisive``: the margin (chi-square
    units) the best candidate needs over the second. ``max_pixels``: pixels per line and view
    used by the two-view refinement (evenly spaced). Raises :class:`CatadioptricError` naming
    the cause when fewer than ``min_families`` families are seen in both views.
    """
    if not isinstance(view_a, ViewLines) or not isinstance(view_b, ViewLines):
        raise CatadioptricError(f"view_a, view_b: expected ViewLines, got {type(view_a).__name__} and "
                                f"{type(view_b).__name__}")
    decisive = as_scalar(decisive, "decisive", positive=True)
    f_scale = as_scalar(f_scale, "f_scale", positive=True)
    if pixel_sigma is not None:
        pixel_sigma = as_scalar(pixel_sigma, "pixel_sigma", positive=True)
    central = is_central(view_a.cam)
    if central != is_central(view_b.cam):
        raise CatadioptricError("view_a, view_b: expected two central or two non-central cameras, got one of each")
    fa, fb = view_a.families(), view_b.families()
    common = [k for k in fa if k in fb]
    if ends is not None:
        missing = [k for k in common if k not in ends]
        if missing:
            raise CatadioptricError(f"ends: expected the matched ends of every family seen in both views, "
                                    f"missing {missing}")
    hints_a = {k: ends[k][0] for k in common} if ends is not None else None
    hints_b = {k: ends[k][1] for k in common} if ends is not None else None
    ea, fail_a = fit_view_families(view_a, keys=common, seed=seed, f_scale=f_scale, pixel_sigma=pixel_sigma,
                                   hints=hints_a)
    eb, fail_b = fit_view_families(view_b, keys=common, seed=seed, f_scale=f_scale, pixel_sigma=pixel_sigma,
                                   hints=hints_b)
    notes = [f"family {k} not used in view A: {v}" for k, v in fail_a.items()]
    notes += [f"family {k} not used in view B: {v}" for k, v in fail_b.items()]
    keys = [k for k in common if k in ea and k in eb]
    if len(keys) < min_families:
        only_a = [k for k in fa if k not in fb]
        only_b = [k for k in fb if k not in fa]
        raise CatadioptricError(
            f"views: expected at least {min_families} families of lines fitted in both views, got {len(keys)} "
            f"(families with lines in A: {len(fa)}, in B: {len(fb)}, in both: {len(common)}; seen only in A: "
            f"{len(only_a)}, only in B: {len(only_b)}; fits that failed: "
            + ("; ".join(notes) if notes else "none") + ")")
    a = np.array([ea[k].direction for k in keys])
    b = np.array([eb[k].direction for k in keys])
    Ca = np.array([ea[k].cov for k in keys])
    Cb = np.array([eb[k].cov for k in keys])
    sigmas = [e.sigma for e in list(ea.values()) + list(eb.values()) if np.isfinite(e.sigma)]
    sigma_est = float(np.median(sigmas)) if sigmas else f_scale
    sigma_cost = pixel_sigma if pixel_sigma is not None else max(sigma_est, 1e-3 * f_scale)
    cands = sign_candidates(a, b, Ca, Cb, signs=np.ones(len(keys)) if ends is not None else None)
    # stage 1: directions and the rays where lines meet, for every candidate (cheap)
    stage = []
    for c in cands:
        cr = translation_direction_from_crossings(view_a, view_b, ea, eb, keys, c.R, sigma_px=sigma_cost, seed=seed)
        stage.append((c.cost + (cr.cost if cr is not None else 0.0), c, cr))
    stage.sort(key=lambda x: x[0])
    out, n_matched = [], 0
    for score1, c, cr in stage:
        cov = None
        if cr is not None:
            n_matched = max(n_matched, cr.n_lines)
            cov = np.full((6, 6), np.nan)
            cov[:3, :3], cov[3:, 3:] = c.cov, cr.cov
        out.append(Candidate(dict(zip(keys, c.signs.astype(int))), c.R, None if cr is None else cr.t, score1, c.cost,
                             cov, cr))
    margin = out[1].cost - out[0].cost if len(out) > 1 else float("inf")
    if not central:
        # stage 2: the metric refinement on the pixels of both views, for the best candidate and for
        # every candidate that stage 1 could not tell from it (ranked by that refinement then)
        close = [i for i, o in enumerate(out) if o.cost < out[0].cost + decisive]
        for i in close:
            fit, n_m = _noncentral_candidate(stage[i][1], keys, view_a, view_b, ea, eb, stage[i][2],
                                             max_pixels=max_pixels, sigma_cost=sigma_cost, pixel_sigma=pixel_sigma)
            n_matched = max(n_matched, n_m)
            if fit is not None:
                o = out[i]
                out[i] = Candidate(o.signs, fit.R, fit.t, fit.cost, o.direction_cost, fit.cov, fit)
        if len(close) > 1:
            refined = sorted((out[i] for i in close), key=lambda o: o.cost)
            out = refined + [o for i, o in enumerate(out) if i not in close]
            margin = refined[1].cost - refined[0].cost
    best = out[0]
    if not central and not isinstance(best.fit, TwoViewFit):
        notes.append("no two lines were matched in both views with a fitted 3-D line in each: metric translation "
                     "not estimated" + ("" if best.t is None else "; t is the direction between the rays' centres"))
    if best.t is None:
        notes.append("no two lines of different families meet in both views: translation not estimated")
    cov = best.cov
    if cov is None:
        cov = np.full((6, 6), np.nan)
        cov[:3, :3] = next(s[1].cov for s in stage if rotation_angle_deg(s[1].R @ best.R.T) < 1e-9)
    sigma = best.fit.sigma if isinstance(best.fit, TwoViewFit) else sigma_est
    return RelativePose(R=best.R, t=best.t, cov=cov, metric=isinstance(best.fit, TwoViewFit),
                        ambiguous=bool(margin < decisive), margin=float(margin), candidates=out, families=keys,
                        lines_matched=n_matched, model="central" if central else "non-central", sigma_px=float(sigma),
                        estimates=(ea, eb), notes=notes)
