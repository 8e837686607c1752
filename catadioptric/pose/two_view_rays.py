"""The two-view refinement's residuals as first-order image distances of the pixels' rays to their
lines: :class:`RayProblem`, the unknowns of :class:`~catadioptric.pose.two_view_problem.Problem`
without a forward projection.

A pixel's ray ``o + lam d`` (its view's frame, unit ``d``; ``Jo``, ``Jd (3, 2)``: their derivatives
by the pixel, fixed for the whole refinement) and its line ``Q + m s`` in the same frame (unit
``s``) are ``delta = n . (Q - o)`` apart along their common normal ``n = unit(d x s)``. Moving the
pixel by ``du`` moves the ray, and ``delta`` by ``g . du`` to first order, with
``g = -(Jo + lam Jd)' n`` (``lam``: the depth along the ray of its point nearest the line; the
normal's own move does not change ``delta`` to first order). The residual is the pixel's
first-order image distance to its line, ``e = delta / |g|``: the shortest pixel move that brings
its ray onto the line, to first order (for a central rig, ``|n . d| / |Jd' n|`` of the
interpretation planes, docs/linefit.md). It is zero exactly where the ray meets the line, and
within a few per cent of the exact distance to the line's image for pixels a few pixels off it
(the curve's own curvature is the second order): on the relative-pose benchmark at 2 px, the
ratio's 5th-95th percentiles 0.98-1.03 at the refinement's answer (one-off, validate/NOTES.md,
2026-11-30; tests/test_two_view_rays.py holds the second order).

The point of the line each pixel sees is not an unknown here: its depth is solved in closed form
at every evaluation (the line's point nearest the ray), so the refinement has no depths to carry,
no image to search or continue, and the trial steps' costs are exact for the state they judge,
where the image residuals' depths follow each step to first order only (a sphere's refinement
crawled through its depths' nonlinearity; validate/NOTES.md, 2026-11-29). Residual and derivative
are compiled (:func:`catadioptric.pose._kernels.first_order_residuals`,
:func:`~catadioptric.pose._kernels.first_order_jacobians`): ``delta``, ``lam``, ``n`` and ``g`` all
move with the pose and the line.
"""
from __future__ import annotations

import numpy as np

from ..linefit.distances import pixels_with_rays
from ._kernels import first_order_jacobians, first_order_residuals
from .two_view_problem import Problem

__all__ = ["RayProblem"]


class RayProblem(Problem):
    """:class:`~catadioptric.pose.two_view_problem.Problem` with first-order residuals (module
    docstring): ``e (N, 2)`` holds each pixel's signed first-order image distance in its first
    column and 0 in the second (NaN where its ray does not see the world, is parallel to its line
    or meets it behind its origin); the Jacobian's depth column is zero (each depth is solved,
    not carried). The arguments are :class:`~catadioptric.pose.two_view_problem.Problem`'s
    (``warm_start`` has nothing to continue here)."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        # each pixel's ray and its derivatives by the pixel, as the kernels take them: columns o, d,
        # Jo (2), Jd (2) of rays (N, 3, 6); NaN where the pixel has none
        self.rays = np.full((self.N, 3, 6), np.nan)
        for v, cam in enumerate(self.cams):
            m = np.asarray(self.view) == v
            if not m.any():
                continue
            px, ok = pixels_with_rays(cam, self.uv[m])
            ok = ok & np.all(np.isfinite(px.Jo), axis=(1, 2)) & np.all(np.isfinite(px.Jd), axis=(1, 2))
            idx = np.nonzero(m)[0][ok]
            self.rays[idx] = np.concatenate([px.o[ok][..., None], px.d[ok][..., None], px.Jo[ok], px.Jd[ok]], axis=2)
        self.centres = np.array([self.ca, self.cb], dtype=float)

    def residuals(self, R, y, mu):
        """Residuals ``e (N, 2)`` and the state :meth:`jacobian` needs (none: each pixel's point is
        the line's point nearest its ray, found again there; ``mu`` given is not used)."""
        s, _, _, rho, u, that, _, k = self.parts(y)
        e = np.empty((self.N, 2))
        first_order_residuals(self.rays, self.owner_c, self.fam_c, self.view_b, float(k), np.ascontiguousarray(rho),
                              np.ascontiguousarray(u), np.ascontiguousarray(s), np.ascontiguousarray(R, dtype=float),
                              np.ascontiguousarray(that), self.centres, e)
        return e, None

    def jacobian(self, R, y, mu, state):
        """``A (N, 2, 10)`` (columns ``self.cols``; row 1 zero) and the depth column ``b (N, 2)``
        (zero) at the state of :meth:`residuals`."""
        s, nv, al, rho, u, that, ntv, k = self.parts(y)
        ds_da = (self.e1 - s * np.sum(s * self.e1, 1, keepdims=True)) / nv[:, None]
        ds_db = (self.e2 - s * np.sum(s * self.e2, 1, keepdims=True)) / nv[:, None]
        e1l, e2l = self.e1[self.fam], self.e2[self.fam]
        du = -np.sin(al)[:, None] * e1l + np.cos(al)[:, None] * e2l
        dthat = np.stack([(self.f1 - that * (that @ self.f1)) / ntv, (self.f2 - that * (that @ self.f2)) / ntv])
        A = np.empty((self.N, 2, 10))
        first_order_jacobians(self.rays, self.owner_c, self.fam_c, self.view_b, float(k), np.ascontiguousarray(rho),
                              np.ascontiguousarray(u), np.ascontiguousarray(du),
                              np.ascontiguousarray(np.stack([s, ds_da, ds_db], axis=1)),
                              np.ascontiguousarray(R, dtype=float), np.ascontiguousarray(np.vstack([that, dthat])),
                              self.centres, A)
        return A, np.zeros((self.N, 2))

    def depth_column(self, R, y, state):
        """Zero: each depth is solved at every evaluation, not an unknown of the steps."""
        return np.zeros((self.N, 2))
