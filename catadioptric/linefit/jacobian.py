"""Forward projection of points with its derivative by the point (Fermat's principle)."""
from __future__ import annotations

import numpy as np

from .._checks import CatadioptricError, as_float_array
from ..cameras import CatadioptricCamera
from ._kernels import uv_jacobian_rows


# --------------------------------------------------------------------------- projection with derivatives
def project_with_jacobian(cam: CatadioptricCamera, points, uv_ref, *, jacobian: bool = True,
                          mirror_points: bool = False, start=None):
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
    pinhole gives ``d uv / dr``. With ``jacobian=False``, ``G`` is not computed (NaN); with
    ``mirror_points=True`` the reflection points ``r (N, 3)`` used (NaN where none) are returned
    fourth, for :func:`image_jacobian` later (an optimiser that only needs ``G`` at the steps it
    accepts). ``start (N, 3)``: reflection points of nearby points (an optimiser's last state;
    NaN rows: none) from which each image is continued (:func:`catadioptric.projection.project_from`);
    only the rows it cannot continue go through the search for every image.
    """
    P = as_float_array(points, "points", 3, finite=False).reshape(-1, 3)
    ref = as_float_array(uv_ref, "uv_ref", 2).reshape(-1, 2)
    if len(ref) != len(P):
        raise CatadioptricError(f"uv_ref: expected one pixel per point ({len(P)}), got {len(ref)}")
    N = len(P)
    uv = np.full((N, 2), np.nan)
    G = np.full((N, 2, 3), np.nan)
    vis = np.zeros(N, dtype=bool)
    r_all = np.full((N, 3), np.nan)
    if N == 0:
        return (uv, G, vis, r_all) if mirror_points else (uv, G, vis)
    rest = np.arange(N)
    if start is not None:
        from ..projection import project_from

        uv_s, r_s, ok_s = project_from(cam, P, start)
        uv[ok_s], r_all[ok_s], vis[ok_s] = uv_s[ok_s], r_s[ok_s], True
        rest = np.nonzero(~ok_s)[0]
    if len(rest):
        _search(cam, P, ref, rest, uv, vis, r_all)
    ok = np.all(np.isfinite(r_all), axis=1)
    if jacobian and np.any(ok):
        G[ok] = _uv_jacobian(cam, r_all[ok], P[ok])
    return (uv, G, vis, r_all) if mirror_points else (uv, G, vis)


def _search(cam, P_all, ref_all, rows, uv_out, vis_out, r_out):
    """:func:`project_with_jacobian`'s choice among every image, for the points of ``rows``."""
    P, ref = P_all[rows], ref_all[rows]
    N = len(rows)
    finite = np.all(np.isfinite(P), axis=-1)
    pr = cam.project(np.where(finite[:, None], P, 0.0))
    d2 = np.sum((pr.uv - ref[:, None, :]) ** 2, axis=-1)
    d2 = np.where(np.isfinite(d2), d2, np.inf)
    has_valid = np.any(pr.valid, axis=-1)
    key = np.where(pr.valid | ~has_valid[:, None], d2, np.inf)
    k = np.argmin(key, axis=-1)
    idx = np.arange(N)
    ok = np.isfinite(key[idx, k]) & finite
    uv_out[rows[ok]] = pr.uv[idx[ok], k[ok]]
    vis_out[rows[ok]] = pr.valid[idx[ok], k[ok]]
    r_out[rows[ok]] = pr.mirror_points[idx[ok], k[ok]]


def image_jacobian(cam: CatadioptricCamera, mirror_points, points) -> np.ndarray:
    """``d uv / d point (N, 2, 3)`` of points ``(N, 3)`` (M) imaged through reflection points
    ``mirror_points (N, 3)`` (as returned by :func:`project_with_jacobian`); NaN rows where either
    is NaN."""
    r = np.asarray(mirror_points, dtype=float).reshape(-1, 3)
    P = np.asarray(points, dtype=float).reshape(-1, 3)
    if len(r) != len(P):
        raise CatadioptricError(f"mirror_points: expected one per point ({len(P)}), got {len(r)}")
    G = np.full((len(P), 2, 3), np.nan)
    ok = np.all(np.isfinite(r), axis=1) & np.all(np.isfinite(P), axis=1)
    if np.any(ok):
        G[ok] = _uv_jacobian(cam, r[ok], P[ok])
    return G


def _uv_jacobian(cam: CatadioptricCamera, r, p):
    """d uv / d p ``(n, 2, 3)`` at reflection points ``r (n, 3)`` of points ``p (n, 3)``.

    Fermat's principle: ``(r, mu)`` solves ``w + u + mu grad Omega = 0``, ``Omega(r) = 0`` (``w``,
    ``u`` unit vectors from the camera's centre ``c`` and from ``p`` to ``r``); differentiated in
    ``p``, the bordered system ``[[M, g], [g^T, 0]] [dr/dp; dmu/dp] = [Pu; 0]`` with ``M = Pw + Pu +
    mu Hess(Omega)`` (``Pw``, ``Pu`` the projectors across ``w``, ``u`` over the distances, ``g =
    grad Omega``) is solved by block elimination with the closed-form inverse of the symmetric
    3 x 3 ``M``, then the pinhole gives ``d uv / d r`` (compiled, one row at a time:
    :func:`catadioptric.linefit._kernels.uv_jacobian_rows`). Where ``M`` is singular and the
    bordered system is not, that system is solved whole (:func:`_bordered_jacobian`)."""
    m = cam.mirror
    r = np.ascontiguousarray(r, dtype=float)
    p = np.ascontiguousarray(p, dtype=float)
    out = np.empty((len(r), 2, 3))
    bad = uv_jacobian_rows(r, p, np.ascontiguousarray(cam.center, dtype=float), float(m.A), float(m.B),
                           np.ascontiguousarray(cam.R_cam_from_mirror, dtype=float),
                           np.ascontiguousarray(cam.pinhole.K, dtype=float), out)
    if bad.any():
        out[bad] = _bordered_jacobian(cam, r[bad], p[bad])
    return out


def _bordered_jacobian(cam: CatadioptricCamera, r, p):
    """:func:`_uv_jacobian` by a pseudo-inverse of the whole bordered 4 x 4 system (the rows whose
    block ``M`` is singular)."""
    m = cam.mirror
    a = r - cam.center
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
    n = len(r)
    K = np.zeros((n, 4, 4))
    K[:, :3, :3] = Pw + Pu + mu[:, None, None] * (2.0 * np.diag([1.0, 1.0, m.A]))
    K[:, :3, 3] = g
    K[:, 3, :3] = g
    rhs = np.zeros((n, 4, 3))
    rhs[:, :3, :] = Pu
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
