"""Two-view refinement of a relative pose from the pixels of lines: rotation, metric translation,
family directions and lines, jointly, by minimising the pixel distances in both views.

Unknowns, in view A's mirror frame unless said otherwise:

* the relative pose ``x_B = R x_A + t`` (``R`` updated on the left by a rotation vector ``w``);
* per family a direction ``s_f = unit(s0_f + a_f e1_f + b_f e2_f)``;
* per line, in inverse-distance coordinates about a centre ``x0`` (the point nearest view A's
  rays): the foot of its perpendicular at ``x0 + u_l / rho_l``, ``u_l = cos(alpha_l) e1 +
  sin(alpha_l) e2``, so that a far line (``rho -> 0``), which a near-central rig hardly places,
  stays a smooth parameter;
* per pixel a depth ``mu_j``: it sees ``P_j = x0 + (u_l + mu_j s_f) / rho_l`` (moved by ``R, t``
  for view B).

Residual: the image of ``P_j`` (the branch nearest the pixel) minus the pixel. The depths are
eliminated in closed form at every step (each touches two residuals), so each
Levenberg-Marquardt step solves one dense system of ``6 + 2 F + 2 L`` unknowns. A robust
(Cauchy) reweighting is followed by a plain least-squares polish on the inliers, whose
inverse Schur complement gives the covariance of ``(w, t)``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._checks import CatadioptricError
from ..linefit.jacobian import project_with_jacobian
from .rotation import exp_rotation, skew

__all__ = ["TwoViewFit", "refine_two_view"]

_RAYLEIGH_MEDIAN = np.sqrt(2.0 * np.log(2.0))  # median of |e| for a 2-D Gaussian of unit sigma


@dataclass
class TwoViewFit:
    """The refined two-view geometry.

    ``R``, ``t``: ``x_B = R x_A + t`` (metres); ``cov (6, 6)``: covariance of ``(w, t)`` (left
    rotation vector, then translation). ``directions (F, 3)`` in A; ``points (L, 3)``: each
    line's point nearest the origin of A. ``sigma``: pixel noise (given, or estimated from
    the inliers), ``cost``: the robust cost ``sum rho(|e_j|^2 / sigma_cost^2)`` of the robust
    stage (comparable between candidates refined with the same ``sigma_cost``),
    ``rms_px (2,)``: inlier rms per view, ``inliers_a``, ``inliers_b`` (masks over the pixels
    given), ``n_pixels (2,)`` inliers per view, ``iterations``."""

    R: np.ndarray
    t: np.ndarray
    cov: np.ndarray
    directions: np.ndarray
    points: np.ndarray
    sigma: float
    cost: float
    rms_px: np.ndarray
    inliers_a: np.ndarray
    inliers_b: np.ndarray
    n_pixels: np.ndarray
    iterations: int


def _basis(s):
    a = np.where((np.abs(s[..., 0]) < 0.8)[..., None], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    e1 = np.cross(a, s)
    e1 /= np.linalg.norm(e1, axis=-1, keepdims=True)
    return e1, np.cross(s, e1)


class _Problem:
    def __init__(self, cam_a, cam_b, dirs0, points0, line_family, uv, owner, view, x0):
        self.cams = (cam_a, cam_b)
        self.s0 = dirs0 / np.linalg.norm(dirs0, axis=1, keepdims=True)
        self.e1, self.e2 = _basis(self.s0)
        self.F, self.L = len(dirs0), len(points0)
        self.fam = np.asarray(line_family, dtype=int)
        self.uv, self.owner, self.view = uv, owner, view
        self.N = len(uv)
        self.x0 = x0
        self.ny = 6 + 2 * self.F + 2 * self.L
        # line charts from the starting points
        s_l = self.s0[self.fam]
        v = points0 - x0
        foot = v - np.sum(v * s_l, axis=1, keepdims=True) * s_l
        dist = np.maximum(np.linalg.norm(foot, axis=1), 1e-9)
        e1l, e2l = self.e1[self.fam], self.e2[self.fam]
        self.alpha0 = np.arctan2(np.sum(foot * e2l, 1), np.sum(foot * e1l, 1))
        self.rho0 = 1.0 / dist
        self.rho_min = 1e-6 / cam_a.mirror.scale
        f = self.fam[owner]
        self.cols = np.empty((self.N, 10), dtype=np.int64)
        self.cols[:, :6] = np.arange(6)
        self.cols[:, 6] = 6 + 2 * f
        self.cols[:, 7] = 7 + 2 * f
        self.cols[:, 8] = 6 + 2 * self.F + 2 * owner
        self.cols[:, 9] = 7 + 2 * self.F + 2 * owner

    def start(self, points_at):
        """Parameters ``y`` (zeros for w, the directions' tangent coordinates) and depths ``mu``."""
        y = np.zeros(self.ny)
        y[6 + 2 * self.F::2] = self.alpha0
        y[7 + 2 * self.F::2] = np.maximum(self.rho0, 2 * self.rho_min)
        return y

    def parts(self, y):
        ab = y[6:6 + 2 * self.F].reshape(-1, 2)
        v = self.s0 + ab[:, :1] * self.e1 + ab[:, 1:] * self.e2
        nv = np.linalg.norm(v, axis=1)
        s = v / nv[:, None]
        al = y[6 + 2 * self.F::2]
        rho = y[7 + 2 * self.F::2]
        e1l, e2l = self.e1[self.fam], self.e2[self.fam]
        u = np.cos(al)[:, None] * e1l + np.sin(al)[:, None] * e2l
        return s, nv, al, rho, u

    def points(self, y, mu):
        s, _, _, rho, u = self.parts(y)
        f, l = self.fam[self.owner], self.owner
        return self.x0 + (u[l] + mu[:, None] * s[f]) / rho[l, None]

    def evaluate(self, R, t, y, mu, jac=True):
        """Residuals ``e (N, 2)`` (NaN where a point has no image), and if ``jac`` the local
        Jacobian ``A (N, 2, 10)`` (columns ``self.cols``) and the depth column ``b (N, 2)``."""
        s, nv, al, rho, u = self.parts(y)
        f, l = self.fam[self.owner], self.owner
        P = self.x0 + (u[l] + mu[:, None] * s[f]) / rho[l, None]
        e = np.full((self.N, 2), np.nan)
        G = np.full((self.N, 2, 3), np.nan)
        X = P.copy()
        inb = self.view == 1
        X[inb] = P[inb] @ R.T + t
        for v in (0, 1):
            m = self.view == v
            if m.any():
                uvp, Gv, _ = project_with_jacobian(self.cams[v], X[m], self.uv[m])
                e[m] = uvp - self.uv[m]
                G[m] = Gv
        if not jac:
            return e, None, None
        rj = rho[l]
        e1f, e2f = self.e1[f], self.e2[f]
        sf = s[f]
        nvf = nv[f]
        ds_da = (e1f - sf * np.sum(sf * e1f, 1, keepdims=True)) / nvf[:, None]
        ds_db = (e2f - sf * np.sum(sf * e2f, 1, keepdims=True)) / nvf[:, None]
        du = -np.sin(al[l])[:, None] * self.e1[f] + np.cos(al[l])[:, None] * self.e2[f]
        dP = np.empty((self.N, 3, 5))  # a, b, alpha, rho, mu
        dP[:, :, 0] = (mu / rj)[:, None] * ds_da
        dP[:, :, 1] = (mu / rj)[:, None] * ds_db
        dP[:, :, 2] = du / rj[:, None]
        dP[:, :, 3] = -(P - self.x0) / rj[:, None]
        dP[:, :, 4] = sf / rj[:, None]
        GB = G.copy()
        GB[inb] = G[inb] @ R  # d uv / d P for view B goes through R
        A = np.zeros((self.N, 2, 10))
        A[inb, :, 0:3] = G[inb] @ (-skew(P[inb] @ R.T))
        A[inb, :, 3:6] = G[inb]
        J5 = GB @ dP
        A[:, :, 6:10] = J5[:, :, :4]
        b = J5[:, :, 4]
        bad = ~np.isfinite(e).all(1) | ~np.isfinite(A).all((1, 2)) | ~np.isfinite(b).all(1)
        A[bad] = 0.0
        b[bad] = 0.0
        return e, A, b

    def apply(self, R, t, y, mu, dy, dmu):
        R2 = exp_rotation(dy[:3]) @ R
        t2 = t + dy[3:6]
        y2 = y + dy
        y2[:6] = 0.0
        rho = y2[7 + 2 * self.F::2]
        y2[7 + 2 * self.F::2] = np.maximum(rho, self.rho_min)
        return R2, t2, y2, mu + dmu


def _weights(e, sigma, c2, robust, mask):
    r2 = np.sum(e**2, axis=1) / sigma**2
    ok = np.isfinite(r2) & mask
    r2 = np.where(ok, r2, 0.0)
    w = np.where(ok, 1.0 / (1.0 + r2 / c2) if robust else 1.0, 0.0)
    cost = float(np.sum(np.where(ok, c2 * np.log1p(r2 / c2) if robust else r2, 0.0)))
    # a pixel whose point has no image costs as much as a far outlier
    cost += float(np.sum(mask & ~np.isfinite(np.sum(e**2, axis=1)))) * (c2 * np.log1p(1e4 / c2) if robust else 1e4)
    return w, cost


def _normal_equations(pb, A, b, e, w, lam):
    """Schur complement over the depths: ``S dy = -g`` and the depth back-substitution terms."""
    wA = A * w[:, None, None]
    Hmm = np.sum(b * b, axis=1) * w
    Hmm_d = Hmm * (1.0 + lam) + 1e-300
    Hym = np.einsum("nki,nk->ni", wA, b)
    gy = np.einsum("nki,nk->ni", wA, np.nan_to_num(e))
    gm = np.sum(b * np.nan_to_num(e), axis=1) * w
    Sloc = np.einsum("nki,nkj->nij", wA, A) - Hym[:, :, None] * Hym[:, None, :] / Hmm_d[:, None, None]
    rloc = gy - Hym * (gm / Hmm_d)[:, None]
    ny = pb.ny
    idx = (pb.cols[:, :, None] * ny + pb.cols[:, None, :]).reshape(-1)
    S = np.bincount(idx, weights=Sloc.reshape(-1), minlength=ny * ny).reshape(ny, ny)
    g = np.bincount(pb.cols.reshape(-1), weights=rloc.reshape(-1), minlength=ny)
    return S, g, Hym, gm, Hmm_d


def _solve_step(pb, A, b, e, w, lam):
    S, g, Hym, gm, Hmm_d = _normal_equations(pb, A, b, e, w, lam)
    d = np.diag(S).copy()
    scale = np.maximum(d, 1e-12 * max(d.max(), 1e-300))
    S_d = S + np.diag(lam * scale + 1e-15 * scale)
    try:
        dy = -np.linalg.solve(S_d, g)
    except np.linalg.LinAlgError:
        dy = -np.linalg.lstsq(S_d, g, rcond=None)[0]
    dmu = -(gm + np.sum(Hym * dy[pb.cols], axis=1)) / Hmm_d
    return dy, dmu


def _lm(pb, R, t, y, mu, sigma, c2, robust, mask, max_iter):
    e, A, b = pb.evaluate(R, t, y, mu)
    w, cost = _weights(e, sigma, c2, robust, mask)
    lam = 1e-3
    it = 0
    for it in range(1, max_iter + 1):
        improved = False
        for _ in range(8):
            dy, dmu = _solve_step(pb, A, b, e, w, lam)
            R2, t2, y2, mu2 = pb.apply(R, t, y, mu, dy, dmu)
            e2, _, _ = pb.evaluate(R2, t2, y2, mu2, jac=False)
            _, cost2 = _weights(e2, sigma, c2, robust, mask)
            if cost2 <= cost:
                improved = True
                break
            lam *= 8.0
        if not improved:
            break
        rel = (cost - cost2) / max(cost, 1e-300)
        R, t, y, mu = R2, t2, y2, mu2
        cost = cost2
        lam = max(lam / 4.0, 1e-9)
        e, A, b = pb.evaluate(R, t, y, mu)
        w, cost = _weights(e, sigma, c2, robust, mask)
        if rel < 1e-10 or np.linalg.norm(dy[:6]) < 1e-14 * (1.0 + np.linalg.norm(t)):
            break
    return R, t, y, mu, cost, it


def refine_two_view(cam_a, cam_b, R0, t0, dirs0, points0, line_family, uv_a, owner_a, uv_b, owner_b, *,
                    sigma_cost: float = 1.0, pixel_sigma: float | None = None, robust: bool = True,
                    c2: float = 9.0, max_iter: int = 50, inlier_sigmas: float = 3.5) -> TwoViewFit:
    """Refine ``x_B = R x_A + t`` and the lines jointly from the pixels of both views.

    ``dirs0 (F, 3)``: starting family directions in A; ``points0 (L, 3)``: a starting point of
    each line in A, ``line_family (L,)`` its family; ``uv_a (Na, 2)`` with ``owner_a (Na,)`` (the
    line each pixel images), likewise for B. ``sigma_cost``: the pixel scale of the robust
    stage (Cauchy, ``c2`` in units of it); ``pixel_sigma``: known pixel noise for the covariance
    (default: estimated from the inliers). Inliers after the robust stage: pixels within
    ``inlier_sigmas`` times the robust noise estimate (or ``pixel_sigma``); then a plain
    least-squares polish on them.
    """
    uv_a = np.asarray(uv_a, float).reshape(-1, 2)
    uv_b = np.asarray(uv_b, float).reshape(-1, 2)
    owner_a = np.asarray(owner_a, int).reshape(-1)
    owner_b = np.asarray(owner_b, int).reshape(-1)
    if len(uv_b) < 3:
        raise CatadioptricError(f"uv_b: expected pixels of lines seen in both views, got {len(uv_b)}")
    uv = np.concatenate([uv_a, uv_b])
    owner = np.concatenate([owner_a, owner_b])
    view = np.concatenate([np.zeros(len(uv_a), int), np.ones(len(uv_b), int)])
    ra = cam_a.backproject(uv_a)
    o, d = ra.origins[ra.valid], ra.directions[ra.valid]
    proj = np.eye(3) - d[:, :, None] * d[:, None, :]
    x0 = np.linalg.lstsq(proj.sum(0), np.einsum("nij,nj->i", proj, o), rcond=None)[0] if len(o) >= 2 else np.zeros(3)
    if not np.all(np.isfinite(x0)) or np.linalg.norm(x0) > 1e3 * cam_a.mirror.scale:
        x0 = np.mean(o, axis=0) if len(o) else np.zeros(3)
    pb = _Problem(cam_a, cam_b, np.asarray(dirs0, float), np.asarray(points0, float), line_family, uv, owner, view,
                  x0)
    R = np.asarray(R0, float)
    t = np.asarray(t0, float).copy()
    y = pb.start(None)
    # starting depths: each pixel's ray closest to its line (B's rays moved into A)
    s, _, _, rho, u = pb.parts(y)
    q = x0 + u / rho[:, None]
    rays_o = np.full((len(uv), 3), np.nan)
    rays_d = np.full((len(uv), 3), np.nan)
    rays_o[: len(uv_a)], rays_d[: len(uv_a)] = ra.origins, ra.directions
    rb = cam_b.backproject(uv_b)
    rays_o[len(uv_a):] = (rb.origins - t) @ R
    rays_d[len(uv_a):] = rb.directions @ R
    ql, sl = q[owner], s[pb.fam[owner]]
    w0 = ql - np.nan_to_num(rays_o)
    bb = np.sum(sl * np.nan_to_num(rays_d), 1)
    lam0 = (bb * np.sum(np.nan_to_num(rays_d) * w0, 1) - np.sum(sl * w0, 1)) / np.maximum(1 - bb * bb, 1e-12)
    mu = lam0 * rho[owner]
    mask = np.ones(len(uv), dtype=bool)
    R, t, y, mu, cost, it1 = _lm(pb, R, t, y, mu, sigma_cost, c2, robust, mask, max_iter)
    e, _, _ = pb.evaluate(R, t, y, mu, jac=False)
    dist = np.linalg.norm(e, axis=1)
    fin = np.isfinite(dist)
    if pixel_sigma is not None:
        thr = inlier_sigmas * pixel_sigma
    else:
        sig = float(np.median(dist[fin]) / _RAYLEIGH_MEDIAN) if fin.any() else sigma_cost
        thr = inlier_sigmas * max(sig, 1e-9 * sigma_cost)
    inl = fin & (dist <= thr)
    if inl[view == 1].sum() < 3:
        inl = fin
    R, t, y, mu, _, it2 = _lm(pb, R, t, y, mu, 1.0, c2, False, inl, max_iter)
    e, A, b = pb.evaluate(R, t, y, mu)
    dist = np.linalg.norm(e, axis=1)
    inl &= np.isfinite(dist)
    w = inl.astype(float)
    S, _, _, _, _ = _normal_equations(pb, A, b, np.nan_to_num(e), w, 0.0)
    n_in = int(inl.sum())
    dof = n_in - pb.ny  # two residuals and one depth per pixel
    rss = float(np.sum(dist[inl] ** 2))
    sigma = pixel_sigma if pixel_sigma is not None else (float(np.sqrt(rss / dof)) if dof > 0 else float("nan"))
    sc = np.sqrt(np.maximum(np.diag(S), 1e-300))
    ev, V = np.linalg.eigh(S / np.outer(sc, sc))
    ev = np.maximum(ev, 1e-15 * max(ev.max(), 1e-300))
    cov_y = (V / ev) @ V.T / np.outer(sc, sc) * sigma**2
    s, _, _, rho, u = pb.parts(y)
    q = x0 + u / rho[:, None]
    sl = s[pb.fam]
    q = q - np.sum(q * sl, 1, keepdims=True) * sl
    rms = np.array([float(np.sqrt(np.mean(dist[inl & (view == v)] ** 2))) if np.any(inl & (view == v)) else np.nan
                    for v in (0, 1)])
    return TwoViewFit(R=R, t=t, cov=cov_y[:6, :6], directions=s, points=q, sigma=sigma, cost=cost, rms_px=rms,
                      inliers_a=inl[view == 0], inliers_b=inl[view == 1],
                      n_pixels=np.array([int(np.sum(inl & (view == v))) for v in (0, 1)]), iterations=it1 + it2)
