"""Batched polynomial kernels: arithmetic on coefficient arrays and real roots in [-1, 1].

Polynomials are coefficient arrays in ascending powers along the last axis,
``p[..., k]`` multiplying ``t**k``; every function works on a whole batch at
once, with Python loops over the (small) degree only, never over the batch; the
root search runs one row at a time in compiled code (:mod:`catadioptric.solvers._kernels`).

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


def roots_in_unit_interval(
    p: np.ndarray, *, cluster_width: float = 2.0**-20, newton_iters: int = 40
) -> tuple[np.ndarray, np.ndarray]:
    """All real roots in [-1, 1] of a batch of polynomials ``p`` of shape (M, n+1).

    Returns ``(index, t)``: flat arrays (grouped by row), ``index[i]`` the row
    of ``p`` whose root is ``t[i]``. Roots are isolated by Descartes' rule on Bernstein coefficients (an
    interval whose coefficients change sign once holds exactly one root), subdividing
    with de Casteljau's algorithm. An interval narrower than ``cluster_width`` that
    still shows two or more sign changes holds a cluster (a double root, two roots
    closer than the width, or a complex pair next to the real axis, all of which
    rounding can turn into one another): it gives the extremum of ``p`` there and the
    real roots of the local quadratic model, when ``p`` is at rounding level near it.
    Candidates are approximate in clusters; callers polish them on the full system.
    Rows that vanish identically give no roots. One row at a time, compiled
    (:func:`catadioptric.solvers._kernels.roots_rows`): brackets are refined by a
    safeguarded Newton iteration (secant start, bisection fallback, steps below 1e-11).
    """
    from ._kernels import roots_rows

    p = np.ascontiguousarray(p, dtype=float)
    M, n1 = p.shape
    n = n1 - 1
    if M == 0 or n < 1:
        return np.zeros(0, dtype=np.intp), np.zeros(0)
    # at most: both ends, n split points, and 3 candidates per 2 sign changes (n in all)
    idx = np.empty(M * (3 * n + 4), dtype=np.intp)
    t = np.empty(M * (3 * n + 4))
    m = roots_rows(p, _bernstein_matrix(n), float(cluster_width), int(newton_iters), idx, t)
    return idx[:m].copy(), t[:m].copy()
