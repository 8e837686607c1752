"""Axial solver: the camera on the mirror's axis. Degree 6.

With the camera on the axis, the normal at a reflection point meets the axis,
so the reflection plane contains the axis and the target: after a rotation about
the axis that puts the target in the plane x = 0, the reflection point is
``(0, y, z)`` with ``y^2 + A z^2 + B z - C = 0`` and ``G(y, z) = 0``, and
``Res_y(G, y^2 + A z^2 + B z - C)`` has degree 6 in z with no spurious factor.
Its coefficients are a homogeneous quadratic in ``(p2, p3, w)``.

For vanishing points this is the paper's "general axial" row of Table 1, whose
printed degree 8 carries the spurious factor; the genuine degree is 6.
A target on the axis itself (a direction along the axis) is imaged as a circle:
two of its points, in the plane x = 0 of the mirror frame, are returned.
"""
from __future__ import annotations

import numpy as np

from .._numeric import rowdot
from .constraints import axial_resultant, reflection_G
from . import bivariate as bv
from .polynomial import deflate_linear, polyval, roots_in_unit_interval
from .reflection import ReflectionSolver, fit_homogeneous_map, map_coefficients, rotation_to_yz

_SCREEN = 1e-5


class AxialSolver(ReflectionSolver):
    name = "axial"
    degree = 6
    reference = "Miraldo et al. CVPR 2018 Table 1 'General Axial' (genuine degree 6); Agrawal et al. ECCV 2010"

    def __init__(self, A, B, C, z_min, z_max, center, scale):
        super().__init__(A, B, C, z_min, z_max, center, scale)
        self.c3 = float(self.c[2])
        self._c_frame = np.array([0.0, 0.0, self.c3])

        def poly(h3):
            h = np.concatenate([np.zeros((len(h3), 1)), h3], axis=1)
            return self._deflate(axial_resultant(self.A, self.B, self.C, self.c3, self.zt, h))

        self._poly = poly
        self._exps, self._qmap = fit_homogeneous_map(poly, 3, 2)
        Gb = reflection_G(self.A, self.B, self.C, 0.0, self.c3, self.zt, np.eye(4)[1:])
        self._gmap = np.stack([bv.y_coefficient(Gb, k, 5) for k in (2, 1, 0)], axis=1).reshape(3, 15)

    def normal_feet(self):
        """The vertices on the axis, and the circle at ``(1 - A) z = c3 + B/2`` where the camera
        ray meets the mirror along its normal (its points in the plane x = 0, where the targets are)."""
        A, B, C, c3 = self.A, self.B, self.C, self.c3
        zs = np.roots([A, B, -C]) if (A or B) else np.zeros(0)
        out = [[0.0, 0.0, z.real] for z in np.atleast_1d(zs) if abs(z.imag) <= 1e-12 * (1 + abs(z))]
        if A != 1:
            zf = (c3 + B / 2) / (1 - A)
            r2 = C - A * zf * zf - B * zf
            if r2 > 0:
                out += [[0.0, np.sqrt(r2), zf], [0.0, -np.sqrt(r2), zf]]
        return np.array(out).reshape(-1, 3)

    def _deflate(self, R):
        """Remove factors known to be spurious for this mirror (none in general)."""
        return R[..., : self.degree + 1] if np.all(R[..., self.degree + 1:] == 0) else R

    def _frame(self, h):
        cs, sn = rotation_to_yz(h[:, 0], h[:, 1])
        hr = h.copy()
        hr[:, 0] = 0.0
        hr[:, 1] = np.hypot(h[:, 0], h[:, 1])
        return hr, cs, sn

    def _candidates(self, h):
        h3 = h[:, 1:]
        Q = map_coefficients(h3, self._exps, self._qmap, self._poly)
        ridx, t = roots_in_unit_interval(Q)
        z = self.zt[0] + self.zt[1] * t
        rho2 = self.C - self.A * z * z - self.B * z
        rho = np.sqrt(np.maximum(rho2, 0.0))
        ys = np.stack([rho, -rho], axis=-1)
        G = rowdot(h3[ridx], self._gmap).reshape(-1, 3, 5)
        a, b, c = (polyval(G[:, k], t)[:, None] for k in range(3))
        Gv = a * ys**2 + b * ys + c
        # scale: the size of the terms of G (absolute coefficients), not its value at the root
        at = np.abs(t)
        Gs = sum(polyval(np.abs(G[:, k]), at)[:, None] * np.abs(ys) ** (2 - k) for k in range(3)) + 1e-300
        # keep the branch that fits best, and any within a factor of it (see general.py)
        rel = np.where((rho2 >= -1e-9)[:, None], np.abs(Gv) / Gs, np.inf)
        best = rel.min(axis=1, keepdims=True)
        keep = rel <= np.maximum(_SCREEN, 10.0 * best)
        kk = np.nonzero(keep)
        r0 = np.stack([np.zeros(len(kk[0])), ys[kk], z[kk[0]]], axis=-1)
        return ridx[kk[0]], r0


class ParaboloidSolver(AxialSolver):
    """Paraboloid (A = 0), camera on the axis: the degree-6 resultant drops to 5 for points
    and 4 for directions (the paper's Table 1 row 'Ellipsoid Axial (A = 0)', printed 6)."""

    name = "paraboloid_axial"
    degree = 5
    reference = "Miraldo et al. CVPR 2018 Table 1 (A = 0 axial; a paraboloid, genuine degree 4 for directions)"


class CylinderSolver(AxialSolver):
    """Cylinder (A = B = 0), camera on the axis: degree 2 (the paper's Table 1 prints 4)."""

    name = "cylinder_axial"
    degree = 2
    reference = "Miraldo et al. CVPR 2018 Table 1 'Cylindrical Axial' (genuine degree 2)"


class ConeSolver(AxialSolver):
    """Cone (B = C = 0), camera on the axis: the resultant is ``z^4`` (the apex, where the
    normal vanishes) times a quadratic; dividing the apex out leaves degree 2
    (the paper's Table 1 prints '4 and z = 0')."""

    name = "cone_axial"
    degree = 2
    reference = "Miraldo et al. CVPR 2018 Table 1 'Conical Axial' (genuine degree 2)"

    def _deflate(self, R):
        z_apex = -self.B / (2 * self.A)
        apex = np.broadcast_to(np.array([self.zt[0] - z_apex, self.zt[1]]), R.shape[:-1] + (2,))  # z - z_apex
        for _ in range(4):
            R = deflate_linear(R, apex)
        return R
