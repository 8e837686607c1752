"""Line curves from chains: robust plane hypotheses along each chain (MSAC), the chain cut into
the runs that one line explains, and runs of one line merged.

Model and distances: :mod:`catadioptric.linefit.planes` (the plane holding a line's rays, pixel
distances to first order).

1. **Along a chain.** Hypotheses ``n = d_i x d_j`` from pairs of points of the chain at least
   ``min_span`` points apart (all such pairs on a grid of the chain, at most ``hypotheses``); a
   hypothesis's consensus is the longest run of consecutive points within ``threshold`` pixels
   (gaps of up to ``max_gap`` points bridged), scored by the MSAC sum ``sum(1 - r^2 / thr^2)``.
   The best run is refitted, re-grown from the refitted plane and kept as a piece when it has
   ``min_points``; what lies on either side is searched again. A chain that turns a corner or runs
   through a junction is so cut into the pieces of its lines.
2. **Merging.** Pieces whose normals are within ``merge_angle_deg`` and which come within
   ``max_gap`` pixels of each other in the image are candidate pairs (parallel lines of one
   plane through the rig have one curve: pieces far apart on it may be different lines); a pair is
   merged when the plane fitted to both explains each within ``threshold`` (the 95th percentile of
   the distances) and its rms stays below ``0.5 threshold`` plus the pieces' own. The best pair
   first, until none passes (greedy agglomeration). Two pieces of one 3-D line (broken by an
   occluder, a window, a gap in the edges) and the band centre and an unpaired edge of one tube
   so become one line.
3. **Each line**: its pixels ordered along the curve, its plane normal with covariance (the
   residual rms, at least ``sigma_floor`` pixels), rms, length.
"""
from __future__ import annotations

import heapq
from dataclasses import dataclass

import numpy as np

from ..linefit.planes import Rays, plane_covariance, plane_distances, refine_plane

__all__ = ["LinePiece", "split_chain", "merge_pieces", "concat_rays"]


@dataclass
class LinePiece:
    """Points ``uv (M, 2)`` explained by one plane: their ``rays``, unit ``normal``, ``rms``
    (pixels), ``sources`` (the chains' indices), ``polarity`` of the chain(s) (0 step edge, +-1 band)."""

    uv: np.ndarray
    rays: Rays
    normal: np.ndarray
    rms: float
    sources: list
    polarity: int

    @property
    def length(self) -> int:
        return len(self.uv)


def _runs(inlier: np.ndarray, max_gap: int) -> list[tuple[int, int]]:
    """Runs ``[a, b)`` of True in ``inlier`` with gaps of at most ``max_gap`` False bridged."""
    idx = np.flatnonzero(inlier)
    if len(idx) == 0:
        return []
    cut = np.flatnonzero(np.diff(idx) > max_gap + 1)
    starts = np.r_[idx[0], idx[cut + 1]]
    ends = np.r_[idx[cut], idx[-1]] + 1
    return list(zip(starts.tolist(), ends.tolist()))


def _best_run(R: np.ndarray, thr: float, max_gap: int) -> tuple[int, int, int] | None:
    """The best run over the rows of ``R (H, M)`` (each hypothesis' distances along the chain): the
    runs of :func:`_runs` in every row, each scored ``sum (1 - (r / thr)^2)`` over its points within
    ``thr``; ``(row, a, b)`` of the highest score (the first row, then the first run, on a tie), or
    None when no point is within ``thr``."""
    rows, cols = np.nonzero(R <= thr)
    if len(rows) == 0:
        return None
    new = np.r_[True, (rows[1:] != rows[:-1]) | (np.diff(cols) > max_gap + 1)]
    first = np.flatnonzero(new)
    last = np.r_[first[1:], len(rows)] - 1
    score = np.add.reduceat(1.0 - (R[rows, cols] / thr) ** 2, first)
    k = int(np.argmax(score))
    return int(rows[first[k]]), int(cols[first[k]]), int(cols[last[k]]) + 1


def _hypotheses(rays: Rays, min_span: int, max_h: int) -> np.ndarray:
    M = len(rays.d)
    step = max(1, int(np.ceil(M / np.sqrt(2.0 * max_h))))
    grid = np.arange(0, M, step)
    i, j = np.meshgrid(grid, grid, indexing="ij")
    keep = (j - i) >= min_span
    i, j = i[keep], j[keep]
    if len(i) == 0:
        i, j = np.array([0]), np.array([M - 1])
    if len(i) > max_h:
        sel = np.round(np.linspace(0, len(i) - 1, max_h)).astype(int)
        i, j = i[sel], j[sel]
    n = np.cross(rays.d[i], rays.d[j])
    nn = np.linalg.norm(n, axis=1)
    return n[nn > 1e-12] / nn[nn > 1e-12, None]


def split_chain(uv: np.ndarray, rays: Rays, *, threshold: float = 1.0, min_points: int = 12, min_span: int = 6,
                max_gap: int = 2, hypotheses: int = 60, source: int = 0, polarity: int = 0) -> list[LinePiece]:
    """The pieces of one ordered chain ``uv (M, 2)`` (rays ``rays``) that single planes explain
    (module docstring, step 1)."""
    pieces = []
    todo = [(0, len(uv))]
    while todo:
        a, b = todo.pop()
        if b - a < min_points:
            continue
        sub = rays.take(slice(a, b))
        if sub.ok.sum() < min_points:
            continue
        H = _hypotheses(sub.take(np.flatnonzero(sub.ok)), min(min_span, int(sub.ok.sum()) - 1), hypotheses)
        if len(H) == 0:
            continue
        best = _best_run(plane_distances(H, sub), threshold, max_gap)
        if best is None or best[2] - best[1] < min_points:
            continue
        h, ra, rb = best
        n = H[h]
        for _ in range(2):  # refit on the run, regrow the run from the refitted plane
            n = refine_plane(sub.take(slice(ra, rb)), n)
            r = plane_distances(n, sub)
            runs = [(x, y) for x, y in _runs(r <= threshold, max_gap) if x <= (ra + rb) // 2 < y]
            if not runs:
                break
            ra, rb = runs[0]
        if rb - ra < min_points:
            continue
        piece_rays = sub.take(slice(ra, rb))
        r = plane_distances(n, piece_rays)
        ok = np.isfinite(r) & (r <= threshold)
        if ok.sum() >= min_points:
            rr = piece_rays.take(np.flatnonzero(ok))
            pieces.append(LinePiece(uv=uv[a + ra: a + rb][ok], rays=rr, normal=n,
                                    rms=float(np.sqrt(np.mean(r[ok] ** 2))), sources=[source], polarity=polarity))
        todo.append((a, a + ra))
        todo.append((a + rb, b))
    return pieces


def concat_rays(parts: list[Rays]) -> Rays:
    """The rays of several pieces joined into one :class:`Rays`, in order."""
    return Rays(*(np.concatenate([getattr(p, f) for p in parts]) for f in ("uv", "d", "Jd", "ok")))


def _joint(p: LinePiece, q: LinePiece, threshold: float):
    """The plane of two pieces together, its rms and whether it explains both."""
    rays = concat_rays([p.rays, q.rays])
    w = np.r_[np.full(p.length, 1.0), np.full(q.length, 1.0)]
    n0 = p.normal if p.length >= q.length else q.normal
    n = refine_plane(rays, n0)
    r = plane_distances(n, rays)
    rp, rq = r[: p.length], r[p.length:]
    ok = (np.percentile(rp, 95) <= threshold) and (np.percentile(rq, 95) <= threshold)
    rms = float(np.sqrt(np.average(r**2, weights=w)))
    ok = ok and rms <= 0.5 * threshold + max(p.rms, q.rms)
    return ok, n, rms, rays


def _gap(p: LinePiece, tree_q) -> float:
    """The smallest image distance between a point of ``p`` and one of the piece whose points
    ``tree_q`` (a ``cKDTree``) holds (pixels)."""
    return float(tree_q.query(p.uv)[0].min())


def merge_pieces(pieces: list[LinePiece], *, threshold: float = 1.0, merge_angle_deg: float = 10.0,
                 max_gap: float = 20.0) -> list[LinePiece]:
    """Pieces of one line merged (module docstring, step 2)."""
    pieces = list(pieces)
    if len(pieces) < 2:
        return pieces
    cos_max = np.cos(np.radians(merge_angle_deg))
    alive = [True] * len(pieces)
    from scipy.spatial import cKDTree

    # every pair of live pieces whose planes are within merge_angle_deg is tested once (a pair's test
    # does not change while both live); the pairs that merge wait in a heap by (rms, i, j): the
    # smallest rms first, ties to the first pair in index order
    heap: list = []
    found: dict = {}
    trees: dict = {}  # each piece's points, for the gaps
    boxes: dict = {}  # each piece's bounding box: a gap no shorter than the boxes' distance

    def box(k):
        if k not in boxes:
            boxes[k] = (pieces[k].uv.min(axis=0), pieces[k].uv.max(axis=0))
        return boxes[k]

    def push(i, j):
        (lo_i, hi_i), (lo_j, hi_j) = box(i), box(j)
        if np.hypot(*np.maximum(np.maximum(lo_i - hi_j, lo_j - hi_i), 0.0)) > max_gap:
            return
        if j not in trees:
            trees[j] = cKDTree(pieces[j].uv)
        if _gap(pieces[i], trees[j]) > max_gap:
            return
        ok, n, rms, rays = _joint(pieces[i], pieces[j], threshold)
        if ok:
            found[i, j] = (n, rays)
            heapq.heappush(heap, (rms, i, j))

    N = np.array([p.normal for p in pieces])
    c = np.abs(N @ N.T)
    lo = np.array([p.uv.min(axis=0) for p in pieces])
    hi = np.array([p.uv.max(axis=0) for p in pieces])
    for i in range(len(pieces)):
        js = np.flatnonzero(c[i, i + 1:] >= cos_max) + i + 1
        # the boxes' distance of push, for all of i's pairs at once (the same arithmetic)
        g = np.maximum(np.maximum(lo[i] - hi[js], lo[js] - hi[i]), 0.0)
        for j in js[np.hypot(g[:, 0], g[:, 1]) <= max_gap]:
            push(i, int(j))
    while heap:
        rms, i, j = heapq.heappop(heap)
        if not (alive[i] and alive[j]):
            continue
        n, rays = found.pop((i, j))
        p, q = pieces[i], pieces[j]
        pieces.append(LinePiece(uv=np.concatenate([p.uv, q.uv]), rays=rays, normal=n, rms=rms,
                                sources=p.sources + q.sources, polarity=p.polarity if p.length >= q.length
                                else q.polarity))
        alive[i] = alive[j] = False
        alive.append(True)
        m = len(pieces) - 1
        for k in range(m):
            if alive[k] and abs(float(pieces[k].normal @ n)) >= cos_max:
                push(k, m)
    return [p for p, a in zip(pieces, alive) if a]


def order_along(piece: LinePiece) -> np.ndarray:
    """Indices ordering the piece's points along its curve: by the angle of their rays in the plane."""
    e1 = piece.rays.d[0] - (piece.rays.d[0] @ piece.normal) * piece.normal
    e1 /= max(np.linalg.norm(e1), 1e-300)
    e2 = np.cross(piece.normal, e1)
    ang = np.arctan2(piece.rays.d @ e2, piece.rays.d @ e1)
    # unwrap about the largest gap so that a curve crossing +-pi stays in one piece
    o = np.argsort(ang)
    a = ang[o]
    gaps = np.diff(np.r_[a, a[0] + 2 * np.pi])
    k = int(np.argmax(gaps))
    return np.r_[o[k + 1:], o[: k + 1]]


def line_covariance(piece: LinePiece, sigma_floor: float, systematic_px: float = 0.0) -> np.ndarray:
    """The normal's covariance: independent pixel noise of the piece's rms (at least
    ``sigma_floor``), plus a systematic error of ``systematic_px`` pixels that does not average out
    along the line (a band centre or an edge offset from the line's true image by a varying part of
    the tube's width, aliasing): counted as two independent errors of that size, at the ends."""
    M = max(int(piece.rays.ok.sum()), 1)
    cov = plane_covariance(piece.normal, piece.rays, max(piece.rms, sigma_floor))
    if systematic_px > 0:
        cov = cov + plane_covariance(piece.normal, piece.rays, systematic_px) * (M / 2.0)
    return cov
