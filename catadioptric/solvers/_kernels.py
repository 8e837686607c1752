"""The compiled inner loops of the reflection solvers (numba), one target or candidate at a time.

Each kernel is the loop form of the routine that calls it and documents it: the same
operations in the same order, float64 throughout, no fast-math (no contraction of products
and sums), so that a row's answer does not depend on the batch it is in nor on the
thread that computes it. Compiled once per machine and cached (numba falls back to a cache
in the user's directory when the package's own is read-only).

* :func:`roots_rows`: real roots in [-1, 1] (:func:`catadioptric.solvers.polynomial.roots_in_unit_interval`);
* :func:`polish_accept`: Newton on Fermat's principle and the acceptance test
  (``ReflectionSolver._finish``);
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["roots_rows", "polish_accept"]

_JIT = {"cache": True, "nogil": True, "error_model": "numpy"}
_STACK = 64  # intervals pending per row: subdivision is depth first, at most ~2 per level (21 levels)


# -- real roots in [-1, 1]

@njit(**_JIT)
def _horner(p, n1, t):
    f = p[n1 - 1]
    for k in range(n1 - 2, -1, -1):
        f = f * t + p[k]
    return f


@njit(**_JIT)
def _refine(p, n1, a, c, iters, tol):
    """Safeguarded Newton on a bracket [a, c] (one sign change, or a == c): the secant point
    of the bracket first, bisection when a step leaves it, stop at steps below ``tol``."""
    fa = _horner(p, n1, a)
    fc = _horner(p, n1, c)
    t = a - fa * (c - a) / (fc - fa)
    if not (math.isfinite(t) and t >= a and t <= c):
        t = 0.5 * (a + c)
    if not a < c:
        return t
    sa = np.sign(fa)
    aw, cw = a, c
    for _ in range(iters):
        f = p[n1 - 1]
        df = 0.0
        for k in range(n1 - 2, -1, -1):
            df = df * t + f
            f = f * t + p[k]
        if np.sign(f) == sa:
            aw = t
        else:
            cw = t
        tn = t - f / df
        bad = not math.isfinite(tn) or tn <= min(aw, cw) or tn >= max(aw, cw)
        if bad:
            tn = 0.5 * (aw + cw)
        done = f == 0.0 or abs(cw - aw) <= tol or (not bad and abs(tn - t) <= tol)
        if f != 0.0:
            t = tn
        if done:
            break
    return t


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
    de Casteljau halving depth first; brackets refined by :func:`_refine`, intervals narrower than
    ``cluster_width`` with two sign changes or more by :func:`_cluster`."""
    M, n1 = p.shape
    n = n1 - 1
    pn = np.empty(n1)
    stack = np.empty((_STACK, n1))
    s_lo = np.empty(_STACK)
    s_w = np.empty(_STACK)
    cur = np.empty(n1)
    m = 0
    for i in range(M):
        m0 = m
        scale = 0.0
        for k in range(n1):
            scale = max(scale, abs(p[i, k]))
        if not scale > 0:
            continue
        for k in range(n1):
            pn[k] = p[i, k] / scale
        for j in range(n1):
            acc = 0.0
            for k in range(n1):
                acc += pn[k] * T[k, j]
            stack[0, j] = acc
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
            if v == 1:
                out_t[m] = _refine(pn, n1, lo * 2.0 - 1.0, (lo + width) * 2.0 - 1.0, newton_iters, 1e-11)
                m += 1
                continue
            if v < 2:
                continue
            if width <= cluster_width:
                m = _cluster(pn, n1, lo * 2.0 - 1.0, width * 2.0, out_t, m)
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
                out_t[m] = _refine(pn, n1, (lo + half) * 2.0 - 1.0, (lo + half) * 2.0 - 1.0, newton_iters, 1e-11)
                m += 1
            s_lo[right] = lo + half
            s_w[right] = half
            s_w[top] = half
            top += 2
        for k in range(m0, m):
            out_i[k] = i
    return m


# -- Newton on Fermat's principle and the acceptance test

@njit(**_JIT)
def _adjugate3(M, adj):
    a, b, c = M[0, 0], M[0, 1], M[0, 2]
    d, e, f = M[1, 0], M[1, 1], M[1, 2]
    g, h, i = M[2, 0], M[2, 1], M[2, 2]
    adj[0, 0] = e * i - f * h
    adj[0, 1] = c * h - b * i
    adj[0, 2] = b * f - c * e
    adj[1, 0] = f * g - d * i
    adj[1, 1] = a * i - c * g
    adj[1, 2] = c * d - a * f
    adj[2, 0] = d * h - e * g
    adj[2, 1] = b * g - a * h
    adj[2, 2] = a * e - b * d


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
def _polish(r, h, sg, A, B, C, c, iters, M, adj, J, rhs, sol, work):
    """Newton on ``grad(|r - c| + sg phi(r)) + mu grad(Omega) = 0``, ``Omega(r) = 0`` in place
    (``ReflectionSolver._finish``, one candidate); the other arguments are work space."""
    hom = (2.0, 2.0, 2.0 * A)
    u = work[0]
    v = work[1]
    grad = work[2]
    gO = work[3]
    f1 = work[4]
    adj_g = work[5]
    delta = work[6]
    mu = 0.0
    for it in range(iters):
        rc0, rc1, rc2 = r[0] - c[0], r[1] - c[1], r[2] - c[2]
        lc = math.sqrt(rc0 * rc0 + rc1 * rc1 + rc2 * rc2)
        u[0], u[1], u[2] = rc0 / lc, rc1 / lc, rc2 / lc
        tw0, tw1, tw2 = h[0] - h[3] * r[0], h[1] - h[3] * r[1], h[2] - h[3] * r[2]
        tn = math.sqrt(tw0 * tw0 + tw1 * tw1 + tw2 * tw2)
        if not tn > 0:
            tn = 1.0
        v[0], v[1], v[2] = -tw0 / tn, -tw1 / tn, -tw2 / tn
        inv_lp = h[3] / tn
        for k in range(3):
            grad[k] = u[k] + sg * v[k]
        gO[0], gO[1], gO[2] = 2 * r[0], 2 * r[1], 2 * A * r[2] + B
        Om = r[0] ** 2 + r[1] ** 2 + A * r[2] ** 2 + B * r[2] - C
        if it == 0:
            mu = -(grad[0] * gO[0] + grad[1] * gO[1] + grad[2] * gO[2]) / (gO[0] * gO[0] + gO[1] * gO[1] + gO[2] * gO[2])
        w = inv_lp * sg
        for i in range(3):
            for j in range(3):
                e = 1.0 if i == j else 0.0
                M[i, j] = (e - u[i] * u[j]) / lc + (e - v[i] * v[j]) * w + mu * (hom[i] if i == j else 0.0)
        for k in range(3):
            f1[k] = grad[k] + mu * gO[k]
        _adjugate3(M, adj)
        detM = M[0, 0] * adj[0, 0] + M[0, 1] * adj[1, 0] + M[0, 2] * adj[2, 0]
        big = 0.0
        for i in range(3):
            adj_g[i] = adj[i, 0] * gO[0] + adj[i, 1] * gO[1] + adj[i, 2] * gO[2]
            for j in range(3):
                big = max(big, abs(adj[i, j]))
        den = gO[0] * adj_g[0] + gO[1] * adj_g[1] + gO[2] * adj_g[2]
        dmu = (Om * detM - (adj_g[0] * f1[0] + adj_g[1] * f1[1] + adj_g[2] * f1[2])) / den
        finite = math.isfinite(dmu)
        for i in range(3):
            g0, g1, g2 = f1[0] + gO[0] * dmu, f1[1] + gO[1] * dmu, f1[2] + gO[2] * dmu
            delta[i] = -(adj[i, 0] * g0 + adj[i, 1] * g1 + adj[i, 2] * g2) / detM
            finite = finite and math.isfinite(delta[i])
        delta[3] = dmu
        if not finite or abs(detM) <= 1e-12 * big:  # M (nearly) singular: the bordered system directly
            for i in range(3):
                for j in range(3):
                    J[i, j] = M[i, j]
                J[i, 3] = gO[i]
                J[3, i] = gO[i]
                rhs[i] = f1[i]
            J[3, 3] = 0.0
            rhs[3] = Om
            _solve4(J, rhs, sol)
            for i in range(4):
                delta[i] = sol[i]
        ok = True
        for i in range(4):
            ok = ok and math.isfinite(delta[i])
        if not ok:
            for i in range(4):
                delta[i] = 0.0
        step = 0.0
        for i in range(3):
            r[i] += delta[i]
            step = max(step, abs(delta[i]))
        mu += delta[3]
        # quadratic convergence: after a step below 1e-8 the error is at rounding level
        if not step > 1e-8:
            break


@njit(**_JIT)
def polish_accept(h, owner, r0, A, B, C, c, zlo, zhi, backward, iters, accept, out_r, out_fwd, out_ok):
    """Per candidate ``r0[i]`` of target ``h[owner[i]]`` (solver frame): the side of the reflected
    ray (``sigma``), Newton's polish, and the acceptance test (``ReflectionSolver._finish``)."""
    r = np.empty(3)
    M = np.empty((3, 3))
    adj = np.empty((3, 3))
    J = np.zeros((4, 4))
    rhs = np.empty(4)
    sol = np.empty(4)
    work = np.empty((7, 4))
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
            out_ok[i] = False
            continue
        _polish(r, hi, sg, A, B, C, c, iters, M, adj, J, rhs, sol, work)
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
        out_r[i, 0], out_r[i, 1], out_r[i, 2] = r[0], r[1], r[2]
        out_fwd[i] = fwd
        out_ok[i] = (math.isfinite(sine) and sine <= accept and abs(om) <= 1e-10 and fwd == (sg > 0)
                     and r[2] >= zlo - 1e-12 and r[2] <= zhi + 1e-12 and math.sqrt(nn) > 1e-9 and tn > 0)


# -- polynomial coefficients of targets by a fitted homogeneous map

@njit(**_JIT)
def monomial_map(h, exps, qmap, degree, qsum, cancelled, Q, weak):
    """``Q[i] = monomials(h[i]) @ qmap`` (``catadioptric.solvers.reflection.map_coefficients``), monomials
    ``prod_k h[i, k]^exps[j, k]`` from powers built by products, and ``weak[i]``: ``max |Q[i]|`` below
    ``cancelled`` times the bound ``max_k |h[i, k]|^degree qsum`` of its terms."""
    N, nv = h.shape
    J, n_out = qmap.shape
    d = 0
    for j in range(J):
        for k in range(nv):
            d = max(d, exps[j, k])
    pw = np.empty((nv, d + 1))
    mo = np.empty(J)
    qmap_t = np.ascontiguousarray(qmap.T)
    for i in range(N):
        for k in range(nv):
            pw[k, 0] = 1.0
            for e in range(1, d + 1):
                pw[k, e] = pw[k, e - 1] * h[i, k]
        for j in range(J):
            mono = 1.0
            for k in range(nv):
                if exps[j, k]:
                    mono *= pw[k, exps[j, k]]
            mo[j] = mono
        for o in range(n_out):
            acc = 0.0
            for j in range(J):
                acc += mo[j] * qmap_t[o, j]
            Q[i, o] = acc
        big = 0.0
        for o in range(n_out):
            big = max(big, abs(Q[i, o]))
        hm = 0.0
        for k in range(nv):
            hm = max(hm, abs(h[i, k]))
        weak[i] = big < cancelled * (hm ** degree * qsum)


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


# -- flat solutions sorted by (owner, z), repeats dropped

@njit(**_JIT)
def sorted_unique(owner, r, fwd, n_owners, tol, out_idx):
    """Indices of the flat solutions ordered by (owner, z) (stable: ties keep their order), without
    repeats: an entry within ``tol`` of an earlier entry of its owner on the same side (``fwd``);
    returns their number (:func:`catadioptric.solvers.reflection.dedupe`)."""
    n = len(owner)
    start = np.zeros(n_owners + 1, dtype=np.intp)
    for i in range(n):
        start[owner[i] + 1] += 1
    for o in range(n_owners):
        start[o + 1] += start[o]
    pos = start[:-1].copy()
    order = np.empty(n, dtype=np.intp)
    for i in range(n):
        order[pos[owner[i]]] = i
        pos[owner[i]] += 1
    m = 0
    for o in range(n_owners):
        a, b = start[o], start[o + 1]
        for j in range(a + 1, b):  # insertion sort by z, stable
            x = order[j]
            k = j - 1
            while k >= a and r[order[k], 2] > r[x, 2]:
                order[k + 1] = order[k]
                k -= 1
            order[k + 1] = x
        for j in range(a, b):
            x = order[j]
            dup = False
            for k in range(a, j):
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
    n = len(owner)
    start = np.zeros(n_owners + 1, dtype=np.intp)
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
        for j in range(a + 1, b):  # insertion sort by key, stable (NaN keys last, as a lexsort)
            x = order[j]
            k = j - 1
            while k >= a and (key[order[k]] > key[x] or (key[order[k]] != key[order[k]] and key[x] == key[x])):
                order[k + 1] = order[k]
                k -= 1
            order[k + 1] = x
        for j in range(a, b):
            slot[j] = j - a
