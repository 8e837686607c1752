"""The compiled inner loops of the reflection solvers (numba), one target or candidate at a time.

Each kernel is the loop form of the routine that calls it and documents it: the same
formulas, float64 throughout, no fast-math (no contraction of products and sums, no
reassociation), every row computed alone, so that a row's answer does not depend on the
batch it is in. Sums run in a fixed order of their terms (numpy's reductions may pair them
otherwise: against the former numpy form the answers agree to rounding, mirror points within
4e-16 of the mirror's scale, with the same flags). Compiled once per machine and cached
(numba falls back to a cache in the user's directory when the package's own is read-only).

* :func:`roots_rows`: real roots in [-1, 1] (:func:`catadioptric.solvers.polynomial.roots_in_unit_interval`);
* :func:`polish_accept`: Newton on Fermat's principle and the acceptance test
  (``ReflectionSolver._finish``);
* :func:`monomial_map`: polynomial coefficients of targets by a fitted homogeneous map
  (:func:`catadioptric.solvers.reflection.map_coefficients`);
* :func:`general_back_substitution`: the general solver's candidates from the octic's roots
  (``GeneralSolver._candidates``).

The batches' bookkeeping (selections, sorting, visibility) is in :mod:`catadioptric.solvers._batch_kernels`.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["roots_rows", "polish_accept", "monomial_map", "general_back_substitution"]

_JIT = {"cache": True, "nogil": True, "error_model": "numpy"}
_BLOCK = 64  # rows per block of the loops that run along rows
_STACK = 64  # intervals pending per row: subdivision is depth first, at most ~2 per level (21 levels)


# -- real roots in [-1, 1]

@njit(**_JIT)
def _horner(p, n1, t):
    f = p[n1 - 1]
    for k in range(n1 - 2, -1, -1):
        f = f * t + p[k]
    return f


@njit(**_JIT)
def _refine_brackets(cf, a, c, nb, iters, tol, out, t, f, df, aw, cw, sa, at):
    """Safeguarded Newton on the brackets ``[a[j], c[j]]`` (one sign change, or ``a == c``) of the
    polynomials ``cf[:, j]`` (ascending powers down the first axis), ``j < nb``: the secant point
    of the bracket first, bisection when a step leaves the bracket, stop at steps below ``tol``;
    answers in ``out[:nb]``. Every bracket runs its own iteration, alone (the same answers in any
    batch); the loops run across the brackets still iterating, kept contiguous at the front
    (``cf`` is reordered), so that the evaluations of different brackets (independent chains of
    products and sums) overlap instead of each waiting on its own last step (docs/solvers.md,
    "Measured"). ``t ... at``: work arrays."""
    n1 = cf.shape[0]
    for j in range(nb):  # the values at both ends (Horner)
        f[j] = cf[n1 - 1, j]
        df[j] = f[j]
    for k in range(n1 - 2, -1, -1):
        for j in range(nb):
            f[j] = f[j] * a[j] + cf[k, j]
            df[j] = df[j] * c[j] + cf[k, j]
    na = 0
    for j in range(nb):
        fa, fc, aj, cj = f[j], df[j], a[j], c[j]
        tj = aj - fa * (cj - aj) / (fc - fa)
        if not (math.isfinite(tj) and tj >= aj and tj <= cj):
            tj = 0.5 * (aj + cj)
        out[j] = tj
        if aj < cj:  # iterates: moved to the front
            t[na] = tj
            sa[na] = np.sign(fa)
            aw[na] = aj
            cw[na] = cj
            at[na] = j
            if na != j:
                for k in range(n1):
                    cf[k, na] = cf[k, j]
            na += 1
    for _ in range(iters):
        if na == 0:
            break
        for j in range(na):
            f[j] = cf[n1 - 1, j]
            df[j] = 0.0
        for k in range(n1 - 2, -1, -1):
            for j in range(na):
                df[j] = df[j] * t[j] + f[j]
                f[j] = f[j] * t[j] + cf[k, j]
        w = 0
        for j in range(na):
            fj, tj = f[j], t[j]
            if np.sign(fj) == sa[j]:
                aw[j] = tj
            else:
                cw[j] = tj
            tn = tj - fj / df[j]
            bad = not math.isfinite(tn) or tn <= min(aw[j], cw[j]) or tn >= max(aw[j], cw[j])
            if bad:
                tn = 0.5 * (aw[j] + cw[j])
            done = fj == 0.0 or abs(cw[j] - aw[j]) <= tol or (not bad and abs(tn - tj) <= tol)
            if fj != 0.0:
                tj = tn
            out[at[j]] = tj
            if not done:
                t[w] = tj
                sa[w] = sa[j]
                aw[w] = aw[j]
                cw[w] = cw[j]
                at[w] = at[j]
                if w != j:
                    for k in range(n1):
                        cf[k, w] = cf[k, j]
                w += 1
        na = w


@njit(**_JIT)
def _cluster(p, n1, a, w, out_t, m):
    """Candidates of a root cluster in [a, a + w]: the extremum (when p is at rounding level
    there) and the real roots of the local quadratic model; appended to ``out_t`` from ``m``."""
    t = a + 0.5 * w
    for _ in range(8):
        d1 = p[n1 - 1] * (n1 - 1)
        for k in range(n1 - 2, 0, -1):
            d1 = d1 * t + p[k] * k
        d2 = p[n1 - 1] * ((n1 - 1) * (n1 - 2))
        for k in range(n1 - 2, 1, -1):
            d2 = d2 * t + p[k] * (k * (k - 1))
        step = d1 / d2
        tn = t - (step if math.isfinite(step) else 0.0)
        t = min(max(tn, a - w), a + 2 * w)
    f = _horner(p, n1, t)
    f2 = p[n1 - 1] * ((n1 - 1) * (n1 - 2))
    for k in range(n1 - 2, 1, -1):
        f2 = f2 * t + p[k] * (k * (k - 1))
    if abs(f) <= 1e-9:
        out_t[m] = t
        m += 1
    x = -2.0 * f / f2
    if x != x:
        return m
    delta = math.sqrt(max(x, 0.0))
    if math.isfinite(delta) and delta > 0 and delta <= 2 * w:
        out_t[m] = t - delta
        out_t[m + 1] = t + delta
        m += 2
    return m


@njit(**_JIT)
def roots_rows(p, T, cluster_width, newton_iters, out_i, out_t):
    """Real roots in [-1, 1] of each row of ``p (M, n+1)`` (ascending powers), as flat
    ``(out_i, out_t)[:m]`` (row, root) grouped by row; returns m. Bernstein coefficients on [0, 1] (``T``), Descartes' rule of signs,
    de Casteljau halving depth first; brackets refined by :func:`_refine_brackets`, a block of
    ``_BLOCK`` rows at once, intervals narrower than
    ``cluster_width`` with two sign changes or more by :func:`_cluster`."""
    M, n1 = p.shape
    n = n1 - 1
    stack = np.empty((_STACK, n1))
    s_lo = np.empty(_STACK)
    s_w = np.empty(_STACK)
    cur = np.empty(n1)
    # the block's normalised rows, and its brackets: their polynomials (columns), ends and slots in out_t
    pb = np.empty((_BLOCK, n1))
    cap = _BLOCK * (3 * n + 4)  # the bound of roots_in_unit_interval's output per row
    b_cf = np.empty((n1, cap))
    b_a = np.empty(cap)
    b_c = np.empty(cap)
    b_slot = np.empty(cap, dtype=np.intp)
    w_t = np.empty(cap)
    w_f = np.empty(cap)
    w_df = np.empty(cap)
    w_aw = np.empty(cap)
    w_cw = np.empty(cap)
    w_sa = np.empty(cap)
    w_at = np.empty(cap, dtype=np.intp)
    w_out = np.empty(cap)
    m = 0
    for s in range(0, M, _BLOCK):
        nbk = 0
        for r in range(min(_BLOCK, M - s)):
            i = s + r
            m0 = m
            scale = 0.0
            for k in range(n1):
                scale = max(scale, abs(p[i, k]))
            if not scale > 0:
                continue
            for k in range(n1):
                pb[r, k] = p[i, k] / scale
            for j in range(n1):  # Bernstein coefficients: independent sums, each in the order of the powers
                stack[0, j] = 0.0
            for k in range(n1):
                for j in range(n1):
                    stack[0, j] += pb[r, k] * T[k, j]
            if stack[0, 0] == 0.0:
                out_t[m] = -1.0
                m += 1
            if stack[0, n] == 0.0:
                out_t[m] = 1.0
                m += 1
            s_lo[0] = 0.0
            s_w[0] = 1.0
            top = 1
            while top > 0:
                top -= 1
                lo = s_lo[top]
                width = s_w[top]
                v = 0
                for k in range(n):
                    if (stack[top, k] >= 0.0) != (stack[top, k + 1] >= 0.0):
                        v += 1
                if v == 1:  # a bracket: refined with the block's others below
                    for k in range(n1):
                        b_cf[k, nbk] = pb[r, k]
                    b_a[nbk] = lo * 2.0 - 1.0
                    b_c[nbk] = (lo + width) * 2.0 - 1.0
                    b_slot[nbk] = m
                    nbk += 1
                    m += 1
                    continue
                if v < 2:
                    continue
                if width <= cluster_width:
                    m = _cluster(pb[r], n1, lo * 2.0 - 1.0, width * 2.0, out_t, m)
                    continue
                # halves: the right one goes to slot top + 1, the left one overwrites slot top
                for k in range(n1):
                    cur[k] = stack[top, k]
                right = top + 1
                stack[right, n] = cur[n]
                for k in range(1, n1):
                    for j in range(n1 - k):
                        cur[j] = 0.5 * (cur[j] + cur[j + 1])
                    stack[top, k] = cur[0]
                    stack[right, n - k] = cur[n - k]
                half = 0.5 * width
                if stack[top, n] == 0.0:  # a zero exactly at the split point is a root of its own
                    for k in range(n1):
                        b_cf[k, nbk] = pb[r, k]
                    b_a[nbk] = (lo + half) * 2.0 - 1.0
                    b_c[nbk] = b_a[nbk]
                    b_slot[nbk] = m
                    nbk += 1
                    m += 1
                s_lo[right] = lo + half
                s_w[right] = half
                s_w[top] = half
                top += 2
            for k in range(m0, m):
                out_i[k] = i
        _refine_brackets(b_cf, b_a, b_c, nbk, newton_iters, 1e-11, w_out, w_t, w_f, w_df, w_aw, w_cw, w_sa, w_at)
        for j in range(nbk):
            out_t[b_slot[j]] = w_out[j]
    return m


# -- Newton on Fermat's principle and the acceptance test

@njit(**_JIT)
def _solve4(a, b, out):
    """``a x = -b`` by elimination with partial pivoting (a and b overwritten); x = 0 when
    |det a| <= 1e-300."""
    det = 1.0
    for k in range(4):
        p = k
        for i in range(k + 1, 4):
            if abs(a[i, k]) > abs(a[p, k]):
                p = i
        if p != k:
            det = -det
            for j in range(4):
                a[k, j], a[p, j] = a[p, j], a[k, j]
            b[k], b[p] = b[p], b[k]
        det *= a[k, k]
        if a[k, k] == 0.0:
            break
        for i in range(k + 1, 4):
            f = a[i, k] / a[k, k]
            for j in range(k, 4):
                a[i, j] -= f * a[k, j]
            b[i] -= f * b[k]
    if not abs(det) > 1e-300:
        for i in range(4):
            out[i] = 0.0
        return
    for i in range(3, -1, -1):
        s = b[i]
        for j in range(i + 1, 4):
            s -= a[i, j] * out[j]
        out[i] = -s / a[i, i]


@njit(**_JIT)
def _polish(r, h, sg, A, B, C, c, iters):
    """Newton on ``grad(|r - c| + sg phi(r)) + mu grad(Omega) = 0``, ``Omega(r) = 0``, ``r`` in place
    (``ReflectionSolver._finish``, one candidate): the Schur complement of the bordered Hessian
    ``[[M, g], [g^T, 0]]``, ``M = Hess f + mu Hess Omega``, by M's adjugate; the bordered system
    directly where M is nearly singular. Scalars throughout (the 3x3 algebra written out)."""
    r0, r1, r2 = r[0], r[1], r[2]
    h0, h1, h2, h3 = h[0], h[1], h[2], h[3]
    mu = 0.0
    for it in range(iters):
        rc0, rc1, rc2 = r0 - c[0], r1 - c[1], r2 - c[2]
        lc = math.sqrt(rc0 * rc0 + rc1 * rc1 + rc2 * rc2)
        u0, u1, u2 = rc0 / lc, rc1 / lc, rc2 / lc
        tw0, tw1, tw2 = h0 - h3 * r0, h1 - h3 * r1, h2 - h3 * r2
        tn = math.sqrt(tw0 * tw0 + tw1 * tw1 + tw2 * tw2)
        if not tn > 0:
            tn = 1.0
        v0, v1, v2 = -tw0 / tn, -tw1 / tn, -tw2 / tn
        inv_lp = h3 / tn
        gr0, gr1, gr2 = u0 + sg * v0, u1 + sg * v1, u2 + sg * v2
        g0, g1, g2 = 2 * r0, 2 * r1, 2 * A * r2 + B
        Om = r0 ** 2 + r1 ** 2 + A * r2 ** 2 + B * r2 - C
        if it == 0:
            mu = -(gr0 * g0 + gr1 * g1 + gr2 * g2) / (g0 * g0 + g1 * g1 + g2 * g2)
        w = inv_lp * sg
        # M = (I - u u^T) / lc + (I - v v^T) w + mu diag(2, 2, 2A)
        m00 = (1.0 - u0 * u0) / lc + (1.0 - v0 * v0) * w + mu * 2.0
        m01 = (0.0 - u0 * u1) / lc + (0.0 - v0 * v1) * w + mu * 0.0
        m02 = (0.0 - u0 * u2) / lc + (0.0 - v0 * v2) * w + mu * 0.0
        m10 = (0.0 - u1 * u0) / lc + (0.0 - v1 * v0) * w + mu * 0.0
        m11 = (1.0 - u1 * u1) / lc + (1.0 - v1 * v1) * w + mu * 2.0
        m12 = (0.0 - u1 * u2) / lc + (0.0 - v1 * v2) * w + mu * 0.0
        m20 = (0.0 - u2 * u0) / lc + (0.0 - v2 * v0) * w + mu * 0.0
        m21 = (0.0 - u2 * u1) / lc + (0.0 - v2 * v1) * w + mu * 0.0
        m22 = (1.0 - u2 * u2) / lc + (1.0 - v2 * v2) * w + mu * (2.0 * A)
        f0, f1, f2 = gr0 + mu * g0, gr1 + mu * g1, gr2 + mu * g2
        a00, a01, a02 = m11 * m22 - m12 * m21, m02 * m21 - m01 * m22, m01 * m12 - m02 * m11
        a10, a11, a12 = m12 * m20 - m10 * m22, m00 * m22 - m02 * m20, m02 * m10 - m00 * m12
        a20, a21, a22 = m10 * m21 - m11 * m20, m01 * m20 - m00 * m21, m00 * m11 - m01 * m10
        detM = m00 * a00 + m01 * a10 + m02 * a20
        big = max(abs(a00), abs(a01), abs(a02), abs(a10), abs(a11), abs(a12), abs(a20), abs(a21), abs(a22))
        ag0 = a00 * g0 + a01 * g1 + a02 * g2
        ag1 = a10 * g0 + a11 * g1 + a12 * g2
        ag2 = a20 * g0 + a21 * g1 + a22 * g2
        den = g0 * ag0 + g1 * ag1 + g2 * ag2
        dmu = (Om * detM - (ag0 * f0 + ag1 * f1 + ag2 * f2)) / den
        e0, e1, e2 = f0 + g0 * dmu, f1 + g1 * dmu, f2 + g2 * dmu
        d0 = -(a00 * e0 + a01 * e1 + a02 * e2) / detM
        d1 = -(a10 * e0 + a11 * e1 + a12 * e2) / detM
        d2 = -(a20 * e0 + a21 * e1 + a22 * e2) / detM
        d3 = dmu
        finite = math.isfinite(d0) and math.isfinite(d1) and math.isfinite(d2) and math.isfinite(d3)
        if not finite or abs(detM) <= 1e-12 * big:  # M (nearly) singular: the bordered system directly
            J = np.array([[m00, m01, m02, g0], [m10, m11, m12, g1], [m20, m21, m22, g2], [g0, g1, g2, 0.0]])
            sol = np.empty(4)
            _solve4(J, np.array([f0, f1, f2, Om]), sol)
            d0, d1, d2, d3 = sol[0], sol[1], sol[2], sol[3]
        if not (math.isfinite(d0) and math.isfinite(d1) and math.isfinite(d2) and math.isfinite(d3)):
            d0, d1, d2, d3 = 0.0, 0.0, 0.0, 0.0
        r0, r1, r2 = r0 + d0, r1 + d1, r2 + d2
        mu += d3
        # quadratic convergence: after a step below 1e-8 the error is at rounding level
        if not max(abs(d0), abs(d1), abs(d2)) > 1e-8:
            break
    r[0], r[1], r[2] = r0, r1, r2


@njit(**_JIT)
def polish_accept(h, owner, r0, A, B, C, c, zlo, zhi, backward, iters, accept, out_owner, out_r, out_fwd):
    """Per candidate ``r0[i]`` of target ``h[owner[i]]`` (solver frame): the side of the reflected
    ray (``sigma``), Newton's polish, and the acceptance test (``ReflectionSolver._finish``); the
    accepted ones, in their order, to ``out_owner``, ``out_r``, ``out_fwd``; returns their number."""
    r = np.empty(3)
    m = 0
    for i in range(len(owner)):
        hi = h[owner[i]]
        r[0], r[1], r[2] = r0[i, 0], r0[i, 1], r0[i, 2]
        # sigma: the reflected ray of the candidate toward (+1) or away from (-1) the target
        n0, n1, n2 = r[0], r[1], A * r[2] + 0.5 * B
        i0, i1, i2 = r[0] - c[0], r[1] - c[1], r[2] - c[2]
        k = 2.0 * ((i0 * n0 + i1 * n1 + i2 * n2) / (n0 * n0 + n1 * n1 + n2 * n2))
        d0, d1, d2 = i0 - n0 * k, i1 - n1 * k, i2 - n2 * k
        tg = (d0 * (hi[0] - hi[3] * r[0]) + d1 * (hi[1] - hi[3] * r[1])) + d2 * (hi[2] - hi[3] * r[2])
        sg = 1.0 if tg >= 0 else -1.0
        if not backward and sg < 0:
            continue
        _polish(r, hi, sg, A, B, C, c, iters)
        n0, n1, n2 = r[0], r[1], A * r[2] + 0.5 * B
        i0, i1, i2 = r[0] - c[0], r[1] - c[1], r[2] - c[2]
        nn = n0 * n0 + n1 * n1 + n2 * n2
        k = 2.0 * ((i0 * n0 + i1 * n1 + i2 * n2) / nn)
        d0, d1, d2 = i0 - n0 * k, i1 - n1 * k, i2 - n2 * k
        dn = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        d0, d1, d2 = d0 / dn, d1 / dn, d2 / dn
        t0, t1, t2 = hi[0] - hi[3] * r[0], hi[1] - hi[3] * r[1], hi[2] - hi[3] * r[2]
        tn = math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
        q = tn if tn > 0 else 1.0
        t0, t1, t2 = t0 / q, t1 / q, t2 / q
        x0, x1, x2 = d1 * t2 - d2 * t1, d2 * t0 - d0 * t2, d0 * t1 - d1 * t0
        sine = math.sqrt(x0 * x0 + x1 * x1 + x2 * x2)
        fwd = (d0 * t0 + d1 * t1) + d2 * t2 > 0
        om = r[0] ** 2 + r[1] ** 2 + A * r[2] ** 2 + B * r[2] - C
        if (math.isfinite(sine) and sine <= accept and abs(om) <= 1e-10 and fwd == (sg > 0)
                and r[2] >= zlo - 1e-12 and r[2] <= zhi + 1e-12 and math.sqrt(nn) > 1e-9 and tn > 0):
            out_owner[m] = owner[i]
            out_r[m, 0], out_r[m, 1], out_r[m, 2] = r[0], r[1], r[2]
            out_fwd[m] = fwd
            m += 1
    return m


# -- polynomial coefficients of targets by a fitted homogeneous map

@njit(**_JIT)
def monomial_map(h, exps, qmap, degree, qsum, cancelled, Q, weak):
    """``Q[i] = monomials(h[i]) @ qmap`` (``catadioptric.solvers.reflection.map_coefficients``), monomials
    ``prod_k h[i, k]^exps[j, k]`` from powers built by products, each output summed in the order of
    the monomials, and ``weak[i]``: ``max |Q[i]|`` below ``cancelled`` times the bound
    ``max_k |h[i, k]|^degree qsum`` of its terms. Blocks of ``_BLOCK`` rows, so that the innermost
    loops run along rows (the same operations for every row of a block)."""
    N, nv = h.shape
    J, n_out = qmap.shape
    d = 0
    for j in range(J):
        for k in range(nv):
            d = max(d, exps[j, k])
    pw = np.empty((nv, d + 1, _BLOCK))
    mono = np.empty(_BLOCK)
    acc = np.empty((n_out, _BLOCK))
    for s in range(0, N, _BLOCK):
        nb = min(_BLOCK, N - s)
        for k in range(nv):
            for i in range(nb):
                pw[k, 0, i] = 1.0
            for e in range(1, d + 1):
                for i in range(nb):
                    pw[k, e, i] = pw[k, e - 1, i] * h[s + i, k]
        acc[:, :nb] = 0.0
        for j in range(J):
            e0 = exps[j, 0]
            for i in range(nb):
                mono[i] = pw[0, e0, i]  # a power 0 is 1.0, an exact factor
            for k in range(1, nv):
                ek = exps[j, k]
                for i in range(nb):
                    mono[i] *= pw[k, ek, i]
            for o in range(n_out):
                q = qmap[j, o]
                if q == 0.0:  # a structural zero of the map (about 40 % of the general solver's): no term
                    continue
                for i in range(nb):
                    acc[o, i] += mono[i] * q
        for i in range(nb):
            big = 0.0
            for o in range(n_out):
                Q[s + i, o] = acc[o, i]
                big = max(big, abs(acc[o, i]))
            hm = 0.0
            for k in range(nv):
                hm = max(hm, abs(h[s + i, k]))
            weak[s + i] = big < cancelled * (hm ** degree * qsum)


# -- the general solver's back-substitution

@njit(**_JIT)
def _poly(p, t):
    f = p[len(p) - 1]
    for k in range(len(p) - 2, -1, -1):
        f = f * t + p[k]
    return f


@njit(**_JIT)
def _poly_abs(p, t):
    f = abs(p[len(p) - 1])
    for k in range(len(p) - 2, -1, -1):
        f = f * t + abs(p[k])
    return f


@njit(**_JIT)
def general_back_substitution(h, owner, t, gmap, emap, f1, f0, A, B, C, zt, screen, near_zero_x,
                              out_owner, out_r):
    """Candidates ``(x, y, z)`` of the general solver from the octic's roots ``t`` of targets
    ``h[owner]`` (``GeneralSolver._candidates`` documents the rules); returns their number."""
    ys = np.empty(4)
    xs = np.empty(4)
    rel = np.empty(4)
    ok = np.empty(4, dtype=np.bool_)
    G = np.empty(15)
    Ec = np.empty(2)
    m = 0
    for i in range(len(owner)):
        hh = h[owner[i]]
        ti = t[i]
        z = zt[0] + zt[1] * ti
        rho2 = C - A * z * z - B * z
        if i == 0 or owner[i] != owner[i - 1]:  # G's and E's coefficients: once per target (roots come grouped)
            for j in range(15):
                G[j] = ((hh[0] * gmap[0, j] + hh[1] * gmap[1, j]) + hh[2] * gmap[2, j]) + hh[3] * gmap[3, j]
            for j in range(2):
                Ec[j] = ((hh[0] * emap[0, j] + hh[1] * emap[1, j]) + hh[2] * emap[2, j]) + hh[3] * emap[3, j]
        a = _poly(G[0:5], ti)
        b = _poly(G[5:10], ti)
        c = _poly(G[10:15], ti)
        # both real roots of a y^2 + b y + c (NaN when complex; one root when linear)
        disc = b * b - 4 * a * c
        sq = math.sqrt(disc) if disc > 0 else (disc if disc != disc else 0.0)
        if disc < -1e-12 * (b * b + abs(4 * a * c)):
            sq = np.nan
        qq = -0.5 * (b + (sq if b >= 0 else -sq))
        y1 = qq / a
        y2 = c / qq
        if abs(a) <= 1e-14 * (abs(b) + abs(c)):
            y1 = -c / b
            y2 = np.nan
        ys[0], ys[1], ys[2], ys[3] = y1, y1, y2, y2
        for k in range(4):
            v = rho2 - ys[k] ** 2
            x = math.sqrt(v) if v > 0 else (v if v != v else 0.0)
            xs[k] = x if k % 2 == 0 else x * -1.0
        Ev = _poly(Ec, ti)
        F1v = hh[0] * _poly(f1, ti)
        F0v = hh[0] * _poly(f0, ti)
        at = abs(ti)
        p1 = abs(hh[0])
        sE = _poly_abs(Ec, at)
        s1 = p1 * _poly_abs(f1, at)
        s0 = p1 * _poly_abs(f0, at)
        best = np.inf
        for k in range(4):
            res = abs(Ev * xs[k] + F1v * ys[k] + F0v)
            sc = sE * abs(xs[k]) + s1 * abs(ys[k]) + s0 + 1e-300
            ok[k] = (rho2 - ys[k] ** 2 >= -near_zero_x * max(abs(rho2), ys[k] ** 2) - 1e-9) and math.isfinite(ys[k])
            rel[k] = res / sc if ok[k] else np.inf
            best = min(best, rel[k])
        no_e = abs(Ev) <= 1e-6 * sE
        for k in range(4):
            small_x = xs[k] ** 2 <= near_zero_x * max(rho2, 0.0)
            if ok[k] and (rel[k] <= max(screen, 10.0 * best) or small_x or no_e):
                out_owner[m] = owner[i]
                out_r[m, 0] = xs[k]
                out_r[m, 1] = ys[k]
                out_r[m, 2] = z
                m += 1
    return m
