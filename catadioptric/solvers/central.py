"""Central solver: the camera at a focus of an ellipsoid or a two-sheet hyperboloid. Degree 2.

Every reflected ray of a central configuration lies on a line through the
viewpoint V (the other focus). The reflection points of a target are therefore
where the line through V and the target (point p, or direction s) meets the
mirror: a quadratic. Both roots are candidates; the law of reflection decides
whether the reflected ray points toward or away from the target.

Reference: Baker, Nayar, IJCV 1999 (the central catadioptric configurations);
Miraldo et al. CVPR 2018 Table 1 'Central' rows (printed 4; genuine degree 2).
"""
from __future__ import annotations

import numpy as np

from .._numeric import unit
from .reflection import ACCEPT, ReflectionSolver, dedupe, reflect


class CentralSolver(ReflectionSolver):
    name = "central"
    degree = 2
    reference = "Baker & Nayar IJCV 1999; Miraldo et al. CVPR 2018 Table 1 (central, genuine degree 2)"

    def __init__(self, A, B, C, z_min, z_max, center, scale, viewpoint):
        super().__init__(A, B, C, z_min, z_max, center, scale)
        self.V = np.asarray(viewpoint, float) / self.L
        self._c_frame = self.c

    def solve_flat(self, targets, w, *, backward=False):
        targets = np.asarray(targets, dtype=float)
        N = len(targets)
        w = np.broadcast_to(np.asarray(w, float), (N,))
        fin = w > 0
        # from the viewpoint toward the target (lengths in the caller's unit: no division that overflows)
        u = unit(np.where(fin[:, None], targets - self.V * self.L, targets))
        A, B, C, V = self.A, self.B, self.C, self.V
        a = u[:, 0] ** 2 + u[:, 1] ** 2 + A * u[:, 2] ** 2
        b = 2 * (V[0] * u[:, 0] + V[1] * u[:, 1] + A * V[2] * u[:, 2]) + B * u[:, 2]
        c = V[0] ** 2 + V[1] ** 2 + A * V[2] ** 2 + B * V[2] - C
        disc = b * b - 4 * a * c
        with np.errstate(invalid="ignore", divide="ignore"):
            sq = np.sqrt(disc)
            q = -0.5 * (b + np.copysign(sq, b))
            roots = np.stack([q / a, c / q], axis=1)
        owner = np.repeat(np.arange(N), 2)
        tt = roots.reshape(-1)
        r = V + tt[:, None] * np.repeat(u, 2, axis=0)
        ok = np.isfinite(tt) & (r[:, 2] >= self.zlo - 1e-12) & (r[:, 2] <= self.zhi + 1e-12)
        owner, r = owner[ok], r[ok]
        nrm = np.stack([r[:, 0], r[:, 1], A * r[:, 2] + 0.5 * B], axis=-1)
        d = reflect(r - self.c, nrm)
        d /= np.linalg.norm(d, axis=-1, keepdims=True)
        tgt = unit(np.where(fin[owner, None], targets[owner] - r * self.L, targets[owner]))
        fwd = np.sum(d * tgt, axis=-1) > 0
        good = (np.linalg.norm(np.cross(d, tgt), axis=-1) <= ACCEPT) & (fwd | backward)
        return dedupe(owner[good], r[good] * self.L, fwd[good], self.L)
