"""General solver: any axially symmetric quadric, a camera off the axis. Degree 8.

The reflection points of a target ``h = (p, w)`` satisfy ``G(y, z) = 0`` and
``H(y, z) = F^2 + (y^2 + A z^2 + B z - C) E^2 = 0`` (module constraints);
``Res_y(G, H)`` has degree 10 in z and always contains the spurious factor
``E(z)^2``. The quotient, the genuine octic, is a homogeneous polynomial of
degree 4 in ``h``, so for one camera its nine coefficients are a fixed linear map
of the 35 monomials of ``h``: one matrix product per batch. For vanishing points
(w = 0) the octic is the paper's kappa_16 with the spurious ``kappa_1^2`` removed.

Degenerate targets: for ``s = +-e1`` (in the frame where ``c = (0, c2, c3)``),
``G`` vanishes identically; there ``d2 = d3 = 0`` gives ``Res_y(d2, d3)`` instead.

Reference: Miraldo, Eiras, Ramalingam, CVPR 2018, Sec. 2.2 (corrected, see
docs/solvers.md); Agrawal, Taguchi, Ramalingam, ECCV 2010 (degree 8 for an
off-axis camera and a finite point).
"""
from __future__ import annotations

import numpy as np

from .._numeric import rowdot
from . import bivariate as bv
from .constraints import (coplanarity, general_resultant, plane_resultant, reflected_yz, reflection_G,
                          resultant_quadratic_linear)
from .polynomial import deflate_linear, polyval, roots_in_unit_interval
from .reflection import ReflectionSolver, fit_homogeneous_map, map_coefficients, rotation_to_yz

_SCREEN = 1e-5
# x^2 = rho^2 - y^2 within this fraction of rho^2 of zero: x is ill-conditioned there (y comes from G,
# which cancels for targets near the plane of the camera and the axis and for cameras near the axis);
# such branches are kept as candidates with x = 0 when negative
_NEAR_ZERO_X = 0.05
# targets this close to the plane of the camera and the axis (|p1| relative to |(p2, p3, w)|) also get
# the reflection points of the 1-D problem in that plane as candidates
_NEAR_PLANE = 1e-3


def quad_roots(a, b, c):
    """Both real roots of ``a y^2 + b y + c`` (NaN when complex; one root when linear)."""
    disc = b * b - 4 * a * c
    sq = np.sqrt(np.maximum(disc, 0.0))
    sq = np.where(disc < -1e-12 * (b * b + np.abs(4 * a * c)), np.nan, sq)
    qq = -0.5 * (b + np.where(b >= 0, sq, -sq))
    with np.errstate(divide="ignore", invalid="ignore"):
        y1 = qq / a
        y2 = c / qq
        lin = np.abs(a) <= 1e-14 * (np.abs(b) + np.abs(c))
        y1 = np.where(lin, -c / b, y1)
        y2 = np.where(lin, np.nan, y2)
    return y1, y2


class GeneralSolver(ReflectionSolver):
    name = "general"
    degree = 8
    reference = "Miraldo et al. CVPR 2018 Sec. 2.2 (kappa_16 / kappa_1^2); Agrawal et al. ECCV 2010"

    def __init__(self, A, B, C, z_min, z_max, center, scale):
        super().__init__(A, B, C, z_min, z_max, center, scale)
        cs, sn = rotation_to_yz(self.c[0], self.c[1])
        self._cs, self._sn = float(cs), float(sn)
        self.c2, self.c3 = float(np.hypot(self.c[0], self.c[1])), float(self.c[2])
        self._c_frame = np.array([0.0, self.c2, self.c3])
        a = (self.A, self.B, self.C, self.c2, self.c3, self.zt)

        def octic(h):
            R, E = general_resultant(*a, h)
            return deflate_linear(deflate_linear(R, E), E)

        self._octic = octic
        self._exps, self._qmap = fit_homogeneous_map(octic, 4, 4)
        at_infinity = self._exps[:, 3] == 0  # monomials free of w: all that directions need
        self._exps_dir, self._qmap_dir = self._exps[at_infinity], self._qmap[at_infinity]
        basis = np.eye(4)
        Gb = reflection_G(*a, basis)
        self._gmap = np.stack([bv.y_coefficient(Gb, k, 5) for k in (2, 1, 0)], axis=1).reshape(4, 15)
        self._emap = coplanarity(*a, basis)[0]
        E, F1, F0 = coplanarity(*a, np.array([[1.0, 0, 0, 0]]))
        self._f1, self._f0 = F1[0], F0[0]  # F = p1 (f1 y + f0)

    def normal_feet(self):
        """Feet in the plane x = 0 of the camera and the axis: ``(0, y, z)`` on the mirror with
        ``(0, y - c2, z - c3)`` along the normal ``(0, y, A z + B/2)``, so
        ``y ((1 - A) z - c3 - B/2) + c2 (A z + B/2) = 0``; with ``y^2 = C - A z^2 - B z``:
        ``c2^2 (A z + B/2)^2 = (C - A z^2 - B z) ((1 - A) z - c3 - B/2)^2``, a quartic in z."""
        P = np.polynomial.Polynomial
        A, B, C, c2, c3 = self.A, self.B, self.C, self.c2, self.c3
        n3 = P([B / 2, A])
        den = P([-c3 - B / 2, 1 - A])
        rho2 = P([C, -B, -A])
        q = c2 * c2 * n3 * n3 - rho2 * den * den
        if not np.any(q.coef):
            return np.zeros((0, 3))
        out = []
        for z in q.roots():
            if abs(z.imag) > 1e-7 * (1 + abs(z.real)):
                continue
            z = z.real
            if abs(den(z)) <= 1e-12:
                continue
            y = -c2 * n3(z) / den(z)
            if abs(y * y - rho2(z)) <= 1e-7 * (1 + y * y):
                out.append([0.0, y, z])
        return np.array(out).reshape(-1, 3)

    def _frame(self, h):
        N = len(h)
        cs, sn = np.full(N, self._cs), np.full(N, self._sn)
        hr = h.copy()
        hr[:, 0] = self._cs * h[:, 0] - self._sn * h[:, 1]
        hr[:, 1] = self._sn * h[:, 0] + self._cs * h[:, 1]
        return hr, cs, sn

    def _candidates(self, h):
        e1 = (np.abs(h[:, 1]) <= 1e-12) & (np.abs(h[:, 2]) <= 1e-12) & (h[:, 3] == 0)
        gen = np.nonzero(~e1)[0]
        hg = h[gen] if len(gen) < len(h) else h
        exps, qmap = (self._exps_dir, self._qmap_dir) if np.all(hg[:, 3] == 0) else (self._exps, self._qmap)
        Q = map_coefficients(hg, exps, qmap, self._octic)
        ridx, t = roots_in_unit_interval(Q)
        # Back-substitution: for each root z, y from G's quadratic (both roots), x = +-sqrt(rho^2 - y^2),
        # screened by the coplanarity E x + F1 y + F0 = 0 (compiled, one root at a time:
        # catadioptric.solvers._kernels.general_back_substitution).
        # Screening picks the branch (y root, sign of x) that fits the coplanarity best. It must not
        # be strict: x = sqrt(rho^2 - y^2) is ill-conditioned where x is small (targets near the
        # plane of the camera and the axis) and z is a poor coordinate near a vertex, so a
        # genuine root can carry a visible residual. Keep every candidate within a factor of the
        # root's best (residual relative to the size of its terms, the absolute coefficients at
        # |t|: rel <= 1 always, no absolute threshold), every candidate with a small x
        # (its residual says little), and every candidate where E vanishes (the coplanarity
        # holds for any x there: one z can hold a solution in the plane x = 0 and a pair off it);
        # the polish and the acceptance test decide.
        # x^2 = rho^2 - y^2 may come out slightly negative for x ~ 0 (a root of the octic known to
        # about the square root of the rounding where two solutions share one z): such branches
        # are kept (x = 0) down to -_NEAR_ZERO_X of max(|rho^2|, y^2)
        from ._kernels import general_back_substitution

        out_o = np.empty(4 * len(t), dtype=np.intp)
        out_r = np.empty((4 * len(t), 3))
        m = general_back_substitution(h, np.ascontiguousarray(gen[ridx]), t, self._gmap, self._emap, self._f1,
                                      self._f0, self.A, self.B, self.C, self.zt, _SCREEN, _NEAR_ZERO_X, out_o, out_r)
        owners = [out_o[:m]]
        pts = [out_r[:m]]
        if np.any(e1):
            o, r = self._e1_candidates(np.nonzero(e1)[0])
            owners.append(o)
            pts.append(r)
        o, r = self._plane_candidates(h, ~e1)
        owners.append(o)
        pts.append(r)
        return np.concatenate(owners), np.concatenate(pts)

    def _plane_candidates(self, h, ok):
        """Targets in or near the plane x = 0 of the camera and the axis: their reflection points in
        that plane, from the 1-D problem there (``Res_y(G, y^2 - rho^2)``). Next to a solution off the
        plane pair (a cusp of the caustic) the octic holds the three in one cluster of roots, too
        poor to back-substitute; in the plane the solution is a simple root. Near the plane the
        in-plane solutions are starting points for the polish."""
        from ._batch_kernels import near_plane

        idx = np.empty(len(h), dtype=np.intp)
        idx = idx[:near_plane(np.ascontiguousarray(h, dtype=float), np.ascontiguousarray(ok, dtype=bool), _NEAR_PLANE,
                              idx)].copy()
        if not len(idx):
            return np.zeros(0, dtype=np.intp), np.zeros((0, 3))
        hp = h[idx].copy()
        hp[:, 0] = 0.0
        R = plane_resultant(self.A, self.B, self.C, self.c2, self.c3, self.zt, hp)
        ridx, t = roots_in_unit_interval(R)
        z = self.zt[0] + self.zt[1] * t
        rho2 = self.C - self.A * z * z - self.B * z
        G = rowdot(hp[ridx], self._gmap).reshape(-1, 3, 5)
        y1, y2 = quad_roots(polyval(G[:, 0], t), polyval(G[:, 1], t), polyval(G[:, 2], t))
        ys = np.stack([y1, y2], axis=-1)
        near = np.isfinite(ys) & (np.abs(ys**2 - rho2[:, None]) <= _NEAR_ZERO_X * np.maximum(np.abs(rho2)[:, None], ys**2))
        kk = np.nonzero(near)
        return idx[ridx[kk[0]]], np.stack([np.zeros(len(kk[0])), ys[kk], z[kk[0]]], axis=-1)

    def _e1_candidates(self, idx):
        """Directions along +-e1: the reflected ray is along x, so d2 = d3 = 0 (target-free)."""
        d2, d3 = reflected_yz(self.A, self.B, self.C, self.c2, self.c3, self.zt)
        a, b, c = (bv.y_coefficient(d2, k, 6) for k in (2, 1, 0))
        f1, f0 = (bv.y_coefficient(d3, k, 6) for k in (1, 0))
        R = resultant_quadratic_linear(a, b, c, f1, f0)
        _, t = roots_in_unit_interval(R[None, :])
        z = self.zt[0] + self.zt[1] * t
        rho2 = self.C - self.A * z * z - self.B * z
        with np.errstate(divide="ignore", invalid="ignore"):
            y = -polyval(f0, t) / polyval(f1, t)
        x = np.sqrt(np.maximum(rho2 - y * y, 0.0))
        ok = np.isfinite(y) & (rho2 - y * y >= -1e-7)
        base = np.concatenate([np.stack([x, y, z], -1)[ok], np.stack([-x, y, z], -1)[ok]])
        owner = np.repeat(idx, len(base))
        return owner, np.tile(base, (len(idx), 1))
