"""The compiled inner loop of the forward projection's derivative (numba), float64, no fast-math,
one row at a time, compiled once per machine and cached, like :mod:`catadioptric.solvers._kernels`:

* :func:`uv_jacobian_rows`: ``d uv / d p`` of points imaged through their reflection points, the
  loop form of :func:`catadioptric.linefit.jacobian._uv_jacobian`, which documents it (Fermat's
  principle differentiated, a bordered 3 x 3 system solved by block elimination with a cofactor
  inverse, then the pinhole). The same formulas in the same order; sums run over their terms in
  index order.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["uv_jacobian_rows"]


@njit(cache=True, nogil=True, error_model="numpy")
def uv_jacobian_rows(r, p, c, mA, mB, Rm, K, out):
    """``out[n] = d uv / d p (2, 3)`` at reflection point ``r[n]`` of point ``p[n]``, for a camera at
    ``c`` looking through ``Rm`` (``R_cam_from_mirror``) with intrinsics ``K`` at a mirror
    ``x^2 + y^2 + mA z^2 + mB z + ... = 0``. Returns a mask of the rows whose bordered system's
    block ``M`` was singular (their ``out`` is not finite; the caller solves them otherwise)."""
    n_rows = r.shape[0]
    bad = np.zeros(n_rows, dtype=np.bool_)
    M = np.empty((3, 3))
    Pu = np.empty((3, 3))
    Mi = np.empty((3, 3))
    MiPu = np.empty((3, 3))
    dr = np.empty((3, 3))
    a = np.empty(3)
    w = np.empty(3)
    u = np.empty(3)
    g = np.empty(3)
    Mg = np.empty(3)
    gM = np.empty(3)
    hd = np.empty(3)
    X = np.empty(3)
    D = np.empty((2, 3))
    DR = np.empty((2, 3))
    for n in range(n_rows):
        for i in range(3):
            a[i] = r[n, i] - c[i]
            u[i] = r[n, i] - p[n, i]
        la = math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])
        lb = math.sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2])
        for i in range(3):
            w[i] = a[i] / la
            u[i] = u[i] / lb
        g[0] = 2.0 * r[n, 0]
        g[1] = 2.0 * r[n, 1]
        g[2] = 2.0 * (mA * r[n, 2] + 0.5 * mB)
        mu = -((w[0] + u[0]) * g[0] + (w[1] + u[1]) * g[1] + (w[2] + u[2]) * g[2]) / \
            (g[0] * g[0] + g[1] * g[1] + g[2] * g[2])
        hd[0] = 2.0
        hd[1] = 2.0
        hd[2] = 2.0 * mA
        for i in range(3):
            for j in range(3):
                e = 1.0 if i == j else 0.0
                pw = (e - w[i] * w[j]) / la
                Pu[i, j] = (e - u[i] * u[j]) / lb
                M[i, j] = (pw + Pu[i, j]) + mu * (hd[i] if i == j else 0.0)
        # cofactor inverse of M
        c00 = M[1, 1] * M[2, 2] - M[1, 2] * M[2, 1]
        c01 = M[0, 2] * M[2, 1] - M[0, 1] * M[2, 2]
        c02 = M[0, 1] * M[1, 2] - M[0, 2] * M[1, 1]
        c10 = M[1, 2] * M[2, 0] - M[1, 0] * M[2, 2]
        c11 = M[0, 0] * M[2, 2] - M[0, 2] * M[2, 0]
        c12 = M[0, 2] * M[1, 0] - M[0, 0] * M[1, 2]
        c20 = M[1, 0] * M[2, 1] - M[1, 1] * M[2, 0]
        c21 = M[0, 1] * M[2, 0] - M[0, 0] * M[2, 1]
        c22 = M[0, 0] * M[1, 1] - M[0, 1] * M[1, 0]
        det = M[0, 0] * c00 + M[0, 1] * c10 + M[0, 2] * c20
        Mi[0, 0], Mi[0, 1], Mi[0, 2] = c00 / det, c01 / det, c02 / det
        Mi[1, 0], Mi[1, 1], Mi[1, 2] = c10 / det, c11 / det, c12 / det
        Mi[2, 0], Mi[2, 1], Mi[2, 2] = c20 / det, c21 / det, c22 / det
        for i in range(3):
            Mg[i] = Mi[i, 0] * g[0] + Mi[i, 1] * g[1] + Mi[i, 2] * g[2]
        gMg = g[0] * Mg[0] + g[1] * Mg[1] + g[2] * Mg[2]
        for i in range(3):
            for j in range(3):
                MiPu[i, j] = Mi[i, 0] * Pu[0, j] + Mi[i, 1] * Pu[1, j] + Mi[i, 2] * Pu[2, j]
        for j in range(3):
            gM[j] = (g[0] * MiPu[0, j] + g[1] * MiPu[1, j] + g[2] * MiPu[2, j]) / gMg
        finite = True
        for i in range(3):
            for j in range(3):
                dr[i, j] = MiPu[i, j] - Mg[i] * gM[j]
                if not math.isfinite(dr[i, j]):
                    finite = False
        if not finite:
            bad[n] = True
            for i in range(2):
                for j in range(3):
                    out[n, i, j] = np.nan
            continue
        # the pinhole: d uv / d X_cam, then through R_cam_from_mirror
        for i in range(3):
            X[i] = Rm[i, 0] * a[0] + Rm[i, 1] * a[1] + Rm[i, 2] * a[2]
        Z = X[2]
        D[0, 0] = K[0, 0] / Z
        D[0, 1] = K[0, 1] / Z
        D[0, 2] = -(K[0, 0] * X[0] + K[0, 1] * X[1]) / (Z * Z)
        D[1, 0] = 0.0
        D[1, 1] = K[1, 1] / Z
        D[1, 2] = -K[1, 1] * X[1] / (Z * Z)
        for i in range(2):
            for j in range(3):
                DR[i, j] = D[i, 0] * Rm[0, j] + D[i, 1] * Rm[1, j] + D[i, 2] * Rm[2, j]
        for i in range(2):
            for j in range(3):
                out[n, i, j] = DR[i, 0] * dr[0, j] + DR[i, 1] * dr[1, j] + DR[i, 2] * dr[2, j]
    return bad
