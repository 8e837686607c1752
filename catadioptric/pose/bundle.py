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
from ..linefit._common import _HALF_NORMAL_MEDIAN
from ..linefit.jacobian import image_jacobian, project_with_jacobian
from ._kernels import reduced_normal_equations
from .meetings import check_corners, meeting_terms
from .rotation import exp_rotation, skew

__all__ = ["TwoViewFit", "refine_two_view"]

_MU_MAX = 1e3  # depths beyond 89.94 degrees from a line's perpendicular are at its vanishing points


@dataclass
class TwoViewFit:
    """The refined two-view geometry.

    ``R``, ``t``: ``x_B = R x_A + t`` (metres); ``cov (6, 6)``: covariance of ``(w, t)`` (left
    rotation vector, then translation). ``directions (F, 3)`` in A; ``points (L, 3)``: each
    line's point nearest the origin of A. ``sigma``: pixel noise (given, or estimated from
    the inliers), ``cost``: the robust cost ``sum rho(|e_j|^2 / sigma_cost^2)`` of the robust
    stage (comparable between candidates refined with the same ``sigma_cost``),
    ``rms_px (2,)``: inlier rms per view, ``inliers_a``, ``inliers_b`` (masks over the pixels
    given), ``n_pixels (2,)`` inliers per view, ``iterations``, ``line_family (L,)``: each line's
    family. Set by :func:`~catadioptric.pose.scale.refine_far_or_free`: ``scale_held`` (the
    rotation and the scene's shape from the fit with the scene held far, the pixels not fixing
    its scale), ``far_gap`` (the far fit's robust cost minus the free one's) and ``scale_std``
    (the free fit's relative deviation of the baseline's length); nan when not compared."""

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
    line_family: np.ndarray | None = None
    scale_held: bool = False
    far_gap: float = float("nan")
    scale_std: float = float("nan")


def _basis(s):
    a = np.where((np.abs(s[..., 0]) < 0.8)[..., None], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    e1 = np.cross(a, s)
    e1 /= np.linalg.norm(e1, axis=-1, keepdims=True)
    return e1, np.cross(s, e1)


class _Problem:
    """The unknowns ``y = [w (3), tau (2), sigma (1), (a_f, b_f) per family, (alpha_l, rho~_l) per
    line]`` and one depth ``mu_j`` per pixel (module docstring). The translation between the two
    views' centres is ``t'' = exp(sigma) t^`` (``t^ = unit(t0^ + tau_1 f1 + tau_2 f2)``), so that
    ``t = t'' - R c_A + c_B``; a line's inverse distance is ``rho = rho~ exp(-sigma)``. Scaling the
    whole scene (baseline and every line together) is then a move of ``sigma`` alone: the
    direction a near-central rig barely sees is a straight line in these coordinates, not the
    curved valley of a metric ``t`` against inverse distances."""

    def __init__(self, cam_a, cam_b, dirs0, points0, line_family, uv, owner, view, centres, R0, t0, warm_start=True,
                 corners=None, corner_sigma=None):
        self.cams = (cam_a, cam_b)
        self.corners = np.zeros((0, 2), dtype=int) if corners is None else np.asarray(corners, dtype=int).reshape(-1, 2)
        self.corner_sigma = (np.ones(len(self.corners)) if corner_sigma is None
                             else np.broadcast_to(np.asarray(corner_sigma, float), (len(self.corners),)).copy())
        self.ca, self.cb = (np.asarray(c, dtype=float) for c in centres)
        self.s0 = dirs0 / np.linalg.norm(dirs0, axis=1, keepdims=True)
        self.e1, self.e2 = _basis(self.s0)
        self.F, self.L = len(dirs0), len(points0)
        self.fam = np.asarray(line_family, dtype=int)
        self.uv, self.owner, self.view = uv, owner, view
        self.N = len(uv)
        self.ny = 6 + 2 * self.F + 2 * self.L
        tt = R0 @ self.ca + np.asarray(t0, dtype=float) - self.cb
        ntt = max(float(np.linalg.norm(tt)), 1e-3 * cam_a.mirror.scale)
        self.that0 = tt / ntt if np.linalg.norm(tt) > 0 else np.array([1.0, 0.0, 0.0])
        self.f1, self.f2 = _basis(self.that0)
        self.sigma0 = float(np.log(ntt))
        # line charts from the starting points (inverse distances in units of the baseline)
        s_l = self.s0[self.fam]
        v = points0 - self.ca
        foot = v - np.sum(v * s_l, axis=1, keepdims=True) * s_l
        dist = np.maximum(np.linalg.norm(foot, axis=1), 1e-9)
        e1l, e2l = self.e1[self.fam], self.e2[self.fam]
        self.alpha0 = np.arctan2(np.sum(foot * e2l, 1), np.sum(foot * e1l, 1))
        self.rho0 = ntt / dist
        self.rho_min = 1e-6
        # nothing the mirror sees lies within it: a line's distance from c_A is at least twice the
        # mirror's size (rho <= k / d_min). A line seen in one view only is barely placed by a
        # near-central rig; unbounded, its distance can fall inside the mirror, where its points
        # reflect nowhere, their pixels lose their gradient and the line stays lost
        self.d_min = 2.0 * max(cam_a.mirror.scale, cam_b.mirror.scale)
        f = self.fam[owner]
        self.cols = np.empty((self.N, 10), dtype=np.int64)
        self.cols[:, :6] = np.arange(6)
        self.cols[:, 6] = 6 + 2 * f
        self.cols[:, 7] = 7 + 2 * f
        self.cols[:, 8] = 6 + 2 * self.F + 2 * owner
        self.cols[:, 9] = 7 + 2 * self.F + 2 * owner
        self.warm_start = bool(warm_start)
        self.r_last = None  # the reflection points of the last state the Jacobian was taken at

    def start(self):
        """Parameters ``y`` at the start (the rotation is carried separately)."""
        y = np.zeros(self.ny)
        y[5] = self.sigma0
        y[6 + 2 * self.F::2] = self.alpha0
        y[7 + 2 * self.F::2] = np.clip(self.rho0, 2 * self.rho_min, np.exp(self.sigma0) / self.d_min)
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
        tv = self.that0 + y[3] * self.f1 + y[4] * self.f2
        ntv = np.linalg.norm(tv)
        return s, nv, al, rho, u, tv / ntv, ntv, float(np.exp(y[5]))

    def corner_terms(self, R, y):
        """The meeting lines' residuals and Jacobian (:func:`catadioptric.pose.meetings.meeting_terms`)."""
        return meeting_terms(self, R, y)

    def translation(self, R, y) -> np.ndarray:
        """``t`` of ``x_B = R x_A + t``."""
        that, _, k = self.parts(y)[5:]
        return k * that - R @ self.ca + self.cb

    def points(self, y, mu):
        """The points the pixels see, in A."""
        s, _, _, rho, u, _, _, k = self.parts(y)
        f, l = self.fam[self.owner], self.owner
        return self.ca + k * (u[l] + mu[:, None] * s[f]) / rho[l, None]

    def evaluate(self, R, y, mu, jac=True):
        """Residuals ``e (N, 2)`` (NaN where a point has no image), and if ``jac`` the local
        Jacobian ``A (N, 2, 10)`` (columns ``self.cols``) and the depth column ``b (N, 2)``."""
        e, state = self.residuals(R, y, mu)
        if not jac:
            return e, None, None
        A, b = self.jacobian(R, y, mu, state)
        return e, A, b

    def residuals(self, R, y, mu):
        """Residuals ``e (N, 2)`` and the state :meth:`jacobian` needs (the points and their
        reflection points): a trial step is judged by its residuals alone. Each image is continued
        from the reflection point of the last state :meth:`jacobian` was taken at (a step moves the
        points little: Newton's method from there, :func:`catadioptric.projection.project_from`);
        the search for every image only where that fails."""
        s, nv, al, rho, u, that, ntv, k = self.parts(y)
        f, l = self.fam[self.owner], self.owner
        V = (u[l] + mu[:, None] * s[f]) / rho[l, None]  # P - c_A = k V
        inb = self.view == 1
        X = self.ca + k * V
        X[inb] = k * (V[inb] @ R.T + that) + self.cb
        e = np.full((self.N, 2), np.nan)
        r = np.full((self.N, 3), np.nan)
        for v in (0, 1):
            m = self.view == v
            if m.any():
                start = self.r_last[m] if self.warm_start and self.r_last is not None else None
                uvp, _, _, r[m] = project_with_jacobian(self.cams[v], X[m], self.uv[m], jacobian=False,
                                                        mirror_points=True, start=start)
                e[m] = uvp - self.uv[m]
        return e, (X, r, V)

    def jacobian(self, R, y, mu, state):
        """The local Jacobian ``A (N, 2, 10)`` and depth column ``b (N, 2)`` at the state of
        :meth:`residuals` for the same ``R, y, mu``."""
        X, r, V = state
        self.r_last = r
        s, nv, al, rho, u, that, ntv, k = self.parts(y)
        f, l = self.fam[self.owner], self.owner
        inb = self.view == 1
        G = self._image_jacobians(r, X)
        rj = rho[l]
        e1f, e2f = self.e1[f], self.e2[f]
        sf = s[f]
        nvf = nv[f]
        ds_da = (e1f - sf * np.sum(sf * e1f, 1, keepdims=True)) / nvf[:, None]
        ds_db = (e2f - sf * np.sum(sf * e2f, 1, keepdims=True)) / nvf[:, None]
        du = -np.sin(al[l])[:, None] * self.e1[f] + np.cos(al[l])[:, None] * self.e2[f]
        dP = np.empty((self.N, 3, 6))  # sigma, a, b, alpha, rho~, mu (in A)
        dP[:, :, 0] = k * V
        dP[:, :, 1] = (k * mu / rj)[:, None] * ds_da
        dP[:, :, 2] = (k * mu / rj)[:, None] * ds_db
        dP[:, :, 3] = k * du / rj[:, None]
        dP[:, :, 4] = -k * V / rj[:, None]
        dP[:, :, 5] = k * sf / rj[:, None]
        GB = G.copy()
        GB[inb] = G[inb] @ R  # d uv / d P for view B goes through R
        A = np.zeros((self.N, 2, 10))
        J6 = GB @ dP
        A[:, :, 5] = J6[:, :, 0]
        A[:, :, 6:10] = J6[:, :, 1:5]
        b = J6[:, :, 5]
        if inb.any():
            RV = V[inb] @ R.T
            A[inb, :, 0:3] = k * (G[inb] @ (-skew(RV)))
            dthat = np.stack([(self.f1 - that * (that @ self.f1)) / ntv, (self.f2 - that * (that @ self.f2)) / ntv],
                             axis=0)  # (2, 3)
            A[inb, :, 3:5] = k * np.einsum("nij,kj->nik", G[inb], dthat)
            A[inb, :, 5] += k * np.einsum("nij,j->ni", G[inb], that)  # the baseline scales with sigma too
        bad = ~np.isfinite(r).all(1) | ~np.isfinite(A).all((1, 2)) | ~np.isfinite(b).all(1)
        A[bad] = 0.0
        b[bad] = 0.0
        return A, b

    def _image_jacobians(self, r, X):
        """``d uv / d X (N, 2, 3)`` of each pixel's point in its own view's frame (NaN where no image)."""
        G = np.full((self.N, 2, 3), np.nan)
        for v in (0, 1):
            m = self.view == v
            if m.any():
                G[m] = image_jacobian(self.cams[v], r[m], X[m])
        return G

    def depth_column(self, R, y, state):
        """The depth column ``b (N, 2)`` of :meth:`jacobian` alone (zero where a point has no image)."""
        X, r, V = state
        s, _, _, rho, _, _, _, k = self.parts(y)
        d = k * s[self.fam[self.owner]] / rho[self.owner, None]  # d P / d mu, in A
        inb = self.view == 1
        d[inb] = d[inb] @ R.T
        b = np.einsum("nij,nj->ni", self._image_jacobians(r, X), d)
        b[~np.isfinite(b).all(1)] = 0.0
        return b

    def apply(self, R, y, mu, dy, dmu):
        """The state after a step (``dy[:3]`` rotates ``R`` on the left; the rest adds)."""
        # a depth moves at most by its own size plus one (mu is the tangent of the angle at c_A between
        # the line's perpendicular and the point) and stays within 89.94 degrees of the perpendicular:
        # an outlier pixel's nearest curve point can lie at a vanishing point, and its depth must
        # not run off to infinity on the way there
        cap = np.abs(mu) + 1.0
        mu2 = np.clip(mu + np.clip(dmu, -cap, cap), -_MU_MAX, _MU_MAX)
        R2 = exp_rotation(dy[:3]) @ R
        y2 = y + dy
        y2[:3] = 0.0
        # the baseline between a millimetre and ten kilometres: beyond, a near-central rig's barely
        # observed scale would run off along its flat valley
        y2[5] = np.clip(y2[5], np.log(1e-3), np.log(1e4))
        rho = y2[7 + 2 * self.F::2]
        y2[7 + 2 * self.F::2] = np.clip(rho, self.rho_min, np.exp(y2[5]) / self.d_min)
        return R2, y2, mu2

    def pushed_bounds(self, y, dy):
        """The bounds of :meth:`apply` that the step ``dy`` pushes against: ``(upper (L,), lower
        (L,), scale)``, lines at their nearest distance (``rho~ = exp(sigma) / d_min``) moved
        nearer, lines at ``rho_min`` moved further, the scale at a limit moved beyond it."""
        i_rho = 7 + 2 * self.F + 2 * np.arange(self.L)
        rho, d_rho = y[i_rho], dy[i_rho]
        upper = (rho >= np.exp(y[5]) / self.d_min * (1 - 1e-9)) & (d_rho - rho * dy[5] > 0)
        lower = (rho <= self.rho_min * (1 + 1e-9)) & (d_rho < 0)
        scale = bool((y[5] <= np.log(1e-3) + 1e-12 and dy[5] < 0) or (y[5] >= np.log(1e4) - 1e-12 and dy[5] > 0))
        return upper, lower, scale

    def bound_chart(self, y, held):
        """The chart of the steps that keep the ``held`` bounds (:meth:`pushed_bounds`' form):
        ``T (ny, ny)`` with ``dy = T dz``, or None when nothing is held. A line at its nearest
        distance follows the scale (``d rho~ = rho~ d sigma``); a line at ``rho_min`` and a scale
        at its limit stay."""
        upper, lower, scale = held
        if not (upper.any() or lower.any() or scale):
            return None
        i_rho = 7 + 2 * self.F + 2 * np.arange(self.L)
        T = np.eye(self.ny)
        fixed = i_rho[upper | lower]
        T[fixed, fixed] = 0.0
        if scale:
            T[5, 5] = 0.0
        else:
            T[i_rho[upper], 5] = y[i_rho[upper]]
        return T

    def jacobian_wt(self, R, y) -> np.ndarray:
        """d(w, t) / d(w, tau, sigma) ``(6, 6)`` for the covariance of ``(w, t)``."""
        that, ntv, k = self.parts(y)[5:]
        J = np.zeros((6, 6))
        J[:3, :3] = np.eye(3)
        J[3:, :3] = skew(R @ self.ca)  # t = k that - R c_A + c_B, d(-R c_A)/dw = [R c_A]_x
        J[3:, 3] = k * (self.f1 - that * (that @ self.f1)) / ntv
        J[3:, 4] = k * (self.f2 - that * (that @ self.f2)) / ntv
        J[3:, 5] = k * that
        return J


def _weights(e, sigma, c2, robust, mask):
    r2 = np.sum(e**2, axis=1) / sigma**2
    ok = np.isfinite(r2) & mask
    r2 = np.where(ok, r2, 0.0)
    w = np.where(ok, 1.0 / (1.0 + r2 / c2) if robust else 1.0, 0.0)
    cost = float(np.sum(np.where(ok, c2 * np.log1p(r2 / c2) if robust else r2, 0.0)))
    # a pixel whose point has no image costs as much as a far outlier
    cost += float(np.sum(mask & ~np.isfinite(np.sum(e**2, axis=1)))) * (c2 * np.log1p(1e4 / c2) if robust else 1e4)
    return w, cost


def _corner_system(pb, R, y, sigma, c2, robust, cmask):
    """The meeting lines' share of the normal equations and of the cost: ``(Sc, gc, cost)``, in the
    pixels' units (``S`` sums squared pixel residuals; a corner's residual is in units of its own
    deviation, so it enters times ``sigma^2``)."""
    r, J = pb.corner_terms(R, y)
    if len(r) == 0:
        return None, None, 0.0
    w, cost = _weights(r[:, None], 1.0, c2, robust, cmask)
    Jw = J * w[:, None]
    return sigma**2 * (Jw.T @ J), sigma**2 * (Jw.T @ r), cost


def _normal_equations(pb, A, b, e, w, lam):
    """Schur complement over the depths: ``S dy = -g`` and the depth back-substitution terms.

    With ``W`` the weights, per pixel ``Hmm = w b'b`` (damped: ``Hmm_d = Hmm (1 + lam)``),
    ``Hym = w A'b``, ``gm = w b'e``; its block ``w A'A - Hym Hym' / Hmm_d`` of ``S`` and
    ``w A'e - Hym gm / Hmm_d`` of ``g`` go to its columns ``pb.cols``
    (:func:`catadioptric.pose._kernels.reduced_normal_equations`, one compiled pass)."""
    return reduced_normal_equations(np.ascontiguousarray(A, dtype=float), np.ascontiguousarray(b, dtype=float),
                                    np.ascontiguousarray(e, dtype=float), np.ascontiguousarray(w, dtype=float),
                                    float(lam), pb.cols, int(pb.ny))


def _damped_solve(S, g, lam):
    """``dy`` of ``(S + lam diag) dy = -g``, Jacobi-scaled (unknowns of very different units:
    radians, metres, inverse distances); an unknown with no information does not move."""
    d = np.diag(S).copy()
    sc = np.sqrt(np.maximum(d, 1e-12 * max(d.max(), 1e-300)))
    S_n = S / np.outer(sc, sc) + np.eye(len(d)) * (lam + 1e-15)
    try:
        return -np.linalg.solve(S_n, g / sc) / sc
    except np.linalg.LinAlgError:
        return -np.linalg.lstsq(S_n, g / sc, rcond=None)[0] / sc


def _solve_step(pb, A, b, e, w, lam, y, mu, hold_scale=False, extra=(None, None)):
    """The damped Gauss-Newton step ``(dy, dmu)``. Unknowns that the step pushes against their
    bounds (:meth:`_Problem.pushed_bounds`; a depth at ``+-_MU_MAX`` pushed outwards) are held on
    them and the step solved again, until it pushes against no other: moved across and clipped
    back by :meth:`_Problem.apply`, they would leave the rest of the step inconsistent, and
    Levenberg-Marquardt would crawl. ``hold_scale``: the scene's scale (``sigma``) is held from
    the start."""
    Sc, gc = extra
    S, g, Hym, gm, Hmm_d = _normal_equations(pb, A, b, e, w, lam)
    if Sc is not None:
        S, g = S + Sc, g + gc
    held = (np.zeros(pb.L, dtype=bool), np.zeros(pb.L, dtype=bool), bool(hold_scale))
    T = pb.bound_chart(y, held)
    dy = _damped_solve(S, g, lam) if T is None else T @ _damped_solve(T.T @ S @ T, T.T @ g, lam)
    dmu = -(gm + np.sum(Hym * dy[pb.cols], axis=1)) / Hmm_d
    stuck = np.zeros(len(mu), dtype=bool)
    for _ in range(8):
        upper, lower, scale = pb.pushed_bounds(y, dy)
        held2 = (held[0] | upper, held[1] | lower, held[2] or scale)
        stuck2 = stuck | ((np.abs(mu) >= _MU_MAX * (1 - 1e-12)) & (dmu * mu > 0))
        if all(np.array_equal(p, q) for p, q in zip(held, held2)) and np.array_equal(stuck, stuck2):
            break
        if not np.array_equal(stuck, stuck2):  # a depth held: no depth column for its pixel
            S, g, Hym, gm, Hmm_d = _normal_equations(pb, A, np.where(stuck2[:, None], 0.0, b), e, w, lam)
            if Sc is not None:
                S, g = S + Sc, g + gc
        held, stuck = held2, stuck2
        T = pb.bound_chart(y, held)
        dy = _damped_solve(S, g, lam) if T is None else T @ _damped_solve(T.T @ S @ T, T.T @ g, lam)
        dmu = np.where(stuck, 0.0, -(gm + np.sum(Hym * dy[pb.cols], axis=1)) / Hmm_d)
    return dy, dmu


def _depth_step(mu, e, b):
    """Each pixel's depth after one Gauss-Newton step on it alone (residuals ``e``, depth column
    ``b``), moved at most by its own size plus one and kept within ``+-_MU_MAX``."""
    bb = np.sum(b * b, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        dmu = np.where(bb > 0, -np.sum(b * np.nan_to_num(e), axis=1) / bb, 0.0)
    cap = np.abs(mu) + 1.0
    return np.clip(mu + np.clip(dmu, -cap, cap), -_MU_MAX, _MU_MAX)


def _settle_depths(pb, R, y, mu):
    """One Gauss-Newton step on each pixel's depth alone (the other unknowns fixed), before the joint
    steps: the depths are the most nonlinear unknowns (a pixel near a vanishing point moves little
    with its depth). Returns ``(mu, e, A, b)`` at the new depths."""
    e, A, b = pb.evaluate(R, y, mu)
    mu = _depth_step(mu, e, b)
    e, A, b = pb.evaluate(R, y, mu)
    return mu, e, A, b


def _trial(pb, R, y, mu, settle):
    """A trial state's residuals and the state :meth:`_Problem.jacobian` needs, ``(mu, e, state)``.
    With ``settle``, each pixel's depth is first moved by one Gauss-Newton step on its own
    (:func:`_depth_step`) at the trial's other unknowns: the joint step moves each depth only as
    far as its linearisation says, and the linearisation is poor (the image of a point moves along
    its curve nonlinearly with its depth). Judged at the depths it left, a step that moves the
    lines' directions or the scene's scale is rejected at small damping and Levenberg-Marquardt
    zig-zags along a near-central rig's flat scale (a variable-projection step on the depths)."""
    e, state = pb.residuals(R, y, mu)
    if settle:
        mu = _depth_step(mu, e, pb.depth_column(R, y, state))
        e, state = pb.residuals(R, y, mu)
    return mu, e, state


def _lm(pb, R, y, mu, sigma, c2, robust, mask, max_iter, tol_chi2, settle=False, hold_scale=False, cmask=None):
    """Levenberg-Marquardt. The damping falls tenfold after each accepted step, down to 1e-15: the
    flat direction of a near-central rig (the scene's scale) has an eigenvalue many orders below
    the diagonal it is damped with, and a damping that stays near 1e-3 would stall along it.
    Stops when a step lowers the cost (chi-square units: residuals over ``sigma``) by less than
    ``tol_chi2``: along that flat direction the steps go on lowering the cost by thousandths of a
    unit, a difference the pixels cannot tell apart, and used to run to ``max_iter``. ``settle``:
    each trial's depths re-solved before it is judged (:func:`_trial`); ``hold_scale``: the scene's
    scale held (:func:`_solve_step`)."""
    if cmask is None:
        cmask = np.ones(len(pb.corners), dtype=bool)
    mu, e, A, b = _settle_depths(pb, R, y, mu)
    w, cost = _weights(e, sigma, c2, robust, mask)
    Sc, gc, cc = _corner_system(pb, R, y, sigma, c2, robust, cmask)
    cost += cc
    lam = 1e-5
    it = 0
    for it in range(1, max_iter + 1):
        improved = False
        for _ in range(12):
            dy, dmu = _solve_step(pb, A, b, e, w, lam, y, mu, hold_scale, (Sc, gc))
            R2, y2, mu2 = pb.apply(R, y, mu, dy, dmu)
            mu2, e2, state2 = _trial(pb, R2, y2, mu2, settle)
            _, cost2 = _weights(e2, sigma, c2, robust, mask)
            cost2 += _corner_system(pb, R2, y2, sigma, c2, robust, cmask)[2]
            if cost2 <= cost:
                improved = True
                break
            lam *= 10.0
        if not improved:
            break
        rel = (cost - cost2) / max(cost, 1e-300)
        cost_before = cost
        R, y, mu, e = R2, y2, mu2, e2
        A, b = pb.jacobian(R, y, mu, state2)
        lam = max(lam / 10.0, 1e-15)
        w, cost = _weights(e, sigma, c2, robust, mask)
        Sc, gc, cc = _corner_system(pb, R, y, sigma, c2, robust, cmask)
        cost += cc
        if rel < 1e-10 or cost_before - cost < tol_chi2:
            break
    return R, y, mu, cost, it


def refine_two_view(cam_a, cam_b, R0, t0, dirs0, points0, line_family, uv_a, owner_a, uv_b, owner_b, *,
                    centres=None, sigma_cost: float = 1.0, pixel_sigma: float | None = None, robust: bool = True,
                    c2: float = 9.0, max_iter: int = 50, inlier_sigmas: float = 3.5,
                    tol_chi2: float = 0.01, warm_start: bool = True, settle_depths: bool = False,
                    hold_scale: bool = False, release_scale: float = 0.05, corners=None,
                    corner_sigma=None) -> TwoViewFit:
    """Refine ``x_B = R x_A + t`` and the lines jointly from the pixels of both views.

    ``dirs0 (F, 3)``: starting family directions in A; ``points0 (L, 3)``: a starting point of
    each line in A, ``line_family (L,)`` its family; ``uv_a (Na, 2)`` with ``owner_a (Na,)`` (the
    line each pixel images), likewise for B. ``centres``: ``(c_A, c_B)``, each view's point nearest
    its rays (default: from the pixels' rays). ``sigma_cost``: the pixel scale of the robust
    stage (Cauchy, ``c2`` in units of it); ``pixel_sigma``: known pixel noise for the covariance
    (default: estimated from the inliers). Inliers after the robust stage: pixels within
    ``inlier_sigmas`` times the robust noise estimate (or ``pixel_sigma``); then a plain
    least-squares polish on them. Each stage stops when a step lowers its cost by less than
    ``tol_chi2`` (chi-square units); the robust stage after at most ``max_iter`` steps, the polish
    when the two have taken ``2 max_iter`` (with exact pixels the robust stage's cost, in units of
    a floor of ``sigma_cost``, stops early and the polish goes on to the last digits).
    ``warm_start``: each step's images continued from the last accepted state's reflection points
    (:func:`catadioptric.projection.project_from`); False: every image searched anew each time
    (slower: 1.32x the time over 8 benchmark draws at 2 px, ``bench/bench_refinement.py --cold``;
    the same minimum, though along a near-central rig's flat scale the two may stop apart: 0.172
    and 0.195 degree on sphere pair 1, equal to 1e-3 degree on the other 7). ``settle_depths``:
    each trial step judged at its depths re-solved (:func:`_trial`); its rotations are not told
    apart from the default's on the benchmark (160 draws at 1 and 2 px: better in 75, Wilcoxon
    p = 0.19) and it takes 0.99-1.74x the time (``bench/bench_refinement.py --settle``), so off by
    default.

    ``corners (K, 2)``: pairs of lines (indices into ``points0``, of different families) whose
    meeting rays were inliers of stage 1's translation
    (:func:`~catadioptric.pose.central.translation_direction_from_crossings`), each with the
    deviation ``corner_sigma (K,)`` of its epipolar residual there: the rays from each view's
    centre that meet both lines must lie in one plane with the baseline
    (:meth:`_Problem.corner_terms`), robust in the first stage, kept in the polish while within
    ``inlier_sigmas`` of deviations that follow the pixels' noise (exact pixels: rays that passed
    stage 1's threshold without their lines meeting are then left out). The lines alone tell a
    near-central rig's translation direction poorly; on the benchmark's first 20 hyperbolic pairs
    at 2 px its median error fell from 2.2 to 0.7 degree with them. The ``cost`` reported is then
    the pixels' alone (candidates with different meetings are ranked by their pixels).

    ``hold_scale``: both stages hold the scene's scale (the baseline's length with every line's
    distance) where ``t0`` puts it, and free it after the polish only if the pixels fix it
    (deviation of its logarithm below ``release_scale``). :func:`~catadioptric.pose.relative_pose`
    holds it through :func:`~catadioptric.pose.scale.refine_far_or_free`, with the scene moved
    far away and ``release_scale=0``, and compares that fit with the free one. Held where the
    start's scale search put it (mostly a bound of its range, 0.25 or 64 m) it gave the
    hyperbolic pairs 0-19 at 2 px 0.143 degree (0.291 free), but on the box scene of
    tests/test_relative_pose.py at 1 px, held at 64 m, 1.24 degree (0.07 free).
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
    if centres is None:
        centres = (_rays_centre(cam_a, uv_a), _rays_centre(cam_b, uv_b))
    corners, corner_sigma = check_corners(corners, corner_sigma, np.asarray(line_family, int).reshape(-1))
    R = np.asarray(R0, float)
    pb = _Problem(cam_a, cam_b, np.asarray(dirs0, float), np.asarray(points0, float), line_family, uv, owner, view,
                  centres, R, t0, warm_start, corners, corner_sigma)
    y = pb.start()
    # starting depths: each pixel's ray closest to its line (B's rays moved into A)
    s, _, _, rho, u, _, _, k = pb.parts(y)
    q = pb.ca + k * u / rho[:, None]
    t = pb.translation(R, y)
    ra, rb = cam_a.backproject(uv_a), cam_b.backproject(uv_b)
    rays_o = np.concatenate([ra.origins, (rb.origins - t) @ R])
    rays_d = np.concatenate([ra.directions, rb.directions @ R])
    ql, sl = q[owner], s[pb.fam[owner]]
    rays_o, rays_d = np.nan_to_num(rays_o), np.nan_to_num(rays_d)
    w0 = ql - rays_o
    bb = np.sum(sl * rays_d, 1)
    lam0 = (bb * np.sum(rays_d * w0, 1) - np.sum(sl * w0, 1)) / np.maximum(1 - bb * bb, 1e-12)
    mu = np.clip(lam0 * rho[owner] / k, -_MU_MAX, _MU_MAX)
    mask = np.ones(len(uv), dtype=bool)
    R, y, mu, cost, it1 = _lm(pb, R, y, mu, sigma_cost, c2, robust, mask, max_iter, tol_chi2, settle_depths,
                              hold_scale)
    e, _, _ = pb.evaluate(R, y, mu, jac=False)
    if len(pb.corners):
        cost = _weights(e, sigma_cost, c2, robust, mask)[1]
    dist = np.linalg.norm(e, axis=1)
    fin = np.isfinite(dist)
    if pixel_sigma is not None:
        noise = pixel_sigma
    else:
        sig = float(np.median(dist[fin]) / _HALF_NORMAL_MEDIAN) if fin.any() else sigma_cost
        noise = max(sig, 1e-9 * sigma_cost)
    # the meetings' deviations follow the pixels' noise where it is below the robust stage's scale
    # (exact pixels: the rays that passed stage 1's threshold without meeting are then outliers)
    pb.corner_sigma = pb.corner_sigma * min(1.0, noise / sigma_cost)
    cmask = np.abs(pb.corner_terms(R, y)[0]) <= inlier_sigmas
    inl = fin & (dist <= inlier_sigmas * noise)
    if inl[view == 1].sum() < 3:
        inl = fin
    # with exact pixels the polish goes on to the last digits
    tol_polish = tol_chi2 * min(1.0, noise / sigma_cost) ** 2
    R, y, mu, _, it2 = _lm(pb, R, y, mu, noise, c2, False, inl, 2 * max_iter - it1, tol_polish, settle_depths,
                           hold_scale, cmask)
    S, sigma, dist, inl = _information(pb, R, y, mu, inl, cmask, c2, pixel_sigma)
    cov_y = _covariance(S, sigma)
    if hold_scale and np.sqrt(cov_y[5, 5]) < release_scale:
        # the pixels fix the scale: freed, where Levenberg-Marquardt no longer crawls along a valley
        R, y, mu, _, it3 = _lm(pb, R, y, mu, noise, c2, False, inl, 2 * max_iter, tol_polish, settle_depths,
                               False, cmask)
        it2 += it3
        S, sigma, dist, inl = _information(pb, R, y, mu, inl, cmask, c2, pixel_sigma)
        cov_y = _covariance(S, sigma)
    Jwt = pb.jacobian_wt(R, y)
    cov = Jwt @ cov_y[:6, :6] @ Jwt.T
    s, _, _, rho, u, _, _, k = pb.parts(y)
    q = pb.ca + k * u / rho[:, None]
    sl = s[pb.fam]
    q = q - np.sum(q * sl, 1, keepdims=True) * sl
    rms = np.array([float(np.sqrt(np.mean(dist[inl & (view == v)] ** 2))) if np.any(inl & (view == v)) else np.nan
                    for v in (0, 1)])
    return TwoViewFit(R=R, t=pb.translation(R, y), cov=cov, directions=s, points=q, sigma=sigma, cost=cost,
                      rms_px=rms, inliers_a=inl[view == 0], inliers_b=inl[view == 1],
                      n_pixels=np.array([int(np.sum(inl & (view == v))) for v in (0, 1)]), iterations=it1 + it2,
                      line_family=pb.fam.copy())


def _information(pb, R, y, mu, inl, cmask, c2, pixel_sigma):
    """The information ``S`` on the unknowns at a state (pixels: the inliers ``inl`` still imaged;
    meetings: ``cmask``), the pixel noise (given, or from the residuals), each pixel's distance and
    the inliers kept."""
    e, A, b = pb.evaluate(R, y, mu)
    dist = np.linalg.norm(e, axis=1)
    inl = inl & np.isfinite(dist)
    S, _, _, _, _ = _normal_equations(pb, A, b, np.nan_to_num(e), inl.astype(float), 0.0)
    dof = int(inl.sum()) - pb.ny  # two residuals and one depth per pixel
    rss = float(np.sum(dist[inl] ** 2))
    sigma = pixel_sigma if pixel_sigma is not None else (float(np.sqrt(rss / dof)) if dof > 0 else float("nan"))
    Sc = _corner_system(pb, R, y, sigma, c2, False, cmask)[0]
    if Sc is not None and np.isfinite(sigma):
        S = S + Sc
    return S, sigma, dist, inl


def _covariance(S, sigma):
    """Inverse of the information on the unknowns the pixels see, times ``sigma^2``; an unknown they
    do not see at all (zero information) gets an infinite variance, one they barely see an
    enormous one."""
    seen = np.diag(S) > 0
    cov_y = np.full(S.shape, np.nan)
    np.fill_diagonal(cov_y, np.inf)
    sc = np.sqrt(np.diag(S)[seen])
    ev, V = np.linalg.eigh(S[np.ix_(seen, seen)] / np.outer(sc, sc))
    ev = np.maximum(ev, 1e-15 * max(ev.max(), 1e-300))
    cov_y[np.ix_(seen, seen)] = (V / ev) @ V.T / np.outer(sc, sc) * sigma**2
    return cov_y


def _rays_centre(cam, uv) -> np.ndarray:
    """The point nearest the rays of pixels ``uv``."""
    r = cam.backproject(uv)
    o, d = r.origins[r.valid], r.directions[r.valid]
    if len(o) < 2:
        return np.zeros(3)
    P = np.eye(3) - d[:, :, None] * d[:, None, :]
    c = np.linalg.lstsq(P.sum(0), np.einsum("nij,nj->i", P, o), rcond=None)[0]
    return c if np.all(np.isfinite(c)) and np.linalg.norm(c) < 1e3 * cam.mirror.scale else np.mean(o, axis=0)
