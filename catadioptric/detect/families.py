"""Families of parallel lines in one view: lines grouped by direction.

Each line ``i`` is known by the plane holding its rays (unit normal ``n_i``, covariance ``C_i``,
:mod:`catadioptric.linefit.planes`); a direction ``s`` is that of line ``i`` only if
``n_i . s = 0``, so parallel lines' planes meet along their common direction (for a central rig
exactly; for a non-central one to the small ratio of the mirror's size to the lines' distance).
Line ``i`` agrees with ``s`` when

    chi2_i(s) = (n_i . s)^2 / (s^T C_i s + sin(angle_floor)^2) <= chi2_max

(``angle_floor`` covers what the covariance does not: the detector's own biases, and for a
non-central rig the model's). Directions are voted for (sequential RANSAC):

1. hypotheses ``s = n_i x n_j`` from pairs of the ``max_seed_lines`` longest lines (planes less
   than ``min_seed_angle_deg`` apart give no direction);
2. the hypothesis whose agreeing lines are the least likely by chance is taken (a-contrario: its
   log number of false alarms ``log C(L - 2, k - 2) + sum log eps_i`` over all but the two most
   precise of its ``k`` lines, ``eps_i`` the width of line i's band of agreement, i.e. the chance
   that a random direction falls in it; ``L`` the lines still free), refined on the lines that
   agree (:func:`catadioptric.linefit.direction_from_planes`, covariance-weighted);
3. a blend of two families (lines of two directions a few degrees apart, agreeing loosely with
   a compromise) is split: when the lines divide into two sets that each fit a direction of their
   own with a total chi-square lower by ``split_gain``, the larger set is kept and the rest stays
   free;
4. the family is accepted when it has ``min_lines`` lines, reaches ``log NFA <= max_log_nfa`` and
   is not a concurrency: lines through one point (the edges meeting at a building's corner) lie
   in planes that all hold the ray to that point and agree with its direction as if they were
   parallel; such a direction is rejected when most of its lines end within ``concurrency_px``
   of where it is imaged (parallel lines recede towards their vanishing point but end short of
   it). Its lines are taken out, and the search goes on;
5. families less than ``merge_deg`` apart (one family split by the search because its lines'
   systematic errors exceed their covariance) are merged;
6. every line is then assigned to the family it agrees with, if exactly one and if its band of
   agreement (``3 sigma``) is at most ``max_band_deg`` wide: a line that agrees with none, with
   several (a line whose plane holds two families' directions, e.g. a horizontal line at the
   height of the rig) or too loosely (a short line) stays unassigned (family -1); families left
   with fewer than ``min_lines`` lines are dropped and the rest refitted.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Family", "LinePlanes", "GroupingOptions", "group_families", "refine_direction", "log_nfa", "concurrent"]


@dataclass(frozen=True)
class LinePlanes:
    """The lines :func:`group_families` groups, each known by the plane holding its rays: unit
    ``normals (L, 3)``, their covariances ``covs (L, 3, 3)`` and each line's number of pixels
    ``pixels (L,)``. With the camera ``cam`` and each line's end pixels ``ends (L, 2, 2)``,
    directions whose lines mostly end at one of its images are rejected as concurrent (None: not
    checked)."""

    normals: np.ndarray
    covs: np.ndarray
    pixels: np.ndarray
    cam: object = None
    ends: np.ndarray | None = None


@dataclass(frozen=True, kw_only=True)
class GroupingOptions:
    """How :func:`group_families` groups lines into families (the module docstring's steps)."""

    #: a line agrees with a direction when its chi-square ``chi2_i(s)`` is at most this
    chi2_max: float = 9.0
    #: the angular error every line is granted beyond its covariance (degrees)
    angle_floor_deg: float = 0.1
    #: the fewest lines of a family
    min_lines: int = 3
    #: the longest lines whose pairs give the hypotheses (step 1)
    max_seed_lines: int = 60
    #: planes closer than this (degrees) give no hypothesis (step 1)
    min_seed_angle_deg: float = 5.0
    #: a family's log number of false alarms must be at most this (step 4)
    max_log_nfa: float = -4.0
    #: lines with fewer pixels do not search for families, they only join them
    min_search_pixels: int = 20
    #: a line joins a family only if its band of agreement (3 sigma) is at most this wide (degrees; step 6)
    max_band_deg: float = 2.0
    #: a direction is a concurrency when most of its lines end within this many pixels of its image (step 4)
    concurrency_px: float = 5.0
    #: families closer than this (degrees) are merged (step 5)
    merge_deg: float = 2.0
    #: a blend of two families is split when two directions lower the total chi-square by more than this (step 3)
    split_gain: float = 25.0
    #: the most families searched for
    max_families: int = 20


@dataclass
class Family:
    """One family of a view: unit ``direction`` (sign arbitrary) with ``cov (3, 3)``, ``lines``
    (indices), ``pixels`` (their total)."""

    direction: np.ndarray
    cov: np.ndarray
    lines: list
    pixels: int

    @property
    def std_deg(self) -> float:
        """The direction's standard error (degrees, root of the covariance's trace)."""
        return float(np.degrees(np.sqrt(max(np.trace(self.cov), 0.0))))


def _chi2(N, C, S, floor2):
    """``(H, L)`` chi-square of each line's plane against each direction ``S (H, 3)``."""
    num = (S @ N.T) ** 2
    den = np.einsum("hi,lij,hj->hl", S, C, S) + floor2
    return num / den


def refine_direction(N, C, lines, s0, covariance: bool = True):
    """The common direction of the lines ``lines`` (plane normals ``N``, covariances ``C``) and its covariance
    (None without ``covariance``), signed like ``s0``; ``s0`` and the identity for fewer than two lines."""
    from ..linefit import direction_from_planes

    if len(lines) < 2:
        return s0, np.eye(3)
    s, cov = direction_from_planes(N[lines], C[lines], covariance=covariance)
    return (s if s @ s0 >= 0 else -s), cov


def log_nfa(eps_agree: np.ndarray, n_free: int) -> float:
    """How surprising it is that ``len(eps_agree)`` of ``n_free`` lines agree with one direction,
    each line ``i`` by chance with probability ``eps_agree[i]`` (for a direction uniform on the
    sphere, ``P(|n . s| <= e) = e``): ``log C(n_free - 2, k - 2) + sum log eps`` over all but the two
    lines that fix the direction (the two most precise: the conservative choice)."""
    from scipy.special import gammaln

    k = len(eps_agree)
    if k <= 2:
        return 0.0
    e = np.sort(eps_agree)[2:]
    m = max(n_free - 2, k - 2)
    log_comb = gammaln(m + 1) - gammaln(k - 1) - gammaln(m - k + 3)
    return float(log_comb + np.sum(np.log(e)))


def log_nfa_rows(eps: np.ndarray, agree: np.ndarray, n_free: int) -> np.ndarray:
    """:func:`log_nfa` of every row of ``eps (H, L)`` over its lines ``agree (H, L)`` at once (the
    hypotheses of one round of :func:`group_families`): ``(H,)``."""
    from scipy.special import gammaln

    k = agree.sum(axis=1)
    if eps.shape[1] < 2:
        return np.zeros(len(k))
    # every agreeing line's log, less the two smallest (the lines that fix the direction)
    rows, cols = np.nonzero(agree)
    logs = np.bincount(rows, weights=np.log(eps[rows, cols]), minlength=len(k))
    two = np.partition(np.where(agree, eps, np.inf), 1, axis=1)[:, :2]
    with np.errstate(invalid="ignore"):
        logs = logs - np.log(np.where(np.isfinite(two), two, 1.0)).sum(axis=1)
    m = np.maximum(n_free - 2, k - 2)
    log_comb = gammaln(m + 1) - gammaln(k - 1) - gammaln(m - k + 3)
    return np.where(k <= 2, 0.0, log_comb + logs)


def concurrent(cam, s, ends, radius: float) -> bool:
    """True when most of the lines (end pixels ``ends (k, 2, 2)``) end within ``radius`` pixels of
    an image of ``+s`` or ``-s``: lines through one point (a building's corner) whose planes all
    hold the ray to it, not parallel lines (which recede towards their vanishing point but
    end short of it)."""
    vp = cam.vanishing_points(np.stack([s, -s]))
    pts = np.asarray(vp.uv)[np.asarray(vp.valid)]
    if len(pts) == 0:
        return False
    d = np.linalg.norm(ends[:, :, None, :] - pts[None, None], axis=-1).min(axis=(1, 2))
    return bool(np.mean(d <= radius) >= 0.5)


def group_families(planes: LinePlanes, options: GroupingOptions = GroupingOptions()) -> tuple[np.ndarray, list[Family]]:
    """Families of the lines ``planes`` (:class:`LinePlanes`: their planes' normals, covariances and
    pixel counts, optionally the camera and their end pixels for the concurrency check), grouped as
    the module docstring says with ``options`` (:class:`GroupingOptions`). Returns ``(family (L,),
    families)``: each line's family index into ``families`` or -1."""
    o = options
    chi2_max, min_lines, max_families = o.chi2_max, o.min_lines, o.max_families
    cam, ends = planes.cam, planes.ends
    N = np.asarray(planes.normals, float).reshape(-1, 3)
    C = np.asarray(planes.covs, float).reshape(-1, 3, 3)
    w = np.asarray(planes.pixels, float).reshape(-1)
    L = len(N)
    label = np.full(L, -1, dtype=np.int64)
    if L < max(min_lines, 2):
        return label, []
    floor2 = np.sin(np.radians(o.angle_floor_deg)) ** 2
    search = w >= o.min_search_pixels  # the lines that find families; shorter ones only join them
    seeds = np.argsort(-np.where(search, w, -1.0))[:min(o.max_seed_lines, int(search.sum()))]
    i, j = np.triu_indices(len(seeds), 1)
    S = np.cross(N[seeds[i]], N[seeds[j]])
    sn = np.linalg.norm(S, axis=1)
    ok = sn >= np.sin(np.radians(o.min_seed_angle_deg))
    S = S[ok] / sn[ok, None]
    if len(S) == 0:
        return label, []
    X2 = _chi2(N, C, S, floor2)  # (H, L)
    # each line's chance of agreeing with a random direction: the width of its band of agreement
    band = np.sqrt(chi2_max * (np.einsum("hi,lij,hj->hl", S, C, S) + floor2))  # (H, L)
    free = search.copy()
    dirs, members = [], []
    agree = None  # the hypotheses' lines, their scores and which are left: valid while ``free`` is unchanged
    for _ in range(10 * max_families):  # rejected hypotheses count too
        if len(dirs) >= max_families:
            break
        if agree is None:
            agree = (X2 <= chi2_max) & free[None]
            left = agree.sum(axis=1) >= min_lines
            n_free = int(free.sum())
            # rank by significance (most negative log NFA first); a row's score is its own lines' alone
            scores = np.zeros(len(S))
            scores[left] = log_nfa_rows(np.minimum(band[left], 1.0), agree[left], n_free)
            rejected = set()  # the line sets already refined and dropped (the same set: the same outcome)
        cand = np.flatnonzero(left)
        if len(cand) == 0:
            break
        h = int(cand[np.argmin(scores[cand])])
        lines = np.flatnonzero(agree[h])
        key = lines.tobytes()
        if key in rejected:  # what follows depends on the lines alone, not on the direction through two of them
            X2[h], left[h] = np.inf, False
            continue
        s = S[h]
        for _ in range(3):
            s, _ = refine_direction(N, C, lines, s, covariance=False)
            x2 = _chi2(N, C, s[None], floor2)[0]
            new = np.flatnonzero((x2 <= chi2_max) & free)
            if np.array_equal(new, lines) or len(new) < min_lines:
                break
            lines = new
        sub = _split(N, C, lines, s, floor2, min_lines, o.split_gain)
        if sub is not None:  # a blend of two families: keep the better half, the rest stays free
            lines = sub
            s, _ = refine_direction(N, C, lines, s, covariance=False)
        b = np.sqrt(chi2_max * (np.einsum("i,lij,j->l", s, C[lines], s) + floor2))
        if (len(lines) < min_lines or log_nfa(np.minimum(b, 1.0), n_free) > o.max_log_nfa
                or (cam is not None and concurrent(cam, s, np.asarray(ends)[lines], o.concurrency_px))):
            # the hypothesis does not hold up once refined: drop it and go on
            X2[h], left[h] = np.inf, False
            rejected.add(key)
            continue
        dirs.append(s)
        members.append(lines)
        free[lines] = False
        agree = None
    dirs = _merge_close(N, C, dirs, members, np.radians(o.merge_deg))
    return _assign(N, C, w, dirs, floor2, chi2_max, min_lines, np.radians(o.max_band_deg))


def _split(N, C, lines, s, floor2, min_lines, gain, tight=4.0):
    """Two families taken for one: when the lines split into two sets of at least ``min_lines``,
    each fitting its own direction (chi-square <= ``tight`` per line about a direction through two
    of its lines), whose total chi-square is lower than the single direction's by more than
    ``gain``, the set of the larger significance (lines, then total chi-square) is returned;
    else None."""
    lines = np.asarray(lines)
    k = len(lines)
    if k < 2 * min_lines or gain <= 0:
        return None
    single = float(np.sum(_chi2(N[lines], C[lines], s[None], floor2)))
    i, j = np.triu_indices(k, 1)
    H = np.cross(N[lines[i]], N[lines[j]])
    hn = np.linalg.norm(H, axis=1)
    keep = hn > 1e-9
    if not keep.any():
        return None
    H = H[keep] / hn[keep, None]
    X = _chi2(N[lines], C[lines], H, floor2)  # (H, k)
    tight_n = (X <= tight).sum(axis=1)
    best, seen = None, set()
    for h in np.argsort(-tight_n)[:20]:
        a = X[h] <= tight
        if a.sum() < min_lines or (~a).sum() < min_lines:
            continue
        if a.tobytes() in seen:  # the same split again (through two other lines of one set): the same totals
            continue
        seen.add(a.tobytes())
        sa, _ = refine_direction(N, C, lines[a], H[h], covariance=False)
        rest = lines[~a]
        # the rest's own best direction (through two of its lines)
        ii, jj = np.triu_indices(len(rest), 1)
        Hb = np.cross(N[rest[ii]], N[rest[jj]])
        nb = np.linalg.norm(Hb, axis=1)
        if not (nb > 1e-9).any():
            continue
        Hb = Hb[nb > 1e-9] / nb[nb > 1e-9, None]
        sb = Hb[int(np.argmin(np.sum(np.minimum(_chi2(N[rest], C[rest], Hb, floor2), 9.0), axis=1)))]
        sb, _ = refine_direction(N, C, rest, sb, covariance=False)
        total = float(np.sum(_chi2(N[lines[a]], C[lines[a]], sa[None], floor2))
                      + np.sum(_chi2(N[rest], C[rest], sb[None], floor2)))
        if single - total > gain and (best is None or total < best[0]):
            best = (total, lines[a] if a.sum() >= (~a).sum() else rest)
    return None if best is None else best[1]


def _merge_close(N, C, dirs, members, max_angle):
    """Directions found twice merged: two families less than ``max_angle`` apart (one family whose
    lines' systematic errors exceed their covariance, split by the sequential search) become one,
    its direction refitted on both sets of lines."""
    dirs, members = list(dirs), [np.asarray(m) for m in members]
    while len(dirs) > 1:
        D = np.array(dirs)
        ang = np.arccos(np.clip(np.abs(D @ D.T), 0.0, 1.0))
        np.fill_diagonal(ang, np.inf)
        i, j = np.unravel_index(int(np.argmin(ang)), ang.shape)
        if ang[i, j] >= max_angle:
            break
        lines = np.union1d(members[i], members[j])
        s0 = dirs[i] if len(members[i]) >= len(members[j]) else dirs[j]
        s, _ = refine_direction(N, C, lines, s0, covariance=False)
        for k in sorted((i, j), reverse=True):
            del dirs[k], members[k]
        dirs.append(s)
        members.append(lines)
    return dirs


def _agree(N, C, D, floor2, chi2_max, max_band):
    """``(F, L)``: line l agrees with direction f, and its band of agreement is at most ``max_band``
    (radians) wide: a line that would agree with directions far apart places nothing."""
    num = (D @ N.T) ** 2
    var = np.einsum("fi,lij,fj->fl", D, C, D) + floor2
    return (num <= chi2_max * var) & (chi2_max * var <= max_band**2)


def _assign(N, C, w, dirs, floor2, chi2_max, min_lines, max_band):
    """Each line to the one family it agrees with (else -1); families left with fewer than
    ``min_lines`` dropped, the others refitted on their lines, until nothing changes."""
    L = len(N)
    label = np.full(L, -1, dtype=np.int64)
    D = np.array(dirs).reshape(-1, 3)
    families: list[Family] = []
    for _ in range(5):
        if len(D) == 0:
            return np.full(L, -1, dtype=np.int64), []
        agree = _agree(N, C, D, floor2, chi2_max, max_band)  # (F, L)
        label = np.where(agree.sum(axis=0) == 1, np.argmax(agree, axis=0), -1)
        keep = [f for f in range(len(D)) if np.sum(label == f) >= min_lines]
        families = []
        for f in keep:
            lines = np.flatnonzero(label == f)
            s, cov = refine_direction(N, C, lines, D[f])
            families.append(Family(direction=s, cov=cov, lines=lines.tolist(), pixels=int(w[lines].sum())))
        newD = np.array([f.direction for f in families]).reshape(-1, 3)
        if len(newD) == len(D) and np.allclose(np.abs(np.sum(newD * D, axis=1)), 1.0, atol=1e-12):
            break
        D = newD
    # the labels of the final directions
    agree = _agree(N, C, D, floor2, chi2_max, max_band)
    label = np.where(agree.sum(axis=0) == 1, np.argmax(agree, axis=0), -1)
    for f, fam in enumerate(families):
        fam.lines = np.flatnonzero(label == f).tolist()
        fam.pixels = int(w[fam.lines].sum())
    return label.astype(np.int64), families
