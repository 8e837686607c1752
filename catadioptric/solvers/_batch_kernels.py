"""The compiled bookkeeping of the reflection solvers' batches (numba), one entry at a time:
targets as unit homogeneous 4-vectors, the selections of targets near a normal line or near the
plane of the camera and the axis, the flat solutions sorted by owner (repeats dropped, slots
ranked, put into their slots), and the visibility of reflection points. Like
:mod:`catadioptric.solvers._kernels` (the solvers' arithmetic): the formulas of the routines
that call them and document them, float64, no fast-math, one entry at a time, cached.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["homogeneous_units", "near_normal", "near_plane", "sorted_unique", "rank_rows", "visibility_rows", "put_rows"]

_JIT = {"cache": True, "nogil": True, "error_model": "numpy"}


# -- flat solutions sorted by (owner, z), repeats dropped

@njit(**_JIT)
def _sort_by_owner(owner, key, n_owners, order, start):
    """``order``: the entries sorted by (owner, key), stable, NaN keys last (as ``np.lexsort``);
    ``start[o]:start[o + 1]``: owner o's entries in ``order``. Counting sort by owner, then
    insertion sort by key within each owner (a few entries)."""
    n = len(owner)
    start[:] = 0
    for i in range(n):
        start[owner[i] + 1] += 1
    for o in range(n_owners):
        start[o + 1] += start[o]
    pos = start[:-1].copy()
    for i in range(n):
        order[pos[owner[i]]] = i
        pos[owner[i]] += 1
    for o in range(n_owners):
        a, b = start[o], start[o + 1]
        for j in range(a + 1, b):
            x = order[j]
            k = j - 1
            while k >= a and (key[order[k]] > key[x] or (key[order[k]] != key[order[k]] and key[x] == key[x])):
                order[k + 1] = order[k]
                k -= 1
            order[k + 1] = x


@njit(**_JIT)
def sorted_unique(owner, r, fwd, n_owners, tol, out_idx):
    """Indices of the flat solutions ordered by (owner, z) (stable: ties keep their order), without
    repeats: an entry within ``tol`` of an earlier entry of its owner on the same side (``fwd``);
    returns their number (:func:`catadioptric.solvers.reflection.dedupe`)."""
    order = np.empty(len(owner), dtype=np.intp)
    start = np.empty(n_owners + 1, dtype=np.intp)
    _sort_by_owner(owner, r[:, 2].copy(), n_owners, order, start)
    m = 0
    for o in range(n_owners):
        for j in range(start[o], start[o + 1]):
            x = order[j]
            dup = False
            for k in range(start[o], j):
                y = order[k]
                d0, d1, d2 = r[x, 0] - r[y, 0], r[x, 1] - r[y, 1], r[x, 2] - r[y, 2]
                if fwd[x] == fwd[y] and math.sqrt(d0 * d0 + d1 * d1 + d2 * d2) <= tol:
                    dup = True
                    break
            if not dup:
                out_idx[m] = x
                m += 1
    return m


# -- visibility of reflection points

@njit(**_JIT)
def visibility_rows(r, target, w, A, B, C, zlo, zhi, L, center, rz, out):
    """``catadioptric.projection.visibility`` one point at a time (its docstring has the tests);
    ``rz`` is the camera's optical axis in the mirror frame (third row of R_cam_from_mirror)."""
    eps = 1e-9
    c0, c1, c2 = center[0] / L, center[1] / L, center[2] / L
    cc = c0 ** 2 + c1 ** 2 + A * c2 ** 2 + B * c2 - C
    for i in range(len(r)):
        rn0, rn1, rn2 = r[i, 0] / L, r[i, 1] / L, r[i, 2] / L
        d0, d1, d2 = rn0 - c0, rn1 - c1, rn2 - c2
        a = d0 ** 2 + d1 ** 2 + A * d2 ** 2
        t_other = cc / a
        zo = c2 + t_other * d2
        blocked_in = t_other > eps and t_other < 1 - eps and zo >= zlo and zo <= zhi
        wi = w[i]
        q0, q1, q2 = target[i, 0] - wi * r[i, 0], target[i, 1] - wi * r[i, 1], target[i, 2] - wi * r[i, 2]
        m = max(abs(q0), abs(q1), abs(q2))
        u0, u1, u2 = q0 / m, q1 / m, q2 / m
        nu = math.sqrt(u0 * u0 + u1 * u1 + u2 * u2)
        v0, v1, v2 = u0 / nu, u1 / nu, u2 / nu
        a2 = v0 ** 2 + v1 ** 2 + A * v2 ** 2
        b2 = 2 * (rn0 * v0 + rn1 * v1 + A * rn2 * v2) + B * v2
        t2 = -b2 / a2
        if wi > 0.5:
            length = m * nu if m > 0 else 0.0
            t_end = length / L * (1 - eps)
        else:
            t_end = np.inf
        zo2 = rn2 + t2 * v2
        blocked_out = t2 > eps and t2 < t_end and zo2 >= zlo and zo2 <= zhi
        front = ((r[i, 0] - center[0]) * rz[0] + (r[i, 1] - center[1]) * rz[1]) + (r[i, 2] - center[2]) * rz[2] > 0
        out[i] = not blocked_in and not blocked_out and front


# -- targets near a normal line (camera - foot)

@njit(**_JIT)
def near_normal(h, foot, back, tol, out_idx):
    """Indices of the targets ``h (N, 4)`` whose direction from ``foot`` is within sine ``tol`` of the
    unit vector ``back`` (``ReflectionSolver._feet_candidates``); returns their number."""
    m = 0
    for i in range(len(h)):
        t0, t1, t2 = h[i, 0] - h[i, 3] * foot[0], h[i, 1] - h[i, 3] * foot[1], h[i, 2] - h[i, 3] * foot[2]
        tn = math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
        x0, x1, x2 = t1 * back[2] - t2 * back[1], t2 * back[0] - t0 * back[2], t0 * back[1] - t1 * back[0]
        if math.sqrt(x0 * x0 + x1 * x1 + x2 * x2) <= tol * tn and tn > 0:
            out_idx[m] = i
            m += 1
    return m


# -- slots of flat entries within their owner

@njit(**_JIT)
def rank_rows(owner, key, n_owners, order, slot):
    """``order``: the entries sorted by (owner, key), stable; ``slot``: each sorted entry's rank within
    its owner (``catadioptric.solvers.reflection.rank_within``)."""
    start = np.empty(n_owners + 1, dtype=np.intp)
    _sort_by_owner(owner, key, n_owners, order, start)
    for o in range(n_owners):
        for j in range(start[o], start[o + 1]):
            slot[j] = j - start[o]


# -- targets as unit homogeneous 4-vectors; targets near the plane of the camera and the axis

@njit(**_JIT)
def homogeneous_units(targets, w4, out):
    """``out[i] = unit((targets[i], w4[i]))`` the way of :func:`catadioptric._numeric.unit` (divided by
    the largest component first, then by the norm: no overflow nor underflow; NaN for a zero vector)."""
    for i in range(len(targets)):
        m = max(abs(targets[i, 0]), abs(targets[i, 1]), abs(targets[i, 2]), abs(w4[i]))
        a0, a1, a2, a3 = targets[i, 0] / m, targets[i, 1] / m, targets[i, 2] / m, w4[i] / m
        n = math.sqrt(((a0 * a0 + a1 * a1) + a2 * a2) + a3 * a3)
        out[i, 0], out[i, 1], out[i, 2], out[i, 3] = a0 / n, a1 / n, a2 / n, a3 / n


@njit(**_JIT)
def near_plane(h, ok, tol, out_idx):
    """Indices of the targets with ``ok`` and ``|h0| <= tol max(|h1|, |h2|, |h3|)``; returns their number."""
    m = 0
    for i in range(len(h)):
        if ok[i] and abs(h[i, 0]) <= tol * max(abs(h[i, 1]), abs(h[i, 2]), abs(h[i, 3])):
            out_idx[m] = i
            m += 1
    return m


# -- flat entries into NaN-padded slots

@njit(**_JIT)
def put_rows(dst, at, src, sel):
    """``dst[at[q]] = src[sel[q]]`` row by row (``dst (M, d)`` a flat view of the slots)."""
    for q in range(len(at)):
        for j in range(dst.shape[1]):
            dst[at[q], j] = src[sel[q], j]
