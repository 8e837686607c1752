"""Matching two views' families and lines without labels (the lines come from each image alone).

1. **Families** (:func:`family_matches`): a rotation maps the families of A onto those of B. Every
   pair of non-parallel families of A with every pair of B and each sign choice whose angles agree
   gives a rotation (Procrustes); every other family of B takes the family of A, and the sign,
   that this rotation brings nearest (within a few standard deviations of their directions), and
   each distinct assignment is refined with the directions' covariances. Symmetric scenes allow
   several (a Manhattan scene up to 24): all are kept, ranked later by the two-view geometry.
2. **Lines** (:func:`match_lines`), for one family assignment and its rotation: where two lines of
   different families meet, each view sees a ray (:mod:`catadioptric.pose.central`); the meeting
   points of A and of B are two views of the same corners, related by the epipolar constraint of
   the displacement ``t'`` between the centres. Candidate pairs of rays (same pair of families,
   close once A's ray is rotated: a corner moves by its parallax only) feed a RANSAC for ``t'``
   (two pairs give it; inliers must lie in front of both centres); each inlier pair votes for the
   two lines that meet there in each view, and lines are matched one to one by their votes. The
   best few displacements of the RANSAC are each verified that way (a meeting ray of A counts where
   the lines matched to its two lines meet in B), and the best verified one is kept.

The matched families and lines then go through :func:`catadioptric.pose.relative_pose` with the
ends known (the assignment's signs).
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from .central import _costs, _meeting, _rad_per_px, _residuals2, _sides
from .rotation import refine_rotation, rotation_angle_deg, rotation_from_directions

__all__ = ["FamilyMatch", "family_matches", "LineMatch", "match_lines"]


@dataclass
class FamilyMatch:
    """``mapping``: ``{family of B: (family of A, sign)}`` (``s_B ~ sign R s_A``); ``R`` refined on all
    mapped families; ``cost``: robust direction cost plus 9 per family of B left unmapped."""

    mapping: dict
    R: np.ndarray
    cost: float


def _sd(C):
    return float(np.sqrt(max(np.trace(C), 0.0)))


def _assign_families(pred, sb, ua, ub, ka, kb) -> dict:
    """B's families each to the family of A whose rotated direction ``pred`` is nearest, within 3
    standard deviations of both directions plus a degree, one to one: where two of B's families
    reach the same family of A (a family of two nearly parallel lines, whose direction is barely
    fixed, reaches anything), the more precise pair keeps it and the other stays unmapped (before,
    such a pair discarded the whole assignment: the right one of a benchmark pair was never tried
    and a wrong one, 16 degrees off, came out unflagged). Returns ``{family of B: (family of A, sign)}``."""
    ang = np.arccos(np.clip(np.abs(pred @ sb.T), 0.0, 1.0))  # (A, B)
    tol = 3.0 * (ua[:, None] + ub[None, :]) + np.radians(1.0)
    pairs = [(tol[i, j], i, j) for j in range(len(kb)) for i in [int(np.argmin(ang[:, j]))] if ang[i, j] <= tol[i, j]]
    mapping, used = {}, set()
    for _, i, j in sorted(pairs):
        if i not in used:
            used.add(i)
            mapping[kb[j]] = (ka[i], 1.0 if pred[i] @ sb[j] > 0 else -1.0)
    return mapping


def _floored(cov, s, floor_rad):
    """A direction's covariance with an error of ``floor_rad`` (radians) added across ``s``."""
    return cov + floor_rad**2 * (np.eye(3) - np.outer(s, s))


def family_matches(ea: dict, eb: dict, *, max_cost_gap: float = 100.0, max_matches: int = 48,
                   same_deg: float = 1.0, max_rotation_deg: float | None = None,
                   floor_deg: float = 0.3) -> list[FamilyMatch]:
    """The assignments of B's families to A's (with signs) that a rotation allows, best first.

    ``ea``, ``eb``: ``{family: FamilyEstimate}`` of each view (any keys: they need not agree).
    ``max_rotation_deg``: only rotations that turn by at most this (a prior on the motion).
    An orthogonal triad of families fits 24 rotations equally well and the directions' costs
    then rank them by their small biases, so ``max_matches`` keeps twice that. ``floor_deg``: an
    error added to every family's direction, for what its covariance leaves out: the planes of a
    non-central rig's lines through one centre are an approximation, and a detected family's lines
    carry the detector's shared biases (on the benchmark's hyperbolic pair p10 the vertical family
    of one view is 0.25 degree off with a standard error of 0.03, so the right assignment of three
    families cost 80 chi-square units against 18 for a wrong one of two)."""
    ka, kb = list(ea), list(eb)
    sa = np.array([ea[k].direction for k in ka])
    sb = np.array([eb[k].direction for k in kb])
    fl = np.radians(floor_deg)
    Ca = {k: _floored(ea[k].cov, ea[k].direction, fl) for k in ka}
    Cb = {k: _floored(eb[k].cov, eb[k].direction, fl) for k in kb}
    ua = np.array([_sd(Ca[k]) for k in ka])
    ub = np.array([_sd(Cb[k]) for k in kb])
    seen, out = set(), []
    for i1, i2 in itertools.permutations(range(len(ka)), 2):
        if np.linalg.norm(np.cross(sa[i1], sa[i2])) < 0.1:
            continue
        for j1, j2 in itertools.permutations(range(len(kb)), 2):
            if np.linalg.norm(np.cross(sb[j1], sb[j2])) < 0.1:
                continue
            for g1, g2 in itertools.product((1.0, -1.0), repeat=2):
                tol = 3.0 * (ua[i1] + ua[i2] + ub[j1] + ub[j2]) + np.radians(1.0)
                if abs(sa[i1] @ sa[i2] - g1 * g2 * (sb[j1] @ sb[j2])) > tol:
                    continue
                R = rotation_from_directions(sa[[i1, i2]], sb[[j1, j2]] * np.array([g1, g2])[:, None])
                if max_rotation_deg is not None and rotation_angle_deg(R) > max_rotation_deg + 10.0:
                    continue
                mapping = _assign_families(sa @ R.T, sb, ua, ub, ka, kb)
                if len(mapping) < 2:
                    continue
                key = tuple(sorted((str(b), str(a), s) for b, (a, s) in mapping.items()))
                if key in seen:
                    continue
                seen.add(key)
                bs = list(mapping)
                A_ = np.array([ea[mapping[b][0]].direction for b in bs])
                B_ = np.array([eb[b].direction * mapping[b][1] for b in bs])
                fit = refine_rotation(A_, B_, np.array([Ca[mapping[b][0]] for b in bs]),
                                      np.array([Cb[b] for b in bs]), R)
                if max_rotation_deg is not None and rotation_angle_deg(fit.R) > max_rotation_deg:
                    continue
                out.append(FamilyMatch(mapping, fit.R, fit.cost + 9.0 * (len(kb) - len(mapping))))
    out.sort(key=lambda m: m.cost)
    kept = []
    for m in out:
        if m.cost > out[0].cost + max_cost_gap or len(kept) >= max_matches:
            break
        if any(rotation_angle_deg(m.R @ k.R.T) < same_deg and m.mapping.keys() == k.mapping.keys() for k in kept):
            continue
        kept.append(m)
    return kept


@dataclass
class LineMatch:
    """Lines matched across the views for one family assignment: ``pairs`` ``[(line of A, line of
    B)]`` (indices into each view's lines), ``t`` the unit displacement between the centres,
    ``cost`` the truncated (MSAC) cost over A's meeting rays, each counted only where the lines
    matched to its two lines meet in B (``n_inliers`` of them), ``n_crossings`` (A's meeting
    rays). When nothing can be matched (fewer than two meeting rays in a view, or fewer than two
    meeting rays of A near one of B under the assignment's rotation), ``t`` is None, no meeting
    ray of A is found in B and the cost is the truncated cost's ceiling, ``c2`` per meeting ray of
    A: an assignment whose lines cannot be matched is scored as one whose lines match nothing, not
    left out (an infinite cost made every such rival lose, and the winner's margin infinite)."""

    pairs: list
    t: np.ndarray | None
    cost: float
    n_inliers: int
    n_crossings: int


def _crossings(view, est: dict, fam_of: dict):
    """Every meeting ray of two lines of different families of one view: rays ``(K, 3)``, the two
    lines ``(K, 2)`` (view indices, ordered by family key) and the family pair ``(K, 2)``."""
    rows = []
    for key, e in est.items():
        if key not in fam_of:
            continue
        u = _sides(view, e)
        for k, i in enumerate(e.lines):
            rows.append((fam_of[key], i, e.normals[k], u[k]))
    rows.sort(key=lambda r: str(r[0]))
    if len(rows) < 2:
        return np.zeros((0, 3)), np.zeros((0, 2), int), []
    fam = [r[0] for r in rows]
    n = np.array([r[2] for r in rows])
    u = np.array([r[3] for r in rows])
    i, j = np.triu_indices(len(rows), 1)
    keep = np.array([fam[a] != fam[b] for a, b in zip(i, j)], dtype=bool)
    i, j = i[keep], j[keep]
    x = _meeting(n[i], u[i], n[j], u[j])
    ok = np.all(np.isfinite(x), axis=1)
    i, j, x = i[ok], j[ok], x[ok]
    lines = np.array([[rows[a][1], rows[b][1]] for a, b in zip(i, j)], dtype=int).reshape(-1, 2)
    pairs = [(fam[a], fam[b]) for a, b in zip(i, j)]
    return x, lines, pairs


def match_lines(view_a, view_b, ea: dict, eb: dict, match: FamilyMatch, *, sigma_px: float = 1.0, seed: int = 0,
                trials: int = 2000, neighbours: int = 4, max_parallax_deg: float = 45.0,
                c2: float = 9.0, verify: int = 8, verify_apart_deg: float = 2.0) -> LineMatch:
    """Match the lines of the two views for one family assignment (module docstring). ``verify``:
    the number of RANSAC displacements, best first and at least ``verify_apart_deg`` apart, that are
    each refined and verified by the one-to-one matching of the lines; the best verified one wins."""
    R = match.R
    xa, la, pa = _crossings(view_a, ea, {k: k for k in ea})
    xb, lb, pb = _crossings(view_b, eb, {b: a for b, (a, _) in match.mapping.items()})
    if len(xa) < 2 or len(xb) < 2:
        return LineMatch([], None, float(c2 * len(xa)), 0, len(xa))
    # B's lines were ordered by A's family keys, so the two lines of a pair correspond in order
    by_pair: dict = {}
    for j, p in enumerate(pb):
        by_pair.setdefault(p, []).append(j)
    ra = xa @ R.T
    cand_i, cand_j = [], []
    cos_max = np.cos(np.radians(max_parallax_deg))
    for i, p in enumerate(pa):
        js = np.array(by_pair.get(p, []), dtype=int)
        if len(js) == 0:
            continue
        c = xb[js] @ ra[i]
        order = np.argsort(-c)[:neighbours]
        js = js[order][c[order] > cos_max]
        cand_i += [i] * len(js)
        cand_j += list(js)
    if len(cand_i) < 2:
        return LineMatch([], None, float(c2 * len(xa)), 0, len(xa))
    ci, cj = np.array(cand_i), np.array(cand_j)
    p_, q_ = ra[ci], xb[cj]
    A = np.cross(p_, q_)
    na = np.linalg.norm(A, axis=1)
    A = A / np.maximum(na, 1e-300)[:, None]
    rpp = max(_rad_per_px(view_a.cam), _rad_per_px(view_b.cam))
    thr = 3.0 * max(0.5, 0.5 * sigma_px) * np.sqrt(2.0) * rpp
    rng = np.random.default_rng(seed)
    S = rng.integers(0, len(ci), (trials, 2))
    S = S[ci[S[:, 0]] != ci[S[:, 1]]]
    T = np.cross(A[S[:, 0]], A[S[:, 1]])
    nt = np.linalg.norm(T, axis=1)
    T = T[nt > 1e-9] / nt[nt > 1e-9, None]
    if len(T) == 0:
        return LineMatch([], None, float(c2 * len(xa)), 0, len(xa))
    T = np.concatenate([T, -T])

    def per_crossing_cost(Ts):
        cost, inl = _costs(A, p_, q_, Ts, thr, c2, min_parallax=3.0 * thr)  # per candidate pair
        r2 = _residuals2(A, Ts, thr)
        r2 = np.where(inl, r2, c2)
        best = np.full((len(Ts), len(xa)), c2)
        for k in range(len(Ts)):
            np.minimum.at(best[k], ci, r2[k])
        return best.sum(axis=1), r2

    def best_pairs(t):
        """Each meeting ray of A at its best inlier candidate in B: ``{i: candidate index}``."""
        r2 = per_crossing_cost(t[None])[1][0]
        best = {}
        for k in np.nonzero(r2 < c2)[0]:
            if ci[k] not in best or r2[k] < r2[best[ci[k]]]:
                best[ci[k]] = k
        return best

    costs = np.concatenate([per_crossing_cost(T[c:c + 256])[0] for c in range(0, len(T), 256)])
    b_cross = {(int(l1), int(l2)): j for j, (l1, l2) in enumerate(lb)}

    def verified(t):
        """Least squares on ``t``'s inlier pairs, lines matched one to one by the votes of the
        meeting rays, and the verified cost (below)."""
        for _ in range(5):  # least squares on the inlier pairs
            ks = np.array(list(best_pairs(t).values()), dtype=int)
            if len(ks) < 2:
                break
            t_new = np.linalg.eigh(A[ks].T @ A[ks])[1][:, 0]
            t = t_new if t_new @ t >= 0 else -t_new
        best_j = best_pairs(t)
        votes: dict = {}
        for i, k in best_j.items():
            for a_line, b_line in zip(la[i], lb[cj[k]]):
                votes[(int(a_line), int(b_line))] = votes.get((int(a_line), int(b_line)), 0) + 1
        pairs, used_a, used_b = [], set(), set()
        for (a_line, b_line), v in sorted(votes.items(), key=lambda kv: -kv[1]):
            if v < 2 or a_line in used_a or b_line in used_b:
                continue
            pairs.append((a_line, b_line))
            used_a.add(a_line)
            used_b.add(b_line)
        # verified: a meeting ray of A counts only where the lines matched to its two lines meet in B, on
        # its epipolar plane and in front of both centres (chance agreements of a wrong rotation spread
        # over many pairs of lines and do not survive the one-to-one matching of the lines)
        to_b = dict(pairs)
        vi, vj = [], []
        for i, (l1, l2) in enumerate(la):
            j = b_cross.get((to_b.get(int(l1), -1), to_b.get(int(l2), -1)))
            if j is not None:
                vi.append(i)
                vj.append(j)
        n_ok, cost_v = 0, c2 * len(xa)
        if vi:
            P, Q = ra[vi], xb[vj]
            Av = np.cross(P, Q)
            Av /= np.maximum(np.linalg.norm(Av, axis=1), 1e-300)[:, None]
            _, inl = _costs(Av, P, Q, t[None], thr, c2, min_parallax=3.0 * thr)
            r2 = _residuals2(Av, t[None], thr)[0]
            ok = inl[0]
            n_ok = int(ok.sum())
            cost_v = float(np.sum(r2[ok]) + c2 * (len(xa) - n_ok))
        return LineMatch(pairs, t, cost_v, n_ok, len(xa))

    # the RANSAC cost counts chance agreements of pairs of meeting rays, which the one-to-one
    # matching of the lines removes: it can rank a wrong displacement first by a hair (a 1e-14 change
    # of the planes swapped the two on a CI pair). So the best few distinct displacements are each
    # verified, and the best verified one is kept.
    tops = []
    for k in np.argsort(costs, kind="stable"):
        if all(T[k] @ u < np.cos(np.radians(verify_apart_deg)) for u in tops):
            tops.append(T[k])
            if len(tops) == verify:
                break
    found = [verified(u) for u in tops]
    return min(found, key=lambda m: (m.cost, -m.n_inliers))
