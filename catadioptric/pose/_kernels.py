"""The compiled inner loops of the pose (numba), float64, no fast-math, compiled once per machine
and cached, like :mod:`catadioptric.solvers._kernels`:

* :func:`reduced_normal_equations`, of the two-view refinement: the normal equations with every
  pixel's depth eliminated (:func:`catadioptric.pose.bundle._normal_equations` documents them).
  One pass over the pixels; each pixel touches 10 unknowns (its columns ``cols``) and its own
  depth, so its 10 x 10 block of the reduced system is formed and added where it belongs, in
  pixel order (the order in which ``numpy.bincount`` would add the same terms).
* :func:`pixel_jacobians`, of the two-view refinement: each pixel's residual differentiated by its
  10 unknowns and its depth (:meth:`catadioptric.pose.two_view_problem.Problem.jacobian`
  documents them), from its image's derivative by its point and the per-family and per-line
  derivatives of the point.
* :func:`alignment_table`, of the lines matched in their order
  (:class:`catadioptric.pose.matching.LinesInOrder`): the dynamic programme of a monotone alignment.
* :func:`neighbour_costs`, of the RANSAC by neighbours (:func:`catadioptric.pose.matching.match_lines`):
  each displacement's truncated cost over the meeting rays of A, each at its best candidate in B,
  without the hypotheses-by-candidates arrays.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["reduced_normal_equations", "pixel_jacobians", "alignment_table", "neighbour_costs"]


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
def pixel_jacobians(G, V, mu, owner, fam, in_b, k, rho, du, fam_dirs, R, dthat, that, A, b):
    """``A (N, 2, 10)`` and ``b (N, 2)`` of :meth:`catadioptric.pose.two_view_problem.Problem.jacobian`,
    filled in place: ``G (N, 2, 3)`` each pixel's image derivative by its point (in its own view's
    frame; NaN: no image), ``V (N, 3)`` its point from ``c_A`` over the scale ``k``, ``mu (N,)`` its
    depth, ``owner (N,)`` its line, ``fam (L,)`` each line's family, ``in_b (N,)`` whether it is B's;
    ``rho (L,)``, ``du (L, 3)`` each line's inverse distance and its foot's derivative by its angle;
    ``fam_dirs (F, 3, 3)`` each family's direction and its derivatives by its two chart
    coordinates (rows ``s``, ``ds/da``, ``ds/db``); ``R``, ``that``
    and ``dthat (2, 3)`` the rotation, the baseline's direction and its derivatives. A row with
    anything not finite is zero (a pixel whose point has no image)."""
    N = G.shape[0]
    dP = np.empty((3, 6))
    GB = np.empty((2, 3))
    RV = np.empty(3)
    J6 = np.empty((2, 6))
    for n in range(N):
        ln = owner[n]
        f = fam[ln]
        rj = rho[ln]
        km = k * mu[n] / rj
        for i in range(3):
            dP[i, 0] = k * V[n, i]
            dP[i, 1] = km * fam_dirs[f, 1, i]
            dP[i, 2] = km * fam_dirs[f, 2, i]
            dP[i, 3] = k * du[ln, i] / rj
            dP[i, 4] = -k * V[n, i] / rj
            dP[i, 5] = k * fam_dirs[f, 0, i] / rj
        for i in range(2):
            for j in range(3):
                if in_b[n]:
                    GB[i, j] = G[n, i, 0] * R[0, j] + G[n, i, 1] * R[1, j] + G[n, i, 2] * R[2, j]
                else:
                    GB[i, j] = G[n, i, j]
        for i in range(2):
            for j in range(6):
                J6[i, j] = GB[i, 0] * dP[0, j] + GB[i, 1] * dP[1, j] + GB[i, 2] * dP[2, j]
        for i in range(2):
            for j in range(5):
                A[n, i, j] = 0.0
            A[n, i, 5] = J6[i, 0]
            for j in range(4):
                A[n, i, 6 + j] = J6[i, 1 + j]
            b[n, i] = J6[i, 5]
        if in_b[n]:
            for i in range(3):
                RV[i] = R[i, 0] * V[n, 0] + R[i, 1] * V[n, 1] + R[i, 2] * V[n, 2]
            for i in range(2):
                g0, g1, g2 = G[n, i, 0], G[n, i, 1], G[n, i, 2]
                # G (-[RV]_x): the rotation's columns
                A[n, i, 0] = k * (g2 * RV[1] - g1 * RV[2])
                A[n, i, 1] = k * (g0 * RV[2] - g2 * RV[0])
                A[n, i, 2] = k * (g1 * RV[0] - g0 * RV[1])
                A[n, i, 3] = k * (g0 * dthat[0, 0] + g1 * dthat[0, 1] + g2 * dthat[0, 2])
                A[n, i, 4] = k * (g0 * dthat[1, 0] + g1 * dthat[1, 1] + g2 * dthat[1, 2])
                A[n, i, 5] += k * (g0 * that[0] + g1 * that[1] + g2 * that[2])
        ok = True
        for i in range(2):
            if not (math.isfinite(b[n, i])):
                ok = False
            for j in range(10):
                if not math.isfinite(A[n, i, j]):
                    ok = False
        if not ok:
            for i in range(2):
                b[n, i] = 0.0
                for j in range(10):
                    A[n, i, j] = 0.0


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


@njit(cache=True, nogil=True, error_model="numpy")
def neighbour_costs(T, A, p, q, starts, n_rays, var, c2, cos_parallax):
    """``cost (H,)`` of unit displacements ``T (H, 3)``: over ``n_rays`` meeting rays of A, each ray's
    smallest truncated term among its candidate pairs, ``c2`` for a ray without one.

    The candidate pairs (``A (K, 3)``: unit normals of their epipolar planes; ``p, q (K, 3)``: the
    rays of A, rotated into B, and of B) come grouped by their ray of A, group ``g`` the rows
    ``starts[g]:starts[g + 1]`` (``starts (G + 1,)``). A pair's term is its squared epipolar residual
    over ``var`` where that is at most ``c2`` and the rays meet in front of both centres (the
    depths' numerators both positive, or the rays within the parallax whose cosine is
    ``cos_parallax``), else ``c2``: the terms of
    :func:`catadioptric.pose.central.truncated_residuals2` with ``min_parallax``."""
    H = T.shape[0]
    G = starts.shape[0] - 1
    K = A.shape[0]
    pq = np.empty(K)
    for k in range(K):
        pq[k] = p[k, 0] * q[k, 0] + p[k, 1] * q[k, 1] + p[k, 2] * q[k, 2]
    out = np.empty(H)
    rest = c2 * (n_rays - G)
    for h in range(H):
        t0, t1, t2 = T[h, 0], T[h, 1], T[h, 2]
        total = 0.0
        for g in range(G):
            best = c2
            for k in range(starts[g], starts[g + 1]):
                r = t0 * A[k, 0] + t1 * A[k, 1] + t2 * A[k, 2]
                r2 = r * r / var
                if r2 < best:
                    pt = t0 * p[k, 0] + t1 * p[k, 1] + t2 * p[k, 2]
                    qt = t0 * q[k, 0] + t1 * q[k, 1] + t2 * q[k, 2]
                    if (pq[k] * qt - pt > 0.0 and qt - pq[k] * pt > 0.0) or pq[k] > cos_parallax:
                        best = r2
            total += best
        out[h] = total + rest
    return out
