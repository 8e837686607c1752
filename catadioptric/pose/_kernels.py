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
* :func:`first_order_residuals` and :func:`first_order_jacobians`, of the two-view refinement's
  first-order residuals (:mod:`catadioptric.pose.two_view_rays`): each pixel's ray against its
  line, one pixel at a time, and their derivatives by its 10 unknowns.
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

__all__ = ["reduced_normal_equations", "pixel_jacobians", "first_order_residuals", "first_order_jacobians",
           "alignment_table", "neighbour_costs"]


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


@njit(cache=True, nogil=True, error_model="numpy")
def _line_in_view(n, owner, fam, in_b, k, rho, u, dirs, R, that, centres, Q, sv):
    """Pixel ``n``'s line in its own view's frame: its point at depth 0 ``Q`` and direction ``sv``
    (``dirs (F, 3)``: the families' directions in A; ``centres (2, 3)``: ``c_A``, ``c_B``)."""
    ln = owner[n]
    f = fam[ln]
    r = rho[ln]
    if in_b[n]:
        for i in range(3):
            Q[i] = k * ((R[i, 0] * u[ln, 0] + R[i, 1] * u[ln, 1] + R[i, 2] * u[ln, 2]) / r + that[i]) + centres[1, i]
            sv[i] = R[i, 0] * dirs[f, 0] + R[i, 1] * dirs[f, 1] + R[i, 2] * dirs[f, 2]
    else:
        for i in range(3):
            Q[i] = centres[0, i] + k * u[ln, i] / r
            sv[i] = dirs[f, i]


@njit(cache=True, nogil=True, error_model="numpy")
def _ray_line(rays, n, Q, sv, nv, M, g, out):
    """Pixel ``n``'s ray (``rays[n]``, as :func:`first_order_residuals`') against the line
    ``Q + m sv``: fills their common normal ``nv (3,)``, ``M = Jo + lam Jd (3, 2)``,
    ``g = -M' nv (2,)`` and ``out = (delta, |g|, lam, m, b, 1 - b^2, |d x sv|)``: the signed
    distance along the normal, its derivative's norm by the pixel, the depths along the ray and
    along the line of their nearest points, the cosine between the two and what follows from it."""
    w0 = Q[0] - rays[n, 0, 0]
    w1 = Q[1] - rays[n, 1, 0]
    w2 = Q[2] - rays[n, 2, 0]
    d0, d1, d2 = rays[n, 0, 1], rays[n, 1, 1], rays[n, 2, 1]
    b = sv[0] * d0 + sv[1] * d1 + sv[2] * d2
    ws = sv[0] * w0 + sv[1] * w1 + sv[2] * w2
    wd = d0 * w0 + d1 * w1 + d2 * w2
    den = 1.0 - b * b
    lam = (wd - b * ws) / den
    m0 = d1 * sv[2] - d2 * sv[1]
    m1 = d2 * sv[0] - d0 * sv[2]
    m2 = d0 * sv[1] - d1 * sv[0]
    mm = math.sqrt(m0 * m0 + m1 * m1 + m2 * m2)
    nv[0], nv[1], nv[2] = m0 / mm, m1 / mm, m2 / mm
    for kk in range(3):
        for i in range(2):
            M[kk, i] = rays[n, kk, 2 + i] + lam * rays[n, kk, 4 + i]
    gg = 0.0
    for i in range(2):
        g[i] = -(M[0, i] * nv[0] + M[1, i] * nv[1] + M[2, i] * nv[2])
        gg += g[i] * g[i]
    out[0] = nv[0] * w0 + nv[1] * w1 + nv[2] * w2
    out[1] = math.sqrt(gg)
    out[2] = lam
    out[3] = (b * wd - ws) / den
    out[4] = b
    out[5] = den
    out[6] = mm


@njit(cache=True, nogil=True, error_model="numpy")
def first_order_residuals(rays, owner, fam, in_b, k, rho, u, dirs, R, that, centres, e):
    """``e (N, 2)`` filled in place: each pixel's first-order image distance to its line
    (:mod:`catadioptric.pose.two_view_rays`), signed, in ``e[:, 0]`` (``e[:, 1]`` zero; NaN where
    its ray is not finite, parallel to the line or meets it behind its origin). ``rays (N, 3, 6)``:
    each pixel's ray in its own view's frame, columns ``o``, ``d`` and their derivatives by the
    pixel ``Jo (3, 2)``, ``Jd (3, 2)``; the rest as :func:`pixel_jacobians`'s, ``u (L, 3)`` each
    line's foot direction, ``dirs (F, 3)`` the families' directions in A, ``centres (2, 3)``
    the views' centres ``c_A``, ``c_B``."""
    N = rays.shape[0]
    Q = np.empty(3)
    sv = np.empty(3)
    nv = np.empty(3)
    M = np.empty((3, 2))
    g = np.empty(2)
    out = np.empty(7)
    for n in range(N):
        _line_in_view(n, owner, fam, in_b, k, rho, u, dirs, R, that, centres, Q, sv)
        _ray_line(rays, n, Q, sv, nv, M, g, out)
        delta, gn, lam = out[0], out[1], out[2]
        if math.isfinite(delta) and math.isfinite(gn) and gn > 0.0 and lam > 0.0:
            e[n, 0] = delta / gn
            e[n, 1] = 0.0
        else:
            e[n, 0] = np.nan
            e[n, 1] = np.nan


@njit(cache=True, nogil=True, error_model="numpy")
def first_order_jacobians(rays, owner, fam, in_b, k, rho, u, du, fam_dirs, R, tframe, centres, A):
    """``A (N, 2, 10)`` filled in place: the derivative of each pixel's first-order image distance
    (:func:`first_order_residuals`) by its 10 unknowns, at the line's point nearest its ray, the columns
    of :func:`pixel_jacobians` (row 1 zero; zero rows where the distance is not finite). The
    distance is ``delta / |g|``: ``delta`` the signed distance between the pixel's ray and its
    line along their common normal ``n``, ``g = -(Jo + lam Jd)' n`` its derivative by the pixel
    (``lam``: the depth along the ray of its point nearest the line); both are differentiated,
    ``lam`` and ``n`` moving with the line. ``rays`` as :func:`first_order_residuals`';
    ``du (L, 3)``: each line's foot's derivative by its angle; ``fam_dirs (F, 3, 3)`` as
    :func:`pixel_jacobians`'s; ``tframe (3, 3)``: its rows ``that`` and ``dthat``."""
    d, Jd = rays[:, :, 1], rays[:, :, 4:6]
    that, dthat = tframe[0], tframe[1:]
    N = rays.shape[0]
    Q = np.empty(3)
    sv = np.empty(3)
    dX = np.empty((10, 3))
    dS = np.empty((10, 3))
    V = np.empty(3)
    RV = np.empty(3)
    M = np.empty((3, 2))
    g = np.empty(2)
    nv = np.empty(3)
    out = np.empty(7)
    dirs = fam_dirs[:, 0, :]
    for n in range(N):
        for i in range(2):
            for j in range(10):
                A[n, i, j] = 0.0
        _line_in_view(n, owner, fam, in_b, k, rho, u, dirs, R, that, centres, Q, sv)
        ln = owner[n]
        f = fam[ln]
        r = rho[ln]
        _ray_line(rays, n, Q, sv, nv, M, g, out)
        delta, gn, lam, b, den, mm = out[0], out[1], out[2], out[4], out[5], out[6]
        if not (math.isfinite(delta) and math.isfinite(gn) and gn > 0.0 and lam > 0.0):
            continue
        mu = out[3] * r / k  # that point's depth (the unknowns' mu)
        # the line's point at the pixel's depth (over k, from c_A) and each column's moves of the
        # point dX and of the direction dS, in A's frame first
        for i in range(3):
            V[i] = (u[ln, i] + mu * fam_dirs[f, 0, i]) / r
        for c in range(10):
            for i in range(3):
                dX[c, i] = 0.0
                dS[c, i] = 0.0
        km = k * mu / r
        for i in range(3):
            dX[5, i] = k * V[i]
            dX[6, i] = km * fam_dirs[f, 1, i]
            dX[7, i] = km * fam_dirs[f, 2, i]
            dS[6, i] = fam_dirs[f, 1, i]
            dS[7, i] = fam_dirs[f, 2, i]
            dX[8, i] = k * du[ln, i] / r
            dX[9, i] = -k * V[i] / r
        if in_b[n]:
            for c in range(5, 10):
                x0, x1, x2 = dX[c, 0], dX[c, 1], dX[c, 2]
                s0, s1, s2 = dS[c, 0], dS[c, 1], dS[c, 2]
                for i in range(3):
                    dX[c, i] = R[i, 0] * x0 + R[i, 1] * x1 + R[i, 2] * x2
                    dS[c, i] = R[i, 0] * s0 + R[i, 1] * s1 + R[i, 2] * s2
            for i in range(3):
                dX[5, i] += k * that[i]
                RV[i] = k * (R[i, 0] * V[0] + R[i, 1] * V[1] + R[i, 2] * V[2])
            # a left rotation by e_c: the point and the direction turn about e_c
            dX[0, 0], dX[0, 1], dX[0, 2] = 0.0, -RV[2], RV[1]
            dX[1, 0], dX[1, 1], dX[1, 2] = RV[2], 0.0, -RV[0]
            dX[2, 0], dX[2, 1], dX[2, 2] = -RV[1], RV[0], 0.0
            dS[0, 0], dS[0, 1], dS[0, 2] = 0.0, -sv[2], sv[1]
            dS[1, 0], dS[1, 1], dS[1, 2] = sv[2], 0.0, -sv[0]
            dS[2, 0], dS[2, 1], dS[2, 2] = -sv[1], sv[0], 0.0
            for i in range(3):
                dX[3, i] = k * dthat[0, i]
                dX[4, i] = k * dthat[1, i]
        jn0 = Jd[n, 0, 0] * nv[0] + Jd[n, 1, 0] * nv[1] + Jd[n, 2, 0] * nv[2]
        jn1 = Jd[n, 0, 1] * nv[0] + Jd[n, 1, 1] * nv[1] + Jd[n, 2, 1] * nv[2]
        ok = True
        for c in range(10):
            ddelta = nv[0] * dX[c, 0] + nv[1] * dX[c, 1] + nv[2] * dX[c, 2]
            nds = nv[0] * dS[c, 0] + nv[1] * dS[c, 1] + nv[2] * dS[c, 2]
            dlam = ((d[n, 0] - b * sv[0]) * dX[c, 0] + (d[n, 1] - b * sv[1]) * dX[c, 1]
                    + (d[n, 2] - b * sv[2]) * dX[c, 2] - b * delta * nds) / den
            # the common normal's move: (I - n n') (d x dS) / |d x s|
            c0 = d[n, 1] * dS[c, 2] - d[n, 2] * dS[c, 1]
            c1 = d[n, 2] * dS[c, 0] - d[n, 0] * dS[c, 2]
            c2 = d[n, 0] * dS[c, 1] - d[n, 1] * dS[c, 0]
            ncr = nv[0] * c0 + nv[1] * c1 + nv[2] * c2
            dn0 = (c0 - ncr * nv[0]) / mm
            dn1 = (c1 - ncr * nv[1]) / mm
            dn2 = (c2 - ncr * nv[2]) / mm
            dg0 = -jn0 * dlam - (M[0, 0] * dn0 + M[1, 0] * dn1 + M[2, 0] * dn2)
            dg1 = -jn1 * dlam - (M[0, 1] * dn0 + M[1, 1] * dn1 + M[2, 1] * dn2)
            dgn = (g[0] * dg0 + g[1] * dg1) / gn
            a = ddelta / gn - delta * dgn / (gn * gn)
            if not math.isfinite(a):
                ok = False
            A[n, 0, c] = a
        if not ok:
            for c in range(10):
                A[n, 0, c] = 0.0
