"""The joint least-squares problem of parallel lines and per-pixel depths (inverse-distance
coordinates), its robust solution, inliers and Schur-complement covariance."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.optimize import least_squares

from .._checks import CatadioptricError
from ._common import HALF_NORMAL_MEDIAN, tangent_basis, unit_vectors
from .distances import closest_depths, depth_refine
from .jacobian import project_with_jacobian
from .linear import ray_frame

__all__ = ["Problem", "FamilyPixels", "FamilyStart", "SolveOptions", "solve_family"]


# --------------------------------------------------------------------------- the joint least-squares problem
class Problem:
    """Lines sharing one direction, in inverse-distance coordinates about a centre ``x0`` (the
    point nearest all rays). Unknowns ``x = [a, b, (alpha_i, rho_i) per line, mu_j per pixel]``:

    * direction ``s = unit(s0 + a e1 + b e2)`` (``e1, e2`` orthonormal, normal to ``s0``);
    * line i: foot of the perpendicular from ``x0`` at ``x0 + u_i / rho_i``,
      ``u_i = cos(alpha_i) e1 + sin(alpha_i) e2``; ``rho_i`` is the inverse distance;
    * pixel j of line i sees ``P_j = x0 + (u_i + mu_j s) / rho_i`` (``mu_j`` is the tangent of
      the angle at ``x0`` between the perpendicular and the point).

    A near-central camera barely sees ``rho_i``: the image of a far line depends on its
    plane through ``x0`` (``alpha_i``, ``s``) and hardly on its distance. In these
    coordinates that weak direction is smooth up to ``rho -> 0`` (the line at infinity)
    instead of running off to infinity. Residual: the image of ``P_j`` (branch nearest
    ``uv_j``) minus ``uv_j``."""

    def __init__(self, cam, uv, owner, n_lines, x0, s0, q0, lam0, rho_max=np.inf):
        self.cam = cam
        self.uv = uv
        self.owner = owner
        self.L = n_lines
        self.x0c = np.asarray(x0, dtype=float)
        self.s0 = unit_vectors(np.asarray(s0, dtype=float))
        self.e1, self.e2 = tangent_basis(self.s0)
        q0 = np.asarray(q0, dtype=float).reshape(n_lines, 3)
        v = q0 - self.x0c
        along = v @ self.s0
        foot = v - along[:, None] * self.s0  # from x0 to the foot, normal to s0
        dist = np.maximum(np.linalg.norm(foot, axis=-1), 1e-9 * cam.mirror.scale)
        self.rho0 = 1.0 / dist
        self.alpha0 = np.arctan2(foot @ self.e2, foot @ self.e1)
        self.mu0 = (np.asarray(lam0, dtype=float) + along[owner]) * self.rho0[owner]
        self.N = len(uv)
        self.np = 2 + 2 * n_lines
        self.n = self.np + self.N
        self.rho_min = 1e-6 / cam.mirror.scale
        self.rho_max = float(rho_max)
        self.penalty = 2.0 * float(np.hypot(cam.pinhole.width, cam.pinhole.height))
        self._cache_x = None
        self.nfev = 0
        rows = np.repeat(np.arange(2 * self.N), 5)
        cols = np.empty((self.N, 2, 5), dtype=np.int64)
        cols[:, :, 0] = 0
        cols[:, :, 1] = 1
        cols[:, :, 2] = (2 + 2 * owner)[:, None]
        cols[:, :, 3] = (3 + 2 * owner)[:, None]
        cols[:, :, 4] = (self.np + np.arange(self.N))[:, None]
        self._rows, self._cols = rows, cols.reshape(-1)

    def x0(self):
        rho = np.minimum(np.maximum(self.rho0, 2 * self.rho_min), 0.999 * self.rho_max)
        lines = np.stack([self.alpha0, rho], axis=1).reshape(-1)
        return np.concatenate([np.zeros(2), lines, self.mu0])

    def bounds(self):
        lo = np.full(self.n, -np.inf)
        lo[3:self.np:2] = self.rho_min
        hi = np.full(self.n, np.inf)
        hi[3:self.np:2] = self.rho_max
        return lo, hi

    def _parts(self, x):
        v = self.s0 + x[0] * self.e1 + x[1] * self.e2
        nv = np.linalg.norm(v)
        s = v / nv
        al = x[2:self.np:2]
        rho = x[3:self.np:2]
        u = np.cos(al)[:, None] * self.e1 + np.sin(al)[:, None] * self.e2
        return s, nv, al, rho, u, x[self.np:]

    def unpack(self, x):
        """``(s, q (L, 3), lam (N,), nv)``: the feet of the perpendiculars and depths from them."""
        s, nv, al, rho, u, mu = self._parts(x)
        return s, self.x0c + u / rho[:, None], mu / rho[self.owner], nv

    def _eval(self, x):
        if self._cache_x is not None and np.array_equal(x, self._cache_x):
            return self._cache
        s, nv, al, rho, u, mu = self._parts(x)
        rj = rho[self.owner]
        P = self.x0c + (u[self.owner] + mu[:, None] * s) / rj[:, None]
        uvp, G, vis = project_with_jacobian(self.cam, P, self.uv)
        self.nfev += 1
        self._cache_x = x.copy()
        self._cache = (s, nv, al, rho, u, mu, P, uvp, G, vis)
        return self._cache

    def residuals(self, x):
        uvp = self._eval(x)[7]
        e = uvp - self.uv
        bad = ~np.all(np.isfinite(e), axis=-1)
        e[bad] = self.penalty
        return e.reshape(-1)

    def jac_blocks(self, x):
        """Per pixel ``(N, 2, 5)``: derivatives by a, b, alpha_i, rho_i, mu_j."""
        s, nv, al, rho, u, mu, P, uvp, G, vis = self._eval(x)
        ds_da = (self.e1 - s * (s @ self.e1)) / nv
        ds_db = (self.e2 - s * (s @ self.e2)) / nv
        rj = rho[self.owner]
        alj = al[self.owner]
        du = -np.sin(alj)[:, None] * self.e1 + np.cos(alj)[:, None] * self.e2
        dP = np.empty((self.N, 3, 5))
        dP[:, :, 0] = (mu / rj)[:, None] * ds_da
        dP[:, :, 1] = (mu / rj)[:, None] * ds_db
        dP[:, :, 2] = du / rj[:, None]
        dP[:, :, 3] = -(P - self.x0c) / rj[:, None]
        dP[:, :, 4] = s / rj[:, None]
        J = G @ dP
        J[~np.all(np.isfinite(J), axis=(1, 2))] = 0.0
        return J

    def jacobian(self, x):
        J = self.jac_blocks(x)
        M = sp.csr_matrix((J.reshape(-1), (self._rows, self._cols)), shape=(2 * self.N, self.n))
        return M

    def sparsity(self):
        return sp.csr_matrix((np.ones(len(self._rows)), (self._rows, self._cols)), shape=(2 * self.N, self.n))

    def solve(self, loss, f_scale, jac="analytic", max_nfev=150):
        kw = dict(loss=loss, f_scale=f_scale, x_scale="jac", method="trf", ftol=1e-6, xtol=1e-10, gtol=1e-10,
                  max_nfev=max_nfev, bounds=self.bounds())
        if jac == "analytic":
            kw["jac"] = self.jacobian
            kw["tr_solver"] = "lsmr"
        else:
            kw["jac"] = jac
            kw["jac_sparsity"] = self.sparsity()
            kw["tr_solver"] = "lsmr"
        res = least_squares(self.residuals, self.x0(), **kw)
        return res.x

    def schur_cov(self, x, keep):
        """``(np, np)`` inverse of the normal matrix of the line parameters after eliminating the
        depths of the pixels in ``keep`` (unit pixel variance)."""
        J = self.jac_blocks(x)[keep]
        A = np.zeros((len(J), 2, self.np))
        own = self.owner[keep]
        A[:, :, 0:2] = J[:, :, 0:2]
        idx = np.arange(len(J))
        A[idx, :, 2 + 2 * own] = J[:, :, 2]
        A[idx, :, 3 + 2 * own] = J[:, :, 3]
        b = J[:, :, 4]
        Npp = np.einsum("nki,nkj->ij", A, A)
        Atb = np.einsum("nki,nk->ni", A, b)
        D = np.sum(b * b, axis=-1)
        D = np.where(D > 0, D, np.inf)
        S = Npp - np.einsum("ni,nj->ij", Atb / D[:, None], Atb)
        # a direction the pixels do not constrain (e.g. a line coplanar with the axis of an
        # axial rig) must come out with an enormous variance, not the zero of a pseudo-inverse
        sc = np.sqrt(np.maximum(np.diag(Npp), 1e-300))
        w, V = np.linalg.eigh(0.5 * (S + S.T) / np.outer(sc, sc))
        w = np.maximum(w, 1e-15 * max(w.max(), 1e-300))
        return (V / w) @ V.T / np.outer(sc, sc)


def _canonical(s, q, lam, owner):
    """Points of the lines nearest the origin, depths shifted to match."""
    t = np.sum(q * s, axis=-1)
    return q - t[:, None] * s, lam + t[owner]


@dataclass(frozen=True)
class FamilyPixels:
    """The pixels :func:`solve_family` fits, of lines sharing one direction: the camera ``cam``,
    ``uv (N, 2)`` pixels that see the world, ``o, d (N, 3)`` their rays, ``owner (N,)`` their line
    among ``n_lines``. ``names``: the argument each line's pixels came from, for errors (None:
    ``line i``); ``x0``: the rays' centre (None: the point nearest the rays)."""

    cam: object
    uv: np.ndarray
    o: np.ndarray
    d: np.ndarray
    owner: np.ndarray
    n_lines: int
    names: list | None = None
    x0: np.ndarray | None = None


@dataclass(frozen=True)
class FamilyStart:
    """Where :func:`solve_family` starts: the ``direction (3,)``, a point of each line
    ``points (n_lines, 3)``, each pixel's depth along its line ``depths (N,)``, and the pixels of
    the first stage ``mask (N,)`` (None: all)."""

    direction: np.ndarray
    points: np.ndarray
    depths: np.ndarray
    mask: np.ndarray | None = None


@dataclass(frozen=True, kw_only=True)
class SolveOptions:
    """How :func:`solve_family` fits (:func:`~catadioptric.linefit.fit_line` documents each)."""

    #: the first stage's loss (``scipy.optimize.least_squares``), then a plain least-squares polish
    loss: str = "soft_l1"
    #: the loss's scale (pixels)
    f_scale: float = 1.0
    #: known pixel noise for the inliers and the covariance (None: estimated)
    pixel_sigma: float | None = None
    #: the inliers' largest distance to the fitted image (pixels; None: from ``pixel_sigma`` or the residuals)
    inlier_threshold: float | None = None
    #: ``"analytic"`` (Fermat's principle) or ``"2-point"``/``"3-point"`` (finite differences)
    jac: str = "analytic"
    #: the lines stay at least this far from the rays' centre (metres)
    min_distance: float = 0.0


def solve_family(pixels: FamilyPixels, start: FamilyStart, options: SolveOptions = SolveOptions()) -> dict:
    """Robust fit, inlier classification, least-squares polish on the inliers, covariance.

    ``pixels``: :class:`FamilyPixels`; ``start``: :class:`FamilyStart`; ``options``:
    :class:`SolveOptions`. The first stage (``loss``) uses the pixels of ``start.mask`` (default
    all) with depths ``start.depths``. The inliers are the pixels within the threshold of the
    fitted image (``inlier_threshold``, else ``3.5 pixel_sigma``, else ``3 max(f_scale, 1.2
    sigma_r)`` with ``sigma_r`` from the median distance); a plain least-squares polish on them is
    repeated (at most three times) until they settle. Lines stay at least ``min_distance``
    from the rays' centre ``x0``. Returns a dict."""
    cam, uv_all, o, d, owner, n_lines = pixels.cam, pixels.uv, pixels.o, pixels.d, pixels.owner, pixels.n_lines
    loss, f_scale, pixel_sigma = options.loss, options.f_scale, options.pixel_sigma
    inlier_threshold, jac, min_distance = options.inlier_threshold, options.jac, options.min_distance
    names = pixels.names or [f"line {i}" for i in range(n_lines)]
    rho_max = 1.0 / min_distance if min_distance > 0 else np.inf
    N = len(uv_all)
    use = np.ones(N, dtype=bool) if start.mask is None else np.asarray(start.mask, dtype=bool).copy()
    nfev = 0
    s = unit_vectors(np.asarray(start.direction, dtype=float))
    q = np.asarray(start.points, dtype=float).reshape(n_lines, 3)
    lam = np.asarray(start.depths, dtype=float).copy()
    xc = ray_frame(cam, o, d).x0 if pixels.x0 is None else np.asarray(pixels.x0, dtype=float)

    def solve(mask, loss_, s, q, lam):
        pb = Problem(cam, uv_all[mask], owner[mask], n_lines, xc, s, q, lam[mask], rho_max)
        x = pb.solve(loss_, f_scale, jac)
        s, q, lam_m, _ = pb.unpack(x)
        q, lam_m = _canonical(s, q, lam_m, owner[mask])
        lam = closest_depths(q[owner], s, o, d)
        lam[mask] = lam_m
        return s, q, lam, pb.nfev

    def classify(s, q, lam, solved):
        """Distances of every pixel to the fitted images (depths of the pixels outside the
        solved set refined first) and the inliers."""
        P = q[owner] + lam[:, None] * s
        uvp, _, vis = project_with_jacobian(cam, P, uv_all)
        rest = ~solved
        if rest.any():
            lam = lam.copy()
            lam[rest], _, uvp[rest], vis[rest] = depth_refine(cam, q[owner[rest]], s, uv_all[rest], lam[rest],
                                                              iters=2)
        dist = np.linalg.norm(uvp - uv_all, axis=-1)
        dist = np.where(np.isfinite(dist), dist, np.inf)
        thr = inlier_threshold
        if thr is None:
            d_in = dist[solved & np.isfinite(dist)]
            sig = float(np.median(d_in) / HALF_NORMAL_MEDIAN) if len(d_in) else f_scale
            thr = 3.5 * pixel_sigma if pixel_sigma is not None else 3.0 * max(f_scale, 1.2 * sig)
        new = dist <= thr
        for i in range(n_lines):
            if int(np.sum(new & (owner == i))) < 3:
                raise CatadioptricError(
                    f"{names[i]}: keeps fewer than 3 inlier pixels (threshold {thr:.3g} px); "
                    f"the pixels do not look like the image of one 3-D line")
        return lam, new, dist, uvp, vis, thr

    s, q, lam, k = solve(use, loss, s, q, lam)
    nfev += k
    lam, inl, dist, uvp, vis, thr = classify(s, q, lam, use)
    polished = loss == "linear" and np.array_equal(inl, use)
    for _round in range(3):  # least-squares polish on the inliers until they settle
        if polished:
            break
        s, q, lam, k = solve(inl, "linear", s, q, lam)
        nfev += k
        lam, new, dist, uvp, vis, thr = classify(s, q, lam, inl)
        polished = np.array_equal(new, inl)
        inl = new  # after the last round: the inliers of the final state
    # the chart re-centred at the solution (parameters zero) for the covariance
    pb = Problem(cam, uv_all[inl], owner[inl], n_lines, xc, s, q, lam[inl], rho_max)
    x = pb.x0()
    e = (uvp - uv_all)[inl]
    cov_unit = pb.schur_cov(x, np.ones(pb.N, dtype=bool))
    n_in = int(inl.sum())
    dof = n_in - pb.np
    rss = float(np.sum(e**2))
    if pixel_sigma is not None:
        sigma = pixel_sigma
    else:
        sigma = float(np.sqrt(rss / dof)) if dof > 0 else float("nan")
    cov = sigma**2 * cov_unit
    E = np.stack([pb.e1, pb.e2], axis=1)
    dir_cov = E @ cov[:2, :2] @ E.T
    # Pluecker (s, m) of each line by (a, b, alpha_i, rho_i) at the chart centre
    s_, _, al, rho, u, _ = pb._parts(x)
    jp = []
    for i in range(n_lines):
        qi = pb.x0c + u[i] / rho[i]
        du = -np.sin(al[i]) * pb.e1 + np.cos(al[i]) * pb.e2
        Jp = np.zeros((6, 4))
        Jp[:3, 0], Jp[:3, 1] = pb.e1, pb.e2
        Jp[3:, 0], Jp[3:, 1] = np.cross(qi, pb.e1), np.cross(qi, pb.e2)
        Jp[3:, 2] = np.cross(du / rho[i], s_)
        Jp[3:, 3] = np.cross(-u[i] / rho[i] ** 2, s_)
        sub = [0, 1, 2 + 2 * i, 3 + 2 * i]
        jp.append(Jp @ cov[np.ix_(sub, sub)] @ Jp.T)
    return dict(s=s, q=q, lam=lam, dist=dist, uv_fit=uvp, visible=vis, inliers=inl, cov=cov, dir_cov=dir_cov,
                pluecker_cov=jp, sigma=sigma, dof=dof, rss=rss, nfev=nfev, threshold=thr)


