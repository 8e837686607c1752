"""The compiled inner loops of the pose (numba), float64, no fast-math, compiled once per machine
and cached, like :mod:`catadioptric.solvers._kernels`:

* :func:`reduced_normal_equations`, of the two-view refinement: the normal equations with every
  pixel's depth eliminated (:func:`catadioptric.pose.bundle._normal_equations` documents them).
  One pass over the pixels; each pixel touches 10 unknowns (its columns ``cols``) and its own
  depth, so its 10 x 10 block of the reduced system is formed and added where it belongs, in
  pixel order (the order in which ``numpy.bincount`` would add the same terms).
* :func:`alignment_table`, of the lines matched in their order
  (:class:`catadioptric.pose.matching.LinesInOrder`): the dynamic programme of a monotone alignment.
"""
from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["reduced_normal_equations", "alignment_table"]


@njit(cache=True, nogil=True, error_model="numpy")
def reduced_normal_equations(A, b, e, w, lam, cols, ny):
    """``S (ny, ny)``, ``g (ny,)`` of the system over the unknowns ``y`` with each pixel's depth
    eliminated (Schur complement, the depth's diagonal damped by ``1 + lam``), and per pixel the
    terms of the depths' back-substitution: ``Hym (N, 10)``, ``gm (N,)``, ``Hmm_d (N,)``.

    ``A (N, 2, 10)``: d residual / d (the pixel's 10 unknowns, columns ``cols (N, 10)``);
    ``b (N, 2)``: d residual / d depth; ``e (N, 2)``: residuals (non-finite read as 0);
    ``w (N,)``: weights."""
    N = A.shape[0]
    S = np.zeros((ny, ny))
    g = np.zeros(ny)
    Hym = np.zeros((N, 10))
    gm = np.zeros(N)
    Hmm_d = np.zeros(N)
    for n in range(N):
        wn = w[n]
        e0 = e[n, 0] if np.isfinite(e[n, 0]) else 0.0
        e1 = e[n, 1] if np.isfinite(e[n, 1]) else 0.0
        b0 = b[n, 0]
        b1 = b[n, 1]
        hmm = (b0 * b0 + b1 * b1) * wn
        hd = hmm * (1.0 + lam) + 1e-300
        Hmm_d[n] = hd
        gmn = (b0 * e0 + b1 * e1) * wn
        gm[n] = gmn
        for i in range(10):
            Hym[n, i] = wn * A[n, 0, i] * b0 + wn * A[n, 1, i] * b1
        for i in range(10):
            ci = cols[n, i]
            wa0 = wn * A[n, 0, i]
            wa1 = wn * A[n, 1, i]
            g[ci] += (wa0 * e0 + wa1 * e1) - Hym[n, i] * (gmn / hd)
            for j in range(10):
                S[ci, cols[n, j]] += (wa0 * A[n, 0, j] + wa1 * A[n, 1, j]) - Hym[n, i] * Hym[n, j] / hd
    return S, g, Hym, gm, Hmm_d


@njit(cache=True, nogil=True, error_model="numpy")
def alignment_table(gain):
    """``D (n + 1, m + 1)``: ``D[i, j]`` the largest total of positive ``gain`` over pairs increasing in
    both indices among the first ``i`` rows and ``j`` columns of ``gain (n, m)`` (finite)."""
    n, m = gain.shape
    D = np.zeros((n + 1, m + 1))
    for i in range(1, n + 1):
        for j in range(1, m + 1):
            g = gain[i - 1, j - 1]
            best = D[i - 1, j - 1] + (g if g > 0.0 else 0.0)
            if D[i, j - 1] > best:
                best = D[i, j - 1]
            if D[i - 1, j] > best:
                best = D[i - 1, j]
            D[i, j] = best
    return D
