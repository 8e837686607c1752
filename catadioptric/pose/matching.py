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
3. **Appearance**, when both views carry it (:class:`catadioptric.appearance.LineAppearance`, from
   the detector): under the assignment, each line's sides are named by its family's direction (A's,
   and B's times the assignment's sign) and the side it is seen on, so that a side of a line of A
   and the same side of its match in B are one side of one 3-D line; two lines whose brighter sides
   differ (both contrasts above :data:`MIN_CONTRAST` grey levels) are not matched: not as the lines
   of a candidate pair of meeting rays, nor in the one-to-one matching that is verified.

The matched families and lines then go through :func:`catadioptric.pose.relative_pose` with the
ends known (the assignment's signs).
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np

from .._numeric import cross
from ..appearance import contrasts_agree
from ._kernels import alignment_table, neighbour_costs
from .central import meeting, rad_per_px, residuals2, sides, translation_costs, truncated_residuals2
from .rotation import refine_rotation, rotation_angle_deg, rotation_from_directions, with_floor

__all__ = ["FamilyMatch", "family_matches", "LineMatch", "LineMatchOptions", "LinesInOrder", "match_lines",
           "MIN_CONTRAST", "FAMILY_FLOOR_DEG"]

#: the error (degrees) :func:`family_matches` adds across every family's direction by default, for
#: what its covariance leaves out (its docstring)
FAMILY_FLOOR_DEG = 0.3

#: the least difference of luminance between a line's two sides (grey levels of an 8-bit scale, or
#: three times the images' noise when larger) that tells its brighter side (module docstring, step 3)
MIN_CONTRAST = 5.0


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


def family_matches(ea: dict, eb: dict, *, max_cost_gap: float = 100.0, max_matches: int = 48,
                   same_deg: float = 1.0, max_rotation_deg: float | None = None,
                   floor_deg: float = FAMILY_FLOOR_DEG) -> list[FamilyMatch]:
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
    Ca = {k: with_floor(ea[k].direction, ea[k].cov, floor_deg) for k in ka}
    Cb = {k: with_floor(eb[k].direction, eb[k].cov, floor_deg) for k in kb}
    ua = np.array([_sd(Ca[k]) for k in ka])
    ub = np.array([_sd(Cb[k]) for k in kb])
    seen, out = set(), []
    for i1, i2 in itertools.permutations(range(len(ka)), 2):
        if np.linalg.norm(cross(sa[i1], sa[i2])) < 0.1:
            continue
        for j1, j2 in itertools.permutations(range(len(kb)), 2):
            if np.linalg.norm(cross(sb[j1], sb[j2])) < 0.1:
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
    #: the best verified cost of the RANSAC's displacements alone (the lines matched in their order,
    #: :class:`LinesInOrder`, left out); ``cost`` when those are all there is
    cost_unordered: float | None = None
    #: the lines matched in their order, unverified (:meth:`LinesInOrder.hypotheses`), for another
    #: call of :func:`match_lines` on the same assignment (``ordered``); None where none were sought
    ordered: list | None = field(default=None, repr=False)


def _crossings(view, est: dict, fam_of: dict):
    """Every meeting ray of two lines of different families of one view: rays ``(K, 3)``, the two
    lines ``(K, 2)`` (view indices, ordered by family key) and the family pair ``(K, 2)``."""
    rows = []
    for key, e in est.items():
        if key not in fam_of:
            continue
        u = sides(view, e)
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
    x = meeting(n[i], u[i], n[j], u[j])
    ok = np.all(np.isfinite(x), axis=1)
    i, j, x = i[ok], j[ok], x[ok]
    lines = np.array([[rows[a][1], rows[b][1]] for a, b in zip(i, j)], dtype=int).reshape(-1, 2)
    pairs = [(fam[a], fam[b]) for a, b in zip(i, j)]
    return x, lines, pairs


def _contrasts(view, est: dict, signs: dict) -> np.ndarray | None:
    """Per line of ``view``: the contrast of its sides (:meth:`~catadioptric.appearance.LineAppearance.contrast`)
    about the normal ``sign s x u`` (``s`` its family's direction, ``u`` the side it is seen on);
    NaN for a line of no family in ``signs`` (``{family key: sign}``). None without appearance."""
    if view.appearance is None:
        return None
    out = np.full(len(view.uv), np.nan)
    for key, sign in signs.items():
        e = est[key]
        m = sign * cross(e.direction, sides(view, e))
        out[np.asarray(e.lines, dtype=np.int64)] = view.appearance.contrast(e.lines, m)
    return out


def _pencil_order(normals, e1, e2) -> np.ndarray:
    """Positions of a family's lines in the order of their planes about the family's direction
    (normal to ``e1``, ``e2``): the planes' angle modulo a half-turn, cut at its widest gap."""
    th = np.mod(np.arctan2(normals @ e2, normals @ e1), np.pi)
    o = np.argsort(th, kind="stable")
    gaps = np.diff(np.r_[th[o], th[o[0]] + np.pi])
    return np.roll(o, -(int(np.argmax(gaps)) + 1))


def _monotone_alignment(gain: np.ndarray) -> list:
    """The pairs ``(i, j)``, increasing in both, of largest total ``gain[i, j]`` (only positive gains
    are taken): a sequence alignment by dynamic programming."""
    n, m = gain.shape
    D = alignment_table(np.ascontiguousarray(gain, dtype=float))
    pairs, i, j = [], n, m
    while i > 0 and j > 0:
        if gain[i - 1, j - 1] > 0 and D[i, j] == D[i - 1, j - 1] + gain[i - 1, j - 1]:
            pairs.append((i - 1, j - 1))
            i, j = i - 1, j - 1
        elif D[i, j] == D[i - 1, j]:
            i -= 1
        else:
            j -= 1
    return pairs[::-1]


class LinesInOrder:
    """Lines of families matched in their order, for repeated patterns.

    Parallel lines on one plane (a chessboard's rows, a grid of windows) are seen, from any centre
    on one side of the plane, in the order they lie: the planes through the centre that hold them
    turn monotonically about the family's direction. A rotation maps that order in A onto the order
    in B (the angles measured in bases ``e1, e2`` of A and ``R e1, R e2`` of B keep their sense). The
    RANSAC of :func:`match_lines` pairs each meeting ray of A with its few nearest in B under the
    rotation, which misses a pattern whose parallax spans several of its cells (a board carried
    around the camera: 9-56 degrees of parallax for cells of 5-6 degrees on ``../shared/real/mei``);
    the order does not depend on the parallax.

    1. Seeds: for two families, every pair of offsets (line ``i`` of A with line ``i - o`` of B)
       that leaves at least ``min_meetings`` meeting rays in common gives a displacement (least
       squares on those rays, then on their inliers), ranked by the truncated cost over A's rays.
    2. Each seed is then aligned again, family by family, against the lines the others have matched:
       the pairs of lines, in order and with gaps (a line missed in one view, another found only in
       one), whose meeting rays fit the displacement best (:func:`_monotone_alignment`), and the
       displacement fitted again; three rounds.

    Lines of families that are not on one plane give matchings that fit nothing, which the
    verification of :func:`match_lines` then rejects."""

    def __init__(self, ea: dict, eb: dict, match: FamilyMatch, crossings_a, crossings_b, *, max_lines: int = 24,
                 min_meetings: int = 6, rounds: int = 3):
        self.R = match.R
        self.xa, la = crossings_a
        self.xb, lb = crossings_b
        self.ra = self.xa @ self.R.T
        self.min_meetings, self.rounds = min_meetings, rounds
        self.orders = {}
        for b, (a, _) in match.mapping.items():
            na, nb = len(ea[a].lines), len(eb[b].lines)
            if not (2 <= na <= max_lines and 2 <= nb <= max_lines):
                continue
            d = ea[a].direction
            e1 = cross(d, np.eye(3)[int(np.argmin(np.abs(d)))])
            e1 /= np.linalg.norm(e1)
            e2 = cross(d, e1)
            oa = np.asarray(ea[a].lines)[_pencil_order(ea[a].normals, e1, e2)]
            ob = np.asarray(eb[b].lines)[_pencil_order(eb[b].normals, self.R @ e1, self.R @ e2)]
            self.orders[a] = (oa, ob)
        self.keys = sorted(self.orders, key=str)  # the meeting rays' lines are ordered by family key
        cross_a = {(int(l1), int(l2)): k for k, (l1, l2) in enumerate(la)}
        cross_b = {(int(l1), int(l2)): k for k, (l1, l2) in enumerate(lb)}
        self.grids = {}
        for f, g in itertools.combinations(self.keys, 2):
            self.grids[f, g] = tuple(self._grid(self.orders[f][v], self.orders[g][v], c)
                                     for v, c in ((0, cross_a), (1, cross_b)))

    @staticmethod
    def _grid(first, second, cross):
        """Meeting-ray indices ``(len(first), len(second))`` of two ordered families (-1: none)."""
        g = np.full((len(first), len(second)), -1, dtype=int)
        for i, l1 in enumerate(first):
            for j, l2 in enumerate(second):
                g[i, j] = cross.get((int(l1), int(l2)), -1)
        return g

    def _between(self, f, g):
        """The grids of families ``f`` (rows) and ``g`` (columns) in A and in B."""
        if (f, g) in self.grids:
            return self.grids[f, g]
        GA, GB = self.grids[g, f]
        return GA.T, GB.T

    def _r2(self, kA, kB, t, thr, c2):
        """Truncated squared residuals (shape of ``kA``) of A's meeting rays ``kA`` seen as B's ``kB``
        under displacement ``t``: ``c2`` where either is missing or the rays do not meet ahead."""
        ok = (kA >= 0) & (kB >= 0)
        out = np.full(kA.shape, c2)
        if ok.any():
            P, Q = self.ra[kA[ok]], self.xb[kB[ok]]
            Av = cross(P, Q)
            Av /= np.maximum(np.linalg.norm(Av, axis=1), 1e-300)[:, None]
            out[ok] = truncated_residuals2(Av, P, Q, t[None], thr, c2, min_parallax=3.0 * thr)[0][0]
        return out

    def _fit(self, kA, kB, thr, c2, rounds: int = 3):
        """The displacement of A's meeting rays ``kA`` seen as B's ``kB`` (1-D, all present): least
        squares, then again on its inliers (``rounds`` in all); with its truncated cost over all of
        A's meeting rays."""
        P, Q = self.ra[kA], self.xb[kB]
        Av = cross(P, Q)
        Av /= np.maximum(np.linalg.norm(Av, axis=1), 1e-300)[:, None]
        use = np.ones(len(kA), dtype=bool)
        t, cost = None, np.inf
        for _ in range(rounds):
            if use.sum() < 2:
                break
            u = np.linalg.eigh(Av[use].T @ Av[use])[1][:, 0]
            T = np.stack([u, -u])
            costs, inl = translation_costs(Av, P, Q, T, thr, c2, min_parallax=3.0 * thr)
            h = int(np.argmin(costs))
            t, cost, use = T[h], float(costs[h]) + c2 * (len(self.xa) - len(kA)), inl[h]
        return t, cost

    def _meetings_of(self, pairs):
        """A's and B's meeting rays ``(kA, kB)`` of every two matched lines of different families
        (``pairs``: ``{family: [(position in A, position in B)]}``)."""
        kA, kB = [], []
        for f, g in itertools.combinations([k for k in self.keys if pairs.get(k)], 2):
            GA, GB = self.grids[f, g]
            pf, pg = np.array(pairs[f]), np.array(pairs[g])
            kA.append(GA[np.ix_(pf[:, 0], pg[:, 0])].ravel())
            kB.append(GB[np.ix_(pf[:, 1], pg[:, 1])].ravel())
        if not kA:
            return np.zeros(0, int), np.zeros(0, int)
        kA, kB = np.concatenate(kA), np.concatenate(kB)
        ok = (kA >= 0) & (kB >= 0)
        return kA[ok], kB[ok]

    def _realign(self, pairs, t, thr, c2):
        """Each family's lines aligned again against the others' matched lines (class docstring, 2)."""
        for _ in range(self.rounds):
            before = ({f: list(p) for f, p in pairs.items()}, t)
            for f in self.keys:
                gain = np.zeros((len(self.orders[f][0]), len(self.orders[f][1])))
                for g in self.keys:
                    if g == f or not pairs.get(g):
                        continue
                    GA, GB = self._between(f, g)
                    pg = np.array(pairs[g])
                    kA = np.broadcast_to(GA[:, pg[:, 0]][:, None, :], gain.shape + (len(pg),))
                    kB = np.broadcast_to(GB[:, pg[:, 1]][None, :, :], gain.shape + (len(pg),))
                    gain += np.sum(c2 - self._r2(kA, kB, t, thr, c2), axis=2)
                pairs[f] = _monotone_alignment(gain)
            kA, kB = self._meetings_of(pairs)
            if len(kA) < self.min_meetings:
                break
            t_new, _ = self._fit(kA, kB, thr, c2)
            if t_new is None:
                break
            t = t_new
            if pairs == before[0] and np.array_equal(t, before[1]):  # a fixed point: another round repeats this one
                break
        return pairs, t

    def _seeds(self, thr, c2, top: int):
        """The ``top`` best of every pair of offsets of every two families (class docstring, 1), each
        fitted once (least squares on its common meeting rays, all offsets in one batch), the best
        first (ties in the order of the families, then of the offsets): ``[(cost, pairs, (kA, kB))]``."""
        costs, made = [], []
        for f, g in itertools.combinations(self.keys, 2):
            GA, GB = self.grids[f, g]
            # every two meeting rays, one of each grid: the offsets (df, dg) that bring them together
            ia, ja = np.nonzero(GA >= 0)
            ib, jb = np.nonzero(GB >= 0)
            df = (ia[:, None] - ib[None, :]).ravel()
            dg = (ja[:, None] - jb[None, :]).ravel()
            a = np.repeat(np.arange(len(ia)), len(ib))
            b = np.tile(np.arange(len(ib)), len(ia))
            # grouped by offset (df, then dg), each group's rays in A's row-major order
            o = np.lexsort((a, dg, df))
            df, dg, a, b = df[o], dg[o], a[o], b[o]
            start = np.flatnonzero(np.r_[True, (np.diff(df) != 0) | (np.diff(dg) != 0)])
            count = np.diff(np.r_[start, len(df)])
            keep = count >= self.min_meetings
            if not keep.any():
                continue
            group = np.repeat(np.cumsum(keep) - 1, count)
            sel = np.repeat(keep, count)
            kA, kB, cid = GA[ia[a[sel]], ja[a[sel]]], GB[ib[b[sel]], jb[b[sel]]], group[sel]
            costs.append(self._batch_costs(kA, kB, cid, int(keep.sum()), thr, c2))
            made.append((f, g, GA.shape, GB.shape, df[start[keep]], dg[start[keep]], kA, kB,
                         np.r_[0, np.cumsum(count[keep])]))
        if not made:
            return []
        first = np.cumsum([0] + [len(c) for c in costs])  # each family pair's first offset, over all
        costs = np.concatenate(costs)
        out = []
        for k in np.argsort(costs, kind="stable")[:top]:
            m = int(np.searchsorted(first, k, side="right")) - 1
            f, g, (na_f, na_g), (nb_f, nb_g), dfs, dgs, kA, kB, bounds = made[m]
            q = int(k - first[m])
            df, dg, u, v = int(dfs[q]), int(dgs[q]), bounds[q], bounds[q + 1]
            i0, i1, j0, j1 = max(0, df), min(na_f, nb_f + df), max(0, dg), min(na_g, nb_g + dg)
            pairs = {f: [(i, i - df) for i in range(i0, i1)], g: [(j, j - dg) for j in range(j0, j1)]}
            out.append((float(costs[k]), pairs, (kA[u:v], kB[u:v])))
        return out

    def _batch_costs(self, kA, kB, cid, n, thr, c2):
        """For ``n`` sets of meeting rays (A's ``kA`` seen as B's ``kB``, set ``cid``): each set's least
        squares displacement (either sign) and its truncated cost over all of A's meeting rays."""
        P, Q = self.ra[kA], self.xb[kB]
        Av = cross(P, Q)
        Av /= np.maximum(np.linalg.norm(Av, axis=1), 1e-300)[:, None]
        M = np.zeros((n, 3, 3))
        np.add.at(M, cid, Av[:, :, None] * Av[:, None, :])
        t = np.linalg.eigh(M)[1][:, :, 0][cid]  # (K, 3): each ray's set's displacement
        r2 = np.sum(Av * t, axis=1) ** 2 / (thr / 3.0) ** 2
        pq = np.sum(P * Q, axis=1)
        det = np.maximum(1.0 - pq**2, 1e-300)
        pt, qt = np.sum(t * P, axis=1), np.sum(t * Q, axis=1)
        lam, mu = (-pt + pq * qt) / det, (qt - pq * pt) / det
        exempt = pq > np.cos(3.0 * thr)
        best = np.full(n, np.inf)
        for sign in (1.0, -1.0):  # -t flips both depths
            inl = (r2 <= c2) & ((sign * lam > 0) & (sign * mu > 0) | exempt)
            used = np.bincount(cid, minlength=n)
            cost = np.bincount(cid, weights=np.where(inl, r2, c2), minlength=n) + c2 * (len(self.xa) - used)
            best = np.minimum(best, cost)
        return best

    def hypotheses(self, thr: float, c2: float, *, top: int = 8) -> list:
        """The ``top`` best seeds, each aligned again: ``[(pairs of lines (A, B), unit displacement)]``."""
        out = []
        seeds = []
        for _, pairs, (kA, kB) in self._seeds(thr, c2, 4 * top):  # one least squares each, then three rounds
            t, cost = self._fit(kA, kB, thr, c2)
            seeds.append((cost, pairs, t))
        seeds.sort(key=lambda h: h[0])
        for _, pairs, t in seeds[:top]:
            pairs, t = self._realign(dict(pairs), t, thr, c2)
            lines = [(int(self.orders[f][0][i]), int(self.orders[f][1][j])) for f, ps in pairs.items() for i, j in ps]
            out.append((lines, t))
        return out


@dataclass(frozen=True, kw_only=True)
class LineMatchOptions:
    """How :func:`match_lines` matches the lines of one family assignment (its docstring)."""

    #: random pairs of candidate meeting-ray pairs the RANSAC draws
    trials: int = 2000
    #: each meeting ray of A is paired with at most this many nearest of B under the rotation
    neighbours: int = 4
    #: ... and only those within this angle of it (degrees: its parallax)
    max_parallax_deg: float = 45.0
    #: the truncated cost's ceiling per meeting ray (squared deviations)
    c2: float = 9.0
    #: the RANSAC's displacements verified, best first ...
    verify: int = 8
    #: ... at least this far apart (degrees)
    verify_apart_deg: float = 2.0
    #: families of at most this many lines in each view are also matched in their order
    max_ordered_lines: int = 24


def match_lines(view_a, view_b, ea: dict, eb: dict, match: FamilyMatch, *, sigma_px: float = 1.0, seed: int = 0,
                options: LineMatchOptions = LineMatchOptions(), appearance: bool = True,
                ordered: list | None = None) -> LineMatch:
    """Match the lines of the two views for one family assignment (module docstring). ``options``
    (:class:`LineMatchOptions`): ``verify``, the number of RANSAC displacements, best first and at
    least ``verify_apart_deg`` apart, that are each refined and verified by the one-to-one matching
    of the lines, the best verified one winning; ``max_ordered_lines``: families of at most this
    many lines in each view are also matched in their order (:class:`LinesInOrder`), and those
    matchings are verified the same way.
    ``appearance=False``: the lines' appearance is not used even where both views carry it (the
    geometry alone, as reported beside the answer's margin). ``ordered``: the lines matched in their
    order as an earlier call on the same views, assignment and options found them
    (``LineMatch.ordered``; they do not look at the appearance), instead of seeking them again."""
    trials, neighbours, max_parallax_deg, c2 = options.trials, options.neighbours, options.max_parallax_deg, options.c2
    verify, verify_apart_deg, max_ordered_lines = options.verify, options.verify_apart_deg, options.max_ordered_lines
    R = match.R
    xa, la, pa = _crossings(view_a, ea, {k: k for k in ea})
    xb, lb, pb = _crossings(view_b, eb, {b: a for b, (a, _) in match.mapping.items()})
    if len(xa) < 2 or len(xb) < 2:
        return LineMatch([], None, float(c2 * len(xa)), 0, len(xa), float(c2 * len(xa)))
    ra = xa @ R.T
    rpp = max(rad_per_px(view_a.cam), rad_per_px(view_b.cam))
    thr = 3.0 * max(0.5, 0.5 * sigma_px) * np.sqrt(2.0) * rpp
    # appearance: which lines of A may be which of B (module docstring, step 3)
    con_a = _contrasts(view_a, ea, {k: 1.0 for k in ea}) if appearance else None
    con_b = _contrasts(view_b, eb, {b: float(sg) for b, (_, sg) in match.mapping.items()}) if appearance else None
    if con_a is not None and con_b is not None:
        floor = max(MIN_CONTRAST, 3.0 * view_a.appearance.noise, 3.0 * view_b.appearance.noise)

        def agree(i_a, i_b):
            return contrasts_agree(con_a[i_a], con_b[i_b], floor)
    else:
        def agree(i_a, i_b):
            return np.ones(np.broadcast(np.asarray(i_a), np.asarray(i_b)).shape, dtype=bool)
    # B's meeting ray of lines (l1, l2), -1 where none: a table over B's lines (one more: "unmatched")
    n_b = max(len(view_a.uv), len(view_b.uv)) + 1
    b_cross = np.full((n_b, n_b), -1, dtype=np.int32)
    b_cross[lb[:, 0], lb[:, 1]] = np.arange(len(lb))

    def scored(pairs, t):
        """The verified cost of lines matched one to one: a meeting ray of A counts only where the
        lines matched to its two lines meet in B, on its epipolar plane and in front of both centres
        (chance agreements of a wrong rotation spread over many pairs of lines and do not survive the
        one-to-one matching of the lines)."""
        to_b = np.full(n_b, n_b - 1, dtype=np.int64)  # a line of A matched to nothing: B's last row, empty
        if pairs:
            pa_, pb_ = np.array(pairs, dtype=np.int64).T
            keep = agree(pa_, pb_)
            pairs = [p for p, k in zip(pairs, keep) if k]
            pa_, pb_ = pa_[keep], pb_[keep]
            to_b[pa_] = pb_
        j_all = b_cross[to_b[la[:, 0]], to_b[la[:, 1]]]
        vi = np.flatnonzero(j_all >= 0)
        vj = j_all[vi]
        n_ok, cost_v = 0, c2 * len(xa)
        if len(vi):
            P, Q = ra[vi], xb[vj]
            Av = cross(P, Q)
            Av /= np.maximum(np.linalg.norm(Av, axis=1), 1e-300)[:, None]
            _, inl = translation_costs(Av, P, Q, t[None], thr, c2, min_parallax=3.0 * thr)
            r2 = residuals2(Av, t[None], thr)[0]
            ok = inl[0]
            n_ok = int(ok.sum())
            cost_v = float(np.sum(r2[ok]) + c2 * (len(xa) - n_ok))
        return LineMatch(pairs, t, cost_v, n_ok, len(xa))

    def by_neighbours():
        """The RANSAC on each meeting ray of A and its nearest in B (module docstring): the best
        few displacements, each verified."""
        # B's lines were ordered by A's family keys, so the two lines of a pair correspond in order
        by_pair: dict = {}
        for j, p in enumerate(pb):
            by_pair.setdefault(p, []).append(j)
        cand_i, cand_j = [], []
        cos_max = np.cos(np.radians(max_parallax_deg))
        for i, p in enumerate(pa):
            js = np.array(by_pair.get(p, []), dtype=int)
            if len(js) == 0:
                continue
            js = js[agree(la[i, 0], lb[js, 0]) & agree(la[i, 1], lb[js, 1])]
            if len(js) == 0:
                continue
            c = xb[js] @ ra[i]
            order = np.argsort(-c)[:neighbours]
            js = js[order][c[order] > cos_max]
            cand_i += [i] * len(js)
            cand_j += list(js)
        if len(cand_i) < 2:
            return []
        ci, cj = np.array(cand_i), np.array(cand_j)
        p_, q_ = ra[ci], xb[cj]
        A = cross(p_, q_)
        na = np.linalg.norm(A, axis=1)
        A = A / np.maximum(na, 1e-300)[:, None]
        rng = np.random.default_rng(seed)
        S = rng.integers(0, len(ci), (trials, 2))
        S = S[ci[S[:, 0]] != ci[S[:, 1]]]
        T = cross(A[S[:, 0]], A[S[:, 1]])
        nt = np.linalg.norm(T, axis=1)
        T = T[nt > 1e-9] / nt[nt > 1e-9, None]
        if len(T) == 0:
            return []
        T = np.concatenate([T, -T])

        # the candidate pairs come grouped by their meeting ray of A (ci does not decrease)
        starts = np.flatnonzero(np.r_[True, ci[1:] != ci[:-1]])

        def best_pairs(t):
            """Each meeting ray of A at its best inlier candidate in B, the first of equals:
            ``{i: candidate index}`` in the order of ``i``."""
            r2 = truncated_residuals2(A, p_, q_, t[None], thr, c2, min_parallax=3.0 * thr)[0][0]
            k = np.flatnonzero(r2 < c2)
            k = k[np.lexsort((k, r2[k], ci[k]))]  # by meeting ray, then residual, then candidate
            first = np.r_[True, ci[k][1:] != ci[k][:-1]][:len(k)]
            return dict(zip(ci[k][first].tolist(), k[first].tolist()))

        costs = neighbour_costs(np.ascontiguousarray(T), np.ascontiguousarray(A), np.ascontiguousarray(p_),
                                np.ascontiguousarray(q_), np.r_[starts, len(ci)].astype(np.int64), len(xa),
                                (thr / 3.0) ** 2, float(c2), float(np.cos(3.0 * thr)))

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
            return scored(pairs, t)

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
        return [verified(u) for u in tops]

    found = by_neighbours()
    unordered = min((m.cost for m in found), default=float(c2 * len(xa)))
    if ordered is None:
        ordered = LinesInOrder(ea, eb, match, (xa, la), (xb, lb), max_lines=max_ordered_lines).hypotheses(thr, c2,
                                                                                                        top=verify)
    found += [scored(pairs, t) for pairs, t in ordered]
    if not found:
        return LineMatch([], None, float(c2 * len(xa)), 0, len(xa), float(c2 * len(xa)), ordered)
    best = min(found, key=lambda m: (m.cost, -m.n_inliers))
    return LineMatch(best.pairs, best.t, best.cost, best.n_inliers, best.n_crossings, unordered, ordered)
