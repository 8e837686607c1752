"""The unknowns and residuals of the two-view refinement (:mod:`catadioptric.pose.bundle`): its
parametrisation, the pixels' residuals and their Jacobians, the bounds on the lines' distances.

Unknowns, in view A's mirror frame unless said otherwise:

* the relative pose ``x_B = R x_A + t`` (``R`` updated on the left by a rotation vector ``w``);
* per family a direction ``s_f = unit(s0_f + a_f e1_f + b_f e2_f)``;
* per line, in inverse-distance coordinates about a centre ``x0`` (the point nearest view A's
  rays): the foot of its perpendicular at ``x0 + u_l / rho_l``, ``u_l = cos(alpha_l) e1 +
  sin(alpha_l) e2``, so that a far line (``rho -> 0``), which a near-central rig hardly places,
  stays a smooth parameter;
* per pixel a depth ``mu_j``: it sees ``P_j = x0 + (u_l + mu_j s_f) / rho_l`` (moved by ``R, t``
  for view B).

Residual: the image of ``P_j`` (the branch nearest the pixel) minus the pixel.
"""
from __future__ import annotations

import numpy as np

from ..linefit.jacobian import image_jacobian, project_with_jacobian
from ._kernels import pixel_jacobians
from .meetings import meeting_residuals, meeting_terms
from .rotation import exp_rotation, skew

__all__ = ["Problem", "MU_MAX"]  # used by the two-view refinement (pose.bundle)

MU_MAX = 1e3  # depths beyond 89.94 degrees from a line's perpendicular are at its vanishing points


def _basis(s):
    a = np.where((np.abs(s[..., 0]) < 0.8)[..., None], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    e1 = np.cross(a, s)
    e1 /= np.linalg.norm(e1, axis=-1, keepdims=True)
    return e1, np.cross(s, e1)


class Problem:
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
        # the pixels projected together, by camera: both views at once when they are one rig's (the
        # same bits: each point's image is found on its own), halving the projections' fixed cost
        same = cam_a is cam_b or (hasattr(cam_a, "same_geometry") and cam_a.same_geometry(cam_b))
        self.by_camera = [(np.ones(len(view), dtype=bool), cam_a)] if same else \
            [(np.asarray(view) == v, c) for v, c in ((0, cam_a), (1, cam_b))]
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
        self.owner_c = np.ascontiguousarray(owner, dtype=np.int64)
        self.fam_c = np.ascontiguousarray(self.fam, dtype=np.int64)
        self.view_b = np.ascontiguousarray(view == 1)
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

    def corner_residuals(self, R, y):
        """The meeting lines' residuals alone (:func:`catadioptric.pose.meetings.meeting_residuals`)."""
        return meeting_residuals(self, R, y)

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
        for m, cam in self.by_camera:
            if m.any():
                start = self.r_last[m] if self.warm_start and self.r_last is not None else None
                uvp, _, _, r[m] = project_with_jacobian(cam, X[m], self.uv[m], jacobian=False, mirror_points=True,
                                                        start=start)
                e[m] = uvp - self.uv[m]
        return e, (X, r, V)

    def jacobian(self, R, y, mu, state):
        """The local Jacobian ``A (N, 2, 10)`` and depth column ``b (N, 2)`` at the state of
        :meth:`residuals` for the same ``R, y, mu``: each pixel's image derivative by its point
        (:func:`catadioptric.linefit.jacobian.image_jacobian`) times the point's derivatives by the pose,
        its family's direction, its line and its depth (compiled, one pixel at a time:
        :func:`catadioptric.pose._kernels.pixel_jacobians`); zero rows where a point has no image."""
        X, r, V = state
        self.r_last = r
        s, nv, al, rho, u, that, ntv, k = self.parts(y)
        G = self._image_jacobians(r, X)
        ds_da = (self.e1 - s * np.sum(s * self.e1, 1, keepdims=True)) / nv[:, None]
        ds_db = (self.e2 - s * np.sum(s * self.e2, 1, keepdims=True)) / nv[:, None]
        e1l, e2l = self.e1[self.fam], self.e2[self.fam]
        du = -np.sin(al)[:, None] * e1l + np.cos(al)[:, None] * e2l
        dthat = np.stack([(self.f1 - that * (that @ self.f1)) / ntv, (self.f2 - that * (that @ self.f2)) / ntv],
                         axis=0)  # (2, 3)
        A = np.empty((self.N, 2, 10))
        b = np.empty((self.N, 2))
        pixel_jacobians(np.ascontiguousarray(G), np.ascontiguousarray(V), np.ascontiguousarray(mu, dtype=float),
                        self.owner_c, self.fam_c, self.view_b, float(k), np.ascontiguousarray(rho),
                        np.ascontiguousarray(du), np.ascontiguousarray(np.stack([s, ds_da, ds_db], axis=1)),
                        np.ascontiguousarray(R, dtype=float), dthat, np.ascontiguousarray(that), A, b)
        return A, b

    def _image_jacobians(self, r, X):
        """``d uv / d X (N, 2, 3)`` of each pixel's point in its own view's frame (NaN where no image)."""
        G = np.full((self.N, 2, 3), np.nan)
        for m, cam in self.by_camera:
            if m.any():
                G[m] = image_jacobian(cam, r[m], X[m])
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
        mu2 = np.clip(mu + np.clip(dmu, -cap, cap), -MU_MAX, MU_MAX)
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
