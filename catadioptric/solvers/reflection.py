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
        from ._batch_kernels import near_normal

        owners, pts = [], []
        h = np.ascontiguousarray(h, dtype=float)
        idx = np.empty(len(h), dtype=np.intp)
        for f in feet:
            back = self._c_frame - f
            back = back / np.linalg.norm(back)
            # the direction toward the target from the foot, h3 - w f (any length), within the sine
            # _NEAR_NORMAL of the way back to the camera
            near = idx[:near_normal(h, np.ascontiguousarray(f, dtype=float), back, _NEAR_NORMAL, idx)].copy()
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
        from ._batch_kernels import homogeneous_units

        targets = np.ascontiguousarray(targets, dtype=float).reshape(-1, 3)
        N = len(targets)
        w = np.broadcast_to(np.asarray(w, float), (N,))
        # (p / L, 1) ~ (p, L): a unit homogeneous 4-vector without dividing, so that no magnitude overflows
        h = np.empty((N, 4))
        homogeneous_units(targets, np.ascontiguousarray((w > 0) * self.L, dtype=float), h)
        hf, cs, sn = self._frame(h)
        owner, r0 = self._candidates(hf)
        fo, fr = self._feet_candidates(hf)
        owner, r0 = np.concatenate([owner, fo]), np.concatenate([r0, fr])
        owner, r, fwd = self._finish(hf, owner, r0, backward)
        r = rot_z(cs[owner], -sn[owner], r) * self.L
        return dedupe(owner, r, fwd, self.L, N)

    def _finish(self, h, owner, r0, backward):
        """Forward/backward assignment, polish and acceptance of candidates (solver frame): the
        side of each candidate's reflected ray (``sigma``: toward the target or away from it; only
        those toward it unless ``backward``), Newton's method with that side, then the law to
        ``ACCEPT``, the mirror to 1e-10, the side unchanged and the patch to 1e-12.

        Newton's method runs on the Lagrange system of Fermat's principle,
        ``grad(|r - c| + sigma phi(r)) + mu grad(Omega) = 0``, ``Omega(r) = 0``, with
        ``phi = |r - p|`` (w = 1) or ``-s . r`` (w = 0, the limit of ``|r - p| - lambda``): its
        stationary points are exactly the reflection points. Each step solves the bordered
        Hessian by the Schur complement of ``M = Hess f + mu Hess Omega`` (the bordered 4x4
        system directly where M is nearly singular), at most 6 steps, stopping after a step below
        1e-8 (quadratic convergence: one or two steps from a polynomial root). One candidate
        at a time, compiled (:func:`catadioptric.solvers._kernels.polish_accept`)."""
        from ._kernels import polish_accept

        owner = np.ascontiguousarray(owner, dtype=np.intp)
        out_o = np.empty(len(owner), dtype=np.intp)
        r = np.empty((len(owner), 3))
        fwd = np.empty(len(owner), dtype=bool)
        m = polish_accept(np.ascontiguousarray(h, dtype=float), owner, np.ascontiguousarray(r0, dtype=float),
                          self.A, self.B, self.C, np.ascontiguousarray(self._c_frame, dtype=float), self.zlo, self.zhi,
                          bool(backward), 6, ACCEPT, out_o, r, fwd)
        return out_o[:m], r[:m], fwd[:m]


def dedupe(owner, r, fwd, length, n_owners=None):
    """Sort flat solutions by (owner, z) and drop repeats of one solution of one target (points
    closer than ``DEDUP`` times ``length``, the mirror's scale in the unit of ``r``, on the same
    side); compiled (:func:`catadioptric.solvers._batch_kernels.sorted_unique`)."""
    from ._batch_kernels import sorted_unique

    if len(owner) == 0:
        return owner, r, fwd
    owner = np.ascontiguousarray(owner, dtype=np.intp)
    n_owners = int(owner.max()) + 1 if n_owners is None else int(n_owners)
    idx = np.empty(len(owner), dtype=np.intp)
    m = sorted_unique(owner, np.ascontiguousarray(r, dtype=float), np.ascontiguousarray(fwd, dtype=bool), n_owners,
                      DEDUP * float(length), idx)
    keep = idx[:m]
    return owner[keep], r[keep], fwd[keep]


def rank_within(owner, key):
    """Order flat entries by (owner, key) (stable) and give each its slot (rank) within its owner;
    compiled (:func:`catadioptric.solvers._batch_kernels.rank_rows`)."""
    from ._batch_kernels import rank_rows

    owner = np.ascontiguousarray(owner, dtype=np.intp)
    order = np.empty(len(owner), dtype=np.intp)
    slot = np.empty(len(owner), dtype=np.intp)
    if len(owner):
        rank_rows(owner, np.ascontiguousarray(key, dtype=float), int(owner.max()) + 1, order, slot)
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
    """Polynomial coefficients of targets ``h (N, n)`` by the fitted map ``(exps, qmap)`` (the
    monomials of each target times the map, compiled: :func:`catadioptric.solvers._kernels.monomial_map`), rebuilt by ``exact(h)`` for the targets where the map's sum cancels to below
    ``_CANCELLED`` of its terms: near a target for which the polynomial vanishes identically (the
    other focus of an ellipsoid seen from near its first focus, where every mirror point reflects)
    the sum keeps only the absolute rounding of its terms, while the construction from the target
    itself keeps its relative accuracy."""
    from ._kernels import monomial_map

    h = np.ascontiguousarray(h, dtype=float)
    qmap = np.ascontiguousarray(qmap, dtype=float)  # one compiled layout (a slice would compile another)
    Q = np.empty((len(h), qmap.shape[1]))
    weak = np.empty(len(h), dtype=bool)
    # a bound of the terms' size: a monomial of degree d is at most max|h_i|^d
    monomial_map(h, exps, qmap, int(exps[0].sum()), float(np.abs(qmap).max(axis=1).sum()), _CANCELLED, Q, weak)
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
