"""Batched polynomial kernels: arithmetic on coefficient arrays and real roots in [-1, 1].

Polynomials are coefficient arrays in ascending powers along the last axis,
``p[..., k]`` multiplying ``t**k``; every function works on a whole batch at
once, with Python loops over the (small) degree only, never over the batch.

Real roots in an interval are isolated with the Bernstein form and Descartes'
rule of signs, subdividing with de Casteljau's algorithm, and refined with a
bracketed Newton iteration. Only roots inside the interval are ever touched,
which is what makes the reflection solvers fast: the mirror patch fixes the
interval of interest.
"""
from __future__ import annotations

from functools import lru_cache
from math import comb

import numpy as np

from .._numeric import rowdot

__all__ = [
    "polymul",
    "polyadd",
    "polysub",
    "polyval",
    "polyder",
    "deflate_linear",
    "roots_in_unit_interval",
]


def _pad(p: np.ndarray, n: int) -> np.ndarray:
    if p.shape[-1] >= n:
        return p
    pad = [(0, 0)] * (p.ndim - 1) + [(0, n - p.shape[-1])]
    return np.pad(p, pad)


def polyadd(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    n = max(p.shape[-1], q.shape[-1])
    return _pad(p, n) + _pad(q, n)


def polysub(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    n = max(p.shape[-1], q.shape[-1])
    return _pad(p, n) - _pad(q, n)


@lru_cache(maxsize=None)
def _conv_matrix(n: int, m: int) -> np.ndarray:
    T = np.zeros((n * m, n + m - 1))
    for i in range(n):
        for j in range(m):
            T[i * m + j, i + j] = 1.0
    return T


def polymul(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Product of batched polynomials (broadcasting over leading axes)."""
    n, m = p.shape[-1], q.shape[-1]
    outer = p[..., :, None] * q[..., None, :]
    return rowdot(outer.reshape(outer.shape[:-2] + (n * m,)), _conv_matrix(n, m))


def polyval(p: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Horner evaluation of ``p[..., :]`` at ``t`` (broadcast against ``p[..., 0]``)."""
    out = np.broadcast_to(p[..., -1], np.broadcast_shapes(p.shape[:-1], np.shape(t))).copy()
    for k in range(p.shape[-1] - 2, -1, -1):
        out *= t
        out += p[..., k]
    return out


def polyval_der(p: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``p(t)`` and ``p'(t)`` in one Horner pass (rows of ``p`` against entries of ``t``)."""
    f = p[..., -1].copy()
    df = np.zeros_like(f)
    for k in range(p.shape[-1] - 2, -1, -1):
        df *= t
        df += f
        f *= t
        f += p[..., k]
    return f, df


def polyder(p: np.ndarray) -> np.ndarray:
    n = p.shape[-1]
    if n == 1:
        return np.zeros_like(p)
    return p[..., 1:] * np.arange(1, n, dtype=float)


def deflate_linear(p: np.ndarray, e: np.ndarray) -> np.ndarray:
    """Exact quotient ``p / e`` for batched linear ``e = e0 + e1 t`` dividing ``p``.

    The division runs from the side that is numerically stable for the root
    of ``e``: from the leading coefficient when that root lies inside the unit
    disc, from the constant term otherwise (and for constant ``e``). The
    remainder, which is rounding noise when ``e`` divides ``p``, is dropped.
    """
    e0, e1 = e[..., 0], e[..., 1]
    n = p.shape[-1] - 1
    forward = np.abs(e1) > np.abs(e0)  # root -e0/e1 inside the unit disc
    q = np.zeros(p.shape[:-1] + (n,))
    # forward: from the top, q[n-1] = p[n]/e1, q[k-1] = (p[k] - e0 q[k]) / e1
    with np.errstate(divide="ignore", invalid="ignore"):
        qf = np.zeros_like(q)
        qf[..., n - 1] = p[..., n] / e1
        for k in range(n - 1, 0, -1):
            qf[..., k - 1] = (p[..., k] - e0 * qf[..., k]) / e1
        # backward: from the bottom, q[0] = p[0]/e0, q[k] = (p[k] - e1 q[k-1]) / e0
        qb = np.zeros_like(q)
        qb[..., 0] = p[..., 0] / e0
        for k in range(1, n):
            qb[..., k] = (p[..., k] - e1 * qb[..., k - 1]) / e0
    q = np.where(forward[..., None], qf, qb)
    return q


@lru_cache(maxsize=None)
def _bernstein_matrix(n: int) -> np.ndarray:
    """Matrix T with ``b = a @ T``: monomial coefficients on t in [-1, 1] to the
    Bernstein coefficients of degree n on u in [0, 1], t = 2u - 1."""
    # monomial in t -> monomial in u: t^k = (2u - 1)^k
    M = np.zeros((n + 1, n + 1))
    for k in range(n + 1):
        for j in range(k + 1):
            M[k, j] = comb(k, j) * 2.0**j * (-1.0) ** (k - j)
    # monomial in u -> Bernstein: b_i = sum_{j<=i} C(i,j)/C(n,j) m_j
    W = np.zeros((n + 1, n + 1))
    for j in range(n + 1):
        for i in range(j, n + 1):
            W[j, i] = comb(i, j) / comb(n, j)
    return M @ W


def _sign_changes(b: np.ndarray) -> np.ndarray:
    s = b >= 0.0  # zeros count as positive: the count stays an upper bound of the same parity
    return np.count_nonzero(s[:, 1:] != s[:, :-1], axis=1)


def _de_casteljau_halves(b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    n = b.shape[1] - 1
    left = np.empty_like(b)
    right = np.empty_like(b)
    cur = b
    left[:, 0] = cur[:, 0]
    right[:, n] = cur[:, n]
    for k in range(1, n + 1):
        cur = 0.5 * (cur[:, :-1] + cur[:, 1:])
        left[:, k] = cur[:, 0]
        right[:, n - k] = cur[:, -1]
    return left, right


def roots_in_unit_interval(
    p: np.ndarray, *, cluster_width: float = 2.0**-20, newton_iters: int = 40
) -> tuple[np.ndarray, np.ndarray]:
    """All real roots in [-1, 1] of a batch of polynomials ``p`` of shape (M, n+1).

    Returns ``(index, t)``: flat arrays (in no particular order), ``index[i]`` the row
    of ``p`` whose root is ``t[i]``. Roots are isolated by Descartes' rule on Bernstein coefficients (an
    interval whose coefficients change sign once holds exactly one root), subdividing
    with de Casteljau's algorithm. An interval narrower than ``cluster_width`` that
    still shows two or more sign changes holds a cluster (a double root, two roots
    closer than the width, or a complex pair next to the real axis, all of which
    rounding can turn into one another): it gives the extremum of ``p`` there and the
    real roots of the local quadratic model, when ``p`` is at rounding level near it.
    Candidates are approximate in clusters; callers polish them on the full system.
    Rows that vanish identically give no roots.
    """
    p = np.asarray(p, dtype=float)
    M, n1 = p.shape
    n = n1 - 1
    if M == 0 or n < 1:
        return np.zeros(0, dtype=np.intp), np.zeros(0)
    scale = np.max(np.abs(p), axis=1)
    live = scale > 0
    if np.all(live):
        pn = p / scale[:, None]
        b = rowdot(pn, _bernstein_matrix(n))
        idx = np.arange(M)
    else:
        pn = np.zeros_like(p)
        pn[live] = p[live] / scale[live, None]
        b = rowdot(pn[live], _bernstein_matrix(n))
        idx = np.nonzero(live)[0]
    lo = np.zeros(len(idx))
    width = 1.0
    out_idx, out_lo, out_hi = [], [], []
    clusters_idx, clusters_lo, clusters_w = [], [], []
    for end, col in ((0.0, 0), (1.0, n)):  # exact roots at the ends
        z = b[:, col] == 0.0
        if np.any(z):
            out_idx.append(idx[z])
            out_lo.append(np.full(np.count_nonzero(z), end))
            out_hi.append(np.full(np.count_nonzero(z), end))
    while len(idx):
        v = _sign_changes(b)
        one = v == 1
        if np.any(one):
            out_idx.append(idx[one])
            out_lo.append(lo[one])
            out_hi.append(lo[one] + width)
        many = v >= 2
        if not np.any(many):
            break
        if width <= cluster_width:
            clusters_idx.append(idx[many])
            clusters_lo.append(lo[many])
            clusters_w.append(np.full(np.count_nonzero(many), width))
            break
        idx, b, lo = idx[many], b[many], lo[many]
        left, right = _de_casteljau_halves(b)
        half = 0.5 * width
        z = left[:, n] == 0.0  # a zero exactly at the split point is a root of its own
        if np.any(z):
            out_idx.append(idx[z])
            out_lo.append(lo[z] + half)
            out_hi.append(lo[z] + half)
        idx = np.concatenate([idx, idx])
        b = np.concatenate([left, right])
        lo = np.concatenate([lo, lo + half])
        width = half
    ridx = np.concatenate(out_idx) if out_idx else np.zeros(0, dtype=np.intp)
    if len(ridx):
        a = np.concatenate(out_lo) * 2.0 - 1.0
        c = np.concatenate(out_hi) * 2.0 - 1.0
        t = _refine_bracketed(pn[ridx], a, c, newton_iters)
    else:
        t = np.zeros(0)
    if clusters_idx:
        ci, ct = _cluster_candidates(pn, np.concatenate(clusters_idx), np.concatenate(clusters_lo) * 2.0 - 1.0,
                                     np.concatenate(clusters_w) * 2.0)
        ridx = np.concatenate([ridx, ci])
        t = np.concatenate([t, ct])
    return ridx, t


def _cluster_candidates(p, idx, a, w):
    """Candidates in tiny intervals [a, a + w] holding a root cluster of the rows ``p[idx]``."""
    q = p[idx]
    dq = polyder(q)
    ddq = polyder(dq)
    # the extremum: a root of p' near the cluster (Newton from the middle, kept in a widened box)
    t = a + 0.5 * w
    for _ in range(8):
        with np.errstate(divide="ignore", invalid="ignore"):
            step = polyval(dq, t) / polyval(ddq, t)
        tn = t - np.where(np.isfinite(step), step, 0.0)
        t = np.clip(tn, a - w, a + 2 * w)
    f = polyval(q, t)
    f2 = polyval(ddq, t)
    small = np.abs(f) <= 1e-9  # rows are normalised to max |coefficient| = 1
    with np.errstate(divide="ignore", invalid="ignore"):
        delta = np.sqrt(np.maximum(-2.0 * f / f2, 0.0))
    pair = np.isfinite(delta) & (delta > 0) & (delta <= 2 * w)
    out_i = [idx[small], idx[pair], idx[pair]]
    out_t = [t[small], (t - delta)[pair], (t + delta)[pair]]
    return np.concatenate(out_i), np.concatenate(out_t)


def _refine_bracketed(p: np.ndarray, a: np.ndarray, c: np.ndarray, iters: int, tol: float = 1e-11) -> np.ndarray:
    """Safeguarded Newton on brackets [a, c] holding one sign change (or a == c).

    Starts from the secant point of the bracket, falls back to bisection when a
    Newton step leaves the bracket, and stops at steps below ``tol`` (the callers
    polish further on the full system). The working set is compacted whenever it
    has shrunk by half, so the cost follows the slow roots, not the batch."""
    fa = polyval(p, a)
    fc = polyval(p, c)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = a - fa * (c - a) / (fc - fa)
    t = np.where(np.isfinite(t) & (t >= a) & (t <= c), t, 0.5 * (a + c))
    sa = np.sign(fa)
    out = t.copy()
    idx = np.nonzero(a < c)[0]
    pw, tw, aw, cw, sw = p[idx], t[idx], a[idx], c[idx], sa[idx]
    live = np.ones(len(idx), dtype=bool)
    for _ in range(iters):
        if not np.any(live):
            break
        f, df = polyval_der(pw, tw)
        same = np.sign(f) == sw
        aw = np.where(same, tw, aw)
        cw = np.where(same, cw, tw)
        with np.errstate(divide="ignore", invalid="ignore"):
            tn = tw - f / df
        bad = ~np.isfinite(tn) | (tn <= np.minimum(aw, cw)) | (tn >= np.maximum(aw, cw))
        tn = np.where(bad, 0.5 * (aw + cw), tn)
        done = (f == 0.0) | (np.abs(cw - aw) <= tol) | (~bad & (np.abs(tn - tw) <= tol))
        tw = np.where(live & (f != 0.0), tn, tw)
        live &= ~done
        if np.count_nonzero(live) < len(live) // 2:  # compact
            out[idx] = tw
            keep = np.nonzero(live)[0]
            idx, pw, tw, aw, cw, sw = idx[keep], pw[keep], tw[keep], aw[keep], cw[keep], sw[keep]
            live = np.ones(len(idx), dtype=bool)
    out[idx] = tw
    return out
