"""The shared back end of the reflection-point solvers.

Every solver finds, for a batch of homogeneous targets ``(p, w)`` (``w = 1`` a
finite point, ``w = 0`` the point at infinity in direction ``p``), all the
points ``r`` of the mirror patch where the law of reflection sends the camera
ray toward the target. The solvers differ in how they reach candidate points
(polynomials of degree 8, 6, 4 or 2; see docs/solvers.md); this module holds
what they share: normalisation, the Newton polish on Fermat's principle, the
acceptance test and the NaN-padded gathering of solutions.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._numeric import rowdot, unit

__all__ = ["ReflectionSolutions", "ReflectionSolver", "reflect", "monomials", "exponents"]

# after polishing, a reflection point must satisfy the law to this (sine of the angle)
ACCEPT = 1e-9
DEDUP = 1e-8
# targets within this sine of a normal line (camera - foot) also start from the foot
_NEAR_NORMAL = 1e-2
# polynomial coefficients from the fitted map while they keep 10 of 16 digits, else rebuilt from the target
_CANCELLED = 1e-6


@dataclass
class ReflectionSolutions:
    """Reflection points of each target, NaN-padded along axis -2.

    ``points (N, K, 3)`` in the caller's frame; ``forward (N, K)`` is True where the
    reflected ray points toward the target (``d . (p - w r) > 0``), False where it
    points away (for w = 0: a point of ``-s``); ``found (N, K)`` marks entries.
    """

    points: np.ndarray
    forward: np.ndarray
    found: np.ndarray


def reflect(incident: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """Reflect directions ``incident (..., 3)`` about normals ``(..., 3)`` (any length)."""
    nn = np.sum(normal * normal, axis=-1, keepdims=True)
    return incident - 2.0 * normal * (np.sum(incident * normal, axis=-1, keepdims=True) / nn)


def exponents(n_vars: int, degree: int) -> np.ndarray:
    """All exponent vectors of the monomials of exactly ``degree`` in ``n_vars`` variables."""
    if n_vars == 1:
        return np.array([[degree]])
    out = []
    for k in range(degree, -1, -1):
        for rest in exponents(n_vars - 1, degree - k):
            out.append([k, *rest])
    return np.array(out)


def monomials(h: np.ndarray, exps: np.ndarray) -> np.ndarray:
    """Values of the monomials ``prod h_i^e_i`` for rows ``h (N, n)``: ``(N, len(exps))``."""
    d = int(exps.max(initial=0))
    pw = np.ones((h.shape[1], d + 1) + h.shape[:1])
    for k in range(1, d + 1):
        pw[:, k] = pw[:, k - 1] * h.T
    out = np.ones((len(exps),) + h.shape[:1])
    for j, e in enumerate(exps):
        for i, k in enumerate(e):
            if k:
                out[j] *= pw[i, k]
    return out.T


def adjugate3(M):
    """Adjugate of batched 3x3 matrices (M @ adj = det I)."""
    a, b, c = M[:, 0, 0], M[:, 0, 1], M[:, 0, 2]
    d, e, f = M[:, 1, 0], M[:, 1, 1], M[:, 1, 2]
    g, h, i = M[:, 2, 0], M[:, 2, 1], M[:, 2, 2]
    out = np.empty_like(M)
    out[:, 0, 0] = e * i - f * h
    out[:, 0, 1] = c * h - b * i
    out[:, 0, 2] = b * f - c * e
    out[:, 1, 0] = f * g - d * i
    out[:, 1, 1] = a * i - c * g
    out[:, 1, 2] = c * d - a * f
    out[:, 2, 0] = d * h - e * g
    out[:, 2, 1] = b * g - a * h
    out[:, 2, 2] = a * e - b * d
    return out


def newton_polish(r, A, B, C, c, h, sigma, iters=6):
    """Newton's method on the Lagrange system of Fermat's principle.

    ``grad(|r - c| + sigma phi(r)) + mu grad(Omega) = 0``, ``Omega(r) = 0``, with
    ``phi = |r - p|`` (w = 1) or ``-s . r`` (w = 0, the limit of ``|r - p| - lambda``);
    ``sigma = +1`` for a reflected ray toward the target, ``-1`` away from it. The
    stationary points are exactly the reflection points. Iterates on the entries
    that still move (quadratic convergence: one or two steps from a polynomial root).
    """
    r = r.copy()
    mu_all = np.zeros(len(r))
    Hom = np.diag([2.0, 2.0, 2.0 * A])
    eye = np.eye(3)
    act = np.arange(len(r))
    for it in range(iters):
        if len(act) == 0:
            break
        ra, ha, sg = r[act], h[act], sigma[act, None]
        rc = ra - c
        lc = np.linalg.norm(rc, axis=-1, keepdims=True)
        u = rc / lc
        # toward the target: p - r = (h3 - w r) / w, or s = h3 at infinity; |r - p| = |h3 - w r| / w without
        # forming p, so that targets of any magnitude (w down to the smallest float) are alike
        tw = ha[:, :3] - ha[:, 3:] * ra
        tn = np.linalg.norm(tw, axis=-1, keepdims=True)
        tn = np.where(tn > 0, tn, 1.0)
        v = -tw / tn
        inv_lp = ha[:, 3:] / tn  # 1 / |r - p|, 0 at infinity
        grad = u + sg * v
        gO = np.stack([2 * ra[:, 0], 2 * ra[:, 1], 2 * A * ra[:, 2] + B], axis=-1)
        Om = ra[:, 0] ** 2 + ra[:, 1] ** 2 + A * ra[:, 2] ** 2 + B * ra[:, 2] - C
        if it == 0:
            mu_all[act] = -np.sum(grad * gO, axis=-1) / np.sum(gO * gO, axis=-1)
        mu = mu_all[act]
        # Schur complement of the bordered Hessian [[M, g], [g^T, 0]], M = Hess f + mu Hess Omega
        M = (eye - u[:, :, None] * u[:, None, :]) / lc[:, :, None]
        M = M + (eye - v[:, :, None] * v[:, None, :]) * (inv_lp * sg)[:, :, None]
        M = M + mu[:, None, None] * Hom
        f1 = grad + mu[:, None] * gO
        adj = adjugate3(M)
        detM = np.einsum("ij,ij->i", M[:, 0, :], adj[:, :, 0])
        with np.errstate(all="ignore"):
            adj_g = np.einsum("nij,nj->ni", adj, gO)
            den = np.einsum("ni,ni->n", gO, adj_g)
            dmu = (Om * detM - np.einsum("ni,ni->n", adj_g, f1)) / den
            dr = -np.einsum("nij,nj->ni", adj, f1 + gO * dmu[:, None]) / detM[:, None]
            delta = np.concatenate([dr, dmu[:, None]], axis=-1)
            weak = ~np.all(np.isfinite(delta), axis=-1) | (np.abs(detM) <= 1e-12 * np.abs(adj).max(axis=(1, 2)))
            if np.any(weak):  # M (nearly) singular: solve the bordered system directly
                J = np.zeros((int(weak.sum()), 4, 4))
                J[:, :3, :3] = M[weak]
                J[:, :3, 3] = gO[weak]
                J[:, 3, :3] = gO[weak]
                rhs = np.concatenate([f1[weak], Om[weak, None]], axis=-1)
                good = np.abs(np.linalg.det(J)) > 1e-300
                sol = np.zeros_like(rhs)
                if np.any(good):
                    sol[good] = np.linalg.solve(J[good], -rhs[good][..., None])[..., 0]
                delta[weak] = sol
        delta[~np.all(np.isfinite(delta), axis=-1)] = 0.0
        r[act] = ra + delta[:, :3]
        mu_all[act] = mu + delta[:, 3]
        # quadratic convergence: after a step below 1e-8 the error is at rounding level
        act = act[np.max(np.abs(delta[:, :3]), axis=-1) > 1e-8]
    return r


def rotation_to_yz(v1, v2):
    """cos, sin of the rotation about z taking (v1, v2) to (0, hypot(v1, v2))."""
    rho = np.hypot(v1, v2)
    safe = rho > 0
    cs = np.where(safe, v2 / np.where(safe, rho, 1.0), 1.0)
    sn = np.where(safe, v1 / np.where(safe, rho, 1.0), 0.0)
    return cs, sn


def rot_z(cs, sn, v):
    """Rotate ``v (..., 3)`` about z by the angle with cosine ``cs`` and sine ``sn``."""
    out = v.copy()
    out[..., 0] = cs * v[..., 0] - sn * v[..., 1]
    out[..., 1] = sn * v[..., 0] + cs * v[..., 1]
    return out


class ReflectionSolver:
    """Base class: one solver per family of configurations (docs/solvers.md).

    Subclasses set ``name``, ``degree`` (of the polynomial they solve), ``reference``
    and implement ``_frame`` (targets into the solver frame) and ``_candidates``
    (candidate reflection points from the polynomial's roots).
    """

    name = "abstract"
    degree = 0
    reference = ""

    def __init__(self, A, B, C, z_min, z_max, center, scale):
        self.L = float(scale)
        self.A, self.B, self.C = float(A), float(B) / self.L, float(C) / self.L**2
        self.zlo, self.zhi = float(z_min) / self.L, float(z_max) / self.L
        self.c = np.asarray(center, dtype=float) / self.L
        pad = 1e-9 * (self.zhi - self.zlo)
        self.zt = np.array([(self.zlo + self.zhi) / 2, (self.zhi - self.zlo) / 2 + pad])

    @property
    def max_solutions(self) -> int:
        return self.degree

    # -- near normal incidence
    def normal_feet(self) -> np.ndarray:
        """Points ``(F, 3)`` of the patch (solver frame) where the camera ray meets the mirror
        along its normal: the camera sees its own reflection there. None by default."""
        return np.zeros((0, 3))

    def _feet_candidates(self, h):
        """The normal feet as candidates for the targets near their normal lines.

        A target on the line through the camera and a foot reflects at the foot; near it, the
        eliminated polynomial has a cluster of roots there (the plane of reflection is
        undetermined on the line itself) whose candidates can be too poor to polish. The foot
        itself is a good start: the reflection point moves smoothly with the target there."""
        feet = self._feet
        if not len(feet):
            return np.zeros(0, dtype=np.intp), np.zeros((0, 3))
        owners, pts = [], []
        for f in feet:
            back = self._c_frame - f
            back = back / np.linalg.norm(back)
            tg = h[:, :3] - h[:, 3:] * f  # toward the target, any length
            tn = np.linalg.norm(tg, axis=1)
            near = np.nonzero((np.linalg.norm(np.cross(tg, back), axis=1) <= _NEAR_NORMAL * tn) & (tn > 0))[0]
            owners.append(near)
            pts.append(np.broadcast_to(f, (len(near), 3)))
        return np.concatenate(owners), np.concatenate(pts)

    @property
    def _feet(self) -> np.ndarray:
        if not hasattr(self, "_feet_cache"):
            f = np.asarray(self.normal_feet(), float).reshape(-1, 3)
            nrm = np.stack([f[:, 0], f[:, 1], self.A * f[:, 2] + 0.5 * self.B], axis=-1)
            ok = ((f[:, 2] >= self.zlo - 1e-12) & (f[:, 2] <= self.zhi + 1e-12)
                  & (np.linalg.norm(nrm, axis=1) > 1e-9) & (np.linalg.norm(f - self._c_frame, axis=1) > 1e-9))
            self._feet_cache = f[ok]
        return self._feet_cache

    # -- to implement
    def _frame(self, h):  # -> (h in the solver frame, cs, sn) per target
        raise NotImplementedError

    def _candidates(self, h):  # -> (owner index, r0 (M, 3)) in the solver frame
        raise NotImplementedError

    # -- shared pipeline
    def solve(self, targets, w, *, backward=False) -> ReflectionSolutions:
        """Reflection points of targets ``(N, 3)`` with weights ``w`` (1: points, 0: directions),
        NaN-padded to ``max_solutions`` per target."""
        owner, r, fwd = self.solve_flat(targets, w, backward=backward)
        return gather(len(targets), owner, r, fwd, self.max_solutions)

    def solve_flat(self, targets, w, *, backward=False):
        """Like :meth:`solve`, as flat arrays ``(owner, points, forward)`` without duplicates."""
        targets = np.asarray(targets, dtype=float)
        N = len(targets)
        w = np.broadcast_to(np.asarray(w, float), (N,))
        # (p / L, 1) ~ (p, L): a unit homogeneous 4-vector without dividing, so that no magnitude overflows
        h = unit(np.concatenate([targets, (w > 0)[:, None] * self.L], axis=1))
        hf, cs, sn = self._frame(h)
        owner, r0 = self._candidates(hf)
        fo, fr = self._feet_candidates(hf)
        owner, r0 = np.concatenate([owner, fo]), np.concatenate([r0, fr])
        owner, r, fwd = self._finish(hf, owner, r0, backward)
        r = rot_z(cs[owner], -sn[owner], r) * self.L
        return dedupe(owner, r, fwd, self.L)

    def _finish(self, h, owner, r0, backward):
        """Forward/backward assignment, polish and acceptance of candidates (solver frame)."""
        A, B, C = self.A, self.B, self.C
        c = self._c_frame
        nrm0 = np.stack([r0[:, 0], r0[:, 1], A * r0[:, 2] + 0.5 * B], axis=-1)
        d0 = reflect(r0 - c, nrm0)
        ho = h[owner]
        # toward the target: (h3 - w r) is (p - r) w for a point, s for a direction
        tg0 = ho[:, :3] - ho[:, 3:] * r0
        sigma = np.where(np.sum(d0 * tg0, axis=-1) >= 0, 1.0, -1.0)
        if not backward:
            keep = sigma > 0
            owner, r0, sigma, ho = owner[keep], r0[keep], sigma[keep], ho[keep]
        r = newton_polish(r0, A, B, C, c, ho, sigma)
        nrm = np.stack([r[:, 0], r[:, 1], A * r[:, 2] + 0.5 * B], axis=-1)
        d = reflect(r - c, nrm)
        d /= np.linalg.norm(d, axis=-1, keepdims=True)
        tgt = ho[:, :3] - ho[:, 3:] * r
        tn = np.linalg.norm(tgt, axis=-1, keepdims=True)
        tgt = tgt / np.where(tn > 0, tn, 1.0)
        sine = np.linalg.norm(np.cross(d, tgt), axis=-1)
        fwd = np.sum(d * tgt, axis=-1) > 0
        om = r[:, 0] ** 2 + r[:, 1] ** 2 + A * r[:, 2] ** 2 + B * r[:, 2] - C
        ok = (np.isfinite(sine) & (sine <= ACCEPT) & (np.abs(om) <= 1e-10) & (fwd == (sigma > 0))
              & (r[:, 2] >= self.zlo - 1e-12) & (r[:, 2] <= self.zhi + 1e-12)
              & (np.linalg.norm(nrm, axis=-1) > 1e-9) & (tn[:, 0] > 0))
        return owner[ok], r[ok], fwd[ok]


def dedupe(owner, r, fwd, length):
    """Sort flat solutions by (owner, z) and drop repeats of one solution of one target (points
    closer than ``DEDUP`` times ``length``, the mirror's scale in the unit of ``r``)."""
    if len(owner) == 0:
        return owner, r, fwd
    order = np.lexsort((r[:, 2], owner))
    owner, r, fwd = owner[order], r[order], fwd[order]
    scale = float(length)
    dup = np.zeros(len(owner), dtype=bool)
    k = 1
    while True:  # compare with the k-th previous entry of the same owner
        same = owner[k:] == owner[:-k]
        if not np.any(same):
            break
        close = np.linalg.norm(r[k:] - r[:-k], axis=1) <= DEDUP * scale
        dup[k:] |= same & close & (fwd[k:] == fwd[:-k])
        k += 1
    keep = ~dup
    return owner[keep], r[keep], fwd[keep]


def rank_within(owner, key):
    """Order flat entries by (owner, key) and give each its slot (rank) within its owner."""
    order = np.lexsort((key, owner))
    o = owner[order]
    starts = np.r_[0, np.nonzero(np.diff(o))[0] + 1] if len(o) else np.zeros(0, dtype=np.intp)
    counts = np.diff(np.r_[starts, len(o)])
    slot = np.arange(len(o)) - np.repeat(starts, counts)
    return order, slot


def gather(N, owner, r, fwd, K):
    """Scatter flat solutions (without duplicates: ``solve_flat``'s) into (N, K) slots."""
    out = np.full((N, K, 3), np.nan)
    fo = np.zeros((N, K), dtype=bool)
    found = np.zeros((N, K), dtype=bool)
    order, slot = rank_within(owner, r[:, 2])
    ok = slot < K
    o, sl = owner[order][ok], slot[ok]
    out[o, sl] = r[order][ok]
    fo[o, sl] = fwd[order][ok]
    found[o, sl] = True
    return ReflectionSolutions(out, fo, found)


def map_coefficients(h, exps, qmap, exact):
    """Polynomial coefficients of targets ``h (N, n)`` by the fitted map ``(exps, qmap)`` (one matrix
    product), rebuilt by ``exact(h)`` for the targets where the map's sum cancels to below
    ``_CANCELLED`` of its terms: near a target for which the polynomial vanishes identically (the
    other focus of an ellipsoid seen from near its first focus, where every mirror point reflects)
    the sum keeps only the absolute rounding of its terms, while the construction from the target
    itself keeps its relative accuracy."""
    Q = rowdot(monomials(h, exps), qmap)
    # a bound of the terms' size: a monomial of degree d is at most max|h_i|^d
    size = np.abs(h).max(axis=1) ** int(exps[0].sum()) * float(np.abs(qmap).max(axis=1).sum())
    weak = np.abs(Q).max(axis=1) < _CANCELLED * size
    if np.any(weak):
        Q[weak] = exact(h[weak])[:, :Q.shape[1]]
    return Q


def fit_homogeneous_map(fn, n_vars: int, degree: int, *, seed: int = 0):
    """Coefficients of a map that is a homogeneous polynomial of ``degree`` in the
    target's ``n_vars`` coordinates, coefficient by coefficient.

    ``fn(h (S, n_vars)) -> (S, n_out)`` is evaluated on well-spread unit targets and
    the map ``(n_monomials, n_out)`` is the least-squares solution, which is exact up
    to rounding because the map is a polynomial of that degree. Entries at the
    rounding level are set to zero (structural zeros). Returns ``(exponents, map)``.
    """
    exps = exponents(n_vars, degree)
    rng = np.random.default_rng(seed)
    S = max(4 * len(exps), 40)
    h = rng.normal(size=(S, n_vars))
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    V = fn(h)
    Mo = monomials(h, exps)
    X, *_ = np.linalg.lstsq(Mo, V, rcond=None)
    big = np.max(np.abs(X))
    resid = np.max(np.abs(Mo @ X - V)) / max(np.max(np.abs(V)), 1e-300)
    if not resid < 1e-9:
        raise ArithmeticError(f"polynomial map fit failed: relative residual {resid:.2e}")
    X[np.abs(X) <= 1e-13 * big] = 0.0
    # drop trailing all-zero outputs (polynomial coefficients above the genuine degree)
    n = X.shape[1]
    while n > 1 and not np.any(X[:, n - 1]):
        n -= 1
    return exps, X[:, :n]
