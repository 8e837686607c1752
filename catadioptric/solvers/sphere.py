"""Sphere solver: any camera position. Degree 4.

Every line through the centre of a sphere is an axis of symmetry, so any camera
is axial for the axis through the centre and the camera. The solver changes to
that frame, solves the axial problem (degree 4 for a sphere: Agrawal, Taguchi,
Ramalingam, ECCV 2010) over the heights the patch spans there, and keeps the
solutions inside the original patch.
"""
from __future__ import annotations

import numpy as np

from .._numeric import rowdot
from .axial import AxialSolver
from .reflection import ReflectionSolutions, gather


class SphereSolver:
    name = "sphere"
    degree = 4
    reference = "Agrawal, Taguchi, Ramalingam, ECCV 2010 (sphere, degree 4); Miraldo et al. CVPR 2018 Table 1"

    def __init__(self, A, B, C, z_min, z_max, center, scale):
        self.o = np.array([0.0, 0.0, -B / 2.0])
        self.R = float(np.sqrt(C + B * B / 4.0))
        self.z_min, self.z_max = float(z_min), float(z_max)
        v = np.asarray(center, float) - self.o
        dist = float(np.linalg.norm(v))
        n = v / dist if dist > 0 else np.array([0.0, 0.0, 1.0])
        # an orthonormal frame whose third axis points from the centre to the camera
        a = np.array([1.0, 0, 0]) if abs(n[0]) < 0.9 else np.array([0, 1.0, 0])
        e1 = np.cross(a, n)
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(n, e1)
        self.Q = np.stack([e1, e2, n])  # rows: new axes in M
        lo, hi = self._height_range(n)
        self.axial = AxialSolver(1.0, 0.0, self.R**2, lo, hi, np.array([0.0, 0.0, dist]), scale)

    @property
    def max_solutions(self) -> int:
        return self.degree

    def _height_range(self, n):
        """Range of the new height n . (r - o) over the patch of the sphere."""
        R = self.R
        vals = []
        for z in (self.z_min, self.z_max):
            zz = float(np.clip(z - self.o[2], -R, R))
            rho = np.sqrt(max(R * R - zz * zz, 0.0))
            nxy = np.hypot(n[0], n[1])
            vals += [n[2] * zz - rho * nxy, n[2] * zz + rho * nxy]
        for sgn in (1.0, -1.0):  # the points of the sphere along +-n
            if self.z_min <= self.o[2] + sgn * R * n[2] <= self.z_max:
                vals.append(sgn * R)
        lo, hi = max(min(vals), -R), min(max(vals), R)
        pad = 1e-9 * R
        return lo - pad, hi + pad

    def solve_flat(self, targets, w, *, backward=False):
        # C order whatever the caller's layout: einsum's summation order (and so the last bits) follows
        # the memory layout, and every row must round the same way in any batch
        targets = np.ascontiguousarray(targets, dtype=float)
        w = np.ascontiguousarray(np.broadcast_to(np.asarray(w, float), (len(targets),)))
        # directions scaled by a power of two to a largest component in [0.5, 1) before they are
        # rotated: exact, so ordinary ones keep their bits, and a subnormal one (|s| ~ 1e-320) no longer
        # loses its last bits to the rotation's products (0.19 px off before)
        dirs = w <= 0
        if np.any(dirs):
            m = np.max(np.abs(targets), axis=1)
            k = np.where(dirs & (m > 0) & np.isfinite(m), np.frexp(np.where(m > 0, m, 1.0))[1], 0)
            targets = np.ldexp(targets, -k[:, None])
        tf = np.where(w[:, None] > 0, rowdot(targets - self.o, self.Q.T), rowdot(targets, self.Q.T))
        owner, r, fwd = self.axial.solve_flat(tf, w, backward=backward)
        r = rowdot(r, self.Q) + self.o
        inside = (r[:, 2] >= self.z_min - 1e-12 * self.R) & (r[:, 2] <= self.z_max + 1e-12 * self.R)
        return owner[inside], r[inside], fwd[inside]

    def solve(self, targets, w, *, backward=False) -> ReflectionSolutions:
        owner, r, fwd = self.solve_flat(targets, w, backward=backward)
        return gather(len(targets), owner, r, fwd, self.degree)
