"""Forward projection of points with its derivative by the point (Fermat's principle)."""
from __future__ import annotations

import numpy as np

from .._checks import CatadioptricError, as_float_array
from ..cameras import CatadioptricCamera


# --------------------------------------------------------------------------- projection with derivatives
def project_with_jacobian(cam: CatadioptricCamera, points, uv_ref):
    """The image of each point nearest a reference pixel, with its derivative.

    ``points (N, 3)`` in M, ``uv_ref (N, 2)``. Returns ``uv (N, 2)``, ``G (N, 2, 3)`` (d uv / d point)
    and ``visible (N,)``: among the valid images of each point (``cam.project``) the one
    nearest ``uv_ref``; where a point has none, the nearest of its other reflection points
    (occluded or behind the camera: a continuous extension, ``visible`` False); NaN where
    the point has no reflection point in the patch at all.

    ``G`` follows from Fermat's principle: the reflection point ``r`` makes
    ``|r - c| + |r - p|`` stationary on the mirror, so ``(r, mu)`` solves
    ``w + u + mu grad Omega = 0``, ``Omega(r) = 0`` (``w``, ``u`` unit vectors from ``c`` and
    from ``p`` to ``r``); differentiating that system in ``p`` gives ``dr/dp``, and the
    pinhole gives ``d uv / dr``.
    """
    P = as_float_array(points, "points", 3, finite=False).reshape(-1, 3)
    ref = as_float_array(uv_ref, "uv_ref", 2).reshape(-1, 2)
    if len(ref) != len(P):
        raise CatadioptricError(f"uv_ref: expected one pixel per point ({len(P)}), got {len(ref)}")
    N = len(P)
    uv = np.full((N, 2), np.nan)
    G = np.full((N, 2, 3), np.nan)
    vis = np.zeros(N, dtype=bool)
    if N == 0:
        return uv, G, vis
    finite = np.all(np.isfinite(P), axis=-1)
    pr = cam.project(np.where(finite[:, None], P, 0.0))
    d2 = np.sum((pr.uv - ref[:, None, :]) ** 2, axis=-1)
    d2 = np.where(np.isfinite(d2), d2, np.inf)
    has_valid = np.any(pr.valid, axis=-1)
    key = np.where(pr.valid | ~has_valid[:, None], d2, np.inf)
    k = np.argmin(key, axis=-1)
    idx = np.arange(N)
    ok = np.isfinite(key[idx, k]) & finite
    uv[ok] = pr.uv[idx[ok], k[ok]]
    vis[ok] = pr.valid[idx[ok], k[ok]]
    if np.any(ok):
        r = pr.mirror_points[idx[ok], k[ok]]
        G[ok] = _uv_jacobian(cam, r, P[ok])
    return uv, G, vis


def _uv_jacobian(cam: CatadioptricCamera, r, p):
    """d uv / d p ``(n, 2, 3)`` at reflection points ``r (n, 3)`` of points ``p (n, 3)``."""
    m = cam.mirror
    c = cam.center
    a = r - c
    b = r - p
    la = np.linalg.norm(a, axis=-1)
    lb = np.linalg.norm(b, axis=-1)
    w = a / la[:, None]
    u = b / lb[:, None]
    g = 2.0 * m.normal(r)  # grad Omega
    mu = -np.sum((w + u) * g, axis=-1) / np.sum(g * g, axis=-1)
    eye = np.eye(3)
    Pw = (eye - w[:, :, None] * w[:, None, :]) / la[:, None, None]
    Pu = (eye - u[:, :, None] * u[:, None, :]) / lb[:, None, None]
    hess_omega = 2.0 * np.diag([1.0, 1.0, m.A])
    n = len(r)
    K = np.zeros((n, 4, 4))
    K[:, :3, :3] = Pw + Pu + mu[:, None, None] * hess_omega
    K[:, :3, 3] = g
    K[:, 3, :3] = g
    rhs = np.zeros((n, 4, 3))
    rhs[:, :3, :] = Pu  # d(grad F)/dp = -Pu, moved to the right-hand side
    try:
        dr_dp = np.linalg.solve(K, rhs)[:, :3, :]
    except np.linalg.LinAlgError:  # a degenerate point somewhere in the batch: pseudo-inverse
        dr_dp = (np.linalg.pinv(K) @ rhs)[:, :3, :]
    R = cam.R_cam_from_mirror
    X = a @ R.T
    Kp = cam.pinhole.K
    Z = X[:, 2]
    duv_dX = np.zeros((n, 2, 3))
    duv_dX[:, 0, 0] = Kp[0, 0] / Z
    duv_dX[:, 0, 1] = Kp[0, 1] / Z
    duv_dX[:, 0, 2] = -(Kp[0, 0] * X[:, 0] + Kp[0, 1] * X[:, 1]) / Z**2
    duv_dX[:, 1, 1] = Kp[1, 1] / Z
    duv_dX[:, 1, 2] = -Kp[1, 1] * X[:, 1] / Z**2
    return duv_dX @ R @ dr_dp


