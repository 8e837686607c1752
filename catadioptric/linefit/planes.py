"""The plane that holds a line's rays: the model of a central image of a line
(:func:`catadioptric.linefit.fit_interpretation_plane`) and the one with which the image path's
chains become lines (:mod:`catadioptric.detect.curves`).

The image of a 3-D line is a curve. Every pixel of it back-projects to a ray meeting the line;
for a central rig all rays pass through the viewpoint, so the line and its rays lie in one
plane through it (the interpretation plane) and the rays' unit directions ``d_j`` satisfy
``n . d_j = 0`` exactly. A non-central rig's rays leave the mirror from points a few
millimetres to centimetres apart, and the line is metres away: the same relation holds to the
ratio of the two, which on the rendered benchmark views is at most 0.17 pixel over every labelled
line of 30 pixels or more (docs/detect.md). So one model serves every rig for finding which
pixels belong together: the unit normal ``n`` of the plane through the origin spanned by the
rays' directions, the distance of a pixel to it measured in the image to first order,

    r_j = |n . d_j| / |Jd_j^T n|        (Jd_j = d d_j / d uv, pixels)

For a central rig this is the exact model (:func:`catadioptric.linefit.fit_interpretation_plane`
fits it); for the image path it groups pixels, and the non-central fits
(:func:`catadioptric.linefit.fit_line`) then take the pixels grouped.
Planes from two pixels ``n = d_1 x d_2`` are the hypotheses of the robust fits; a plane is
refined by reweighted eigenvectors (minimising the sum of ``r_j^2``) and its covariance is the
first-order one, in the tangent plane of ``n``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._numeric import row_norm
from ._common import tangent_basis
from .distances import pixels_with_rays

__all__ = ["Rays", "pixel_rays_with_jacobian", "plane_distances", "refine_plane", "plane_covariance",
           "refine_planes", "plane_covariances"]


@dataclass
class Rays:
    """Unit ray directions ``d (M, 3)`` of pixels ``uv (M, 2)`` and their derivatives by the pixel
    ``Jd (M, 3, 2)``; ``ok (M,)``: the pixel sees the world and its derivative is finite."""

    uv: np.ndarray
    d: np.ndarray
    Jd: np.ndarray
    ok: np.ndarray

    def take(self, idx) -> "Rays":
        return Rays(self.uv[idx], self.d[idx], self.Jd[idx], self.ok[idx])


def pixel_rays_with_jacobian(cam, uv: np.ndarray) -> Rays:
    """The rays of pixels ``uv (M, 2)`` and their derivatives (central differences of a quarter pixel)."""
    uv = np.asarray(uv, dtype=float).reshape(-1, 2)
    if len(uv) == 0:
        return Rays(uv, np.zeros((0, 3)), np.zeros((0, 3, 2)), np.zeros(0, bool))
    px, valid = pixels_with_rays(cam, uv)
    ok = valid & np.all(np.isfinite(px.Jd), axis=(1, 2)) & np.all(np.isfinite(px.d), axis=1)
    d = np.where(ok[:, None], px.d, 0.0)
    Jd = np.where(ok[:, None, None], px.Jd, 0.0)
    return Rays(uv, d, Jd, ok)


def plane_distances(n: np.ndarray, rays: Rays) -> np.ndarray:
    """First-order image distances (pixels) of the rays to planes with unit normals ``n (H, 3)``:
    ``(H, M)`` (``(M,)`` for one normal ``(3,)``); inf where a pixel has no ray."""
    one = np.ndim(n) == 1
    n = np.atleast_2d(n)
    num = np.abs(n @ rays.d.T)
    M = len(rays.d)
    # Jd^T n of every pixel and normal as one product: (H, 3) by (3, M 2)
    den = row_norm((n @ rays.Jd.transpose(1, 0, 2).reshape(3, 2 * M)).reshape(len(n), M, 2))
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.where((den > 0) & rays.ok[None], num / den, np.inf)
    return r[0] if one else r


def refine_plane(rays: Rays, n0: np.ndarray | None = None, iters: int = 8, tol: float = 1e-13) -> np.ndarray:
    """The unit normal minimising the sum of squared first-order distances of ``rays`` (all
    assumed inliers), by reweighted smallest eigenvectors from ``n0`` (default: unweighted),
    at most ``iters`` of them, until the normal moves by less than ``tol``."""
    d, Jd = rays.d[rays.ok], rays.Jd[rays.ok]
    w = np.ones(len(d))
    if n0 is not None:
        w = 1.0 / np.maximum(row_norm(n0 @ Jd), 1e-300) ** 2
    n = n0
    for _ in range(iters):
        n_new = np.linalg.eigh((d * w[:, None]).T @ d)[1][:, 0]
        if n is not None and n_new @ n < 0:
            n_new = -n_new
        w = 1.0 / np.maximum(row_norm(n_new @ Jd), 1e-300) ** 2
        done = n is not None and np.linalg.norm(n_new - n) < tol
        n = n_new
        if done:
            break
    return n


def plane_covariance(n: np.ndarray, rays: Rays, sigma: float) -> np.ndarray:
    """First-order covariance ``(3, 3)`` of the normal ``n`` fitted to ``rays`` with pixel noise
    ``sigma``: ``E (A^T A)^-1 E^T sigma^2`` with rows ``A_j = (d_j . E) / |Jd_j^T n|``, ``E`` a basis
    of the tangent plane of ``n``."""
    d, Jd = rays.d[rays.ok], rays.Jd[rays.ok]
    e1, e2 = tangent_basis(n)
    E = np.stack([e1, e2], axis=1)
    w = 1.0 / np.maximum(row_norm(np.einsum("mki,k->mi", Jd, n)), 1e-300)
    A = (d @ E) * w[:, None]
    return E @ np.linalg.pinv(A.T @ A) @ E.T * sigma**2


def refine_planes(rays, line, mask, G, lines=None, iters: int = 50, tol: float = 1e-14):
    """:func:`refine_plane` of ``G`` lines at once (no start normal): each line's normal ``(G, 3)``
    from its rays in ``mask`` (``line (M,)``: each ray's line), ``lines (G,)``: those to refine
    (the others' rows are left NaN)."""
    active = np.ones(G, dtype=bool) if lines is None else lines.copy()
    d, Jd = rays.d, rays.Jd
    w = mask.astype(float)
    n = np.full((G, 3), np.nan)
    first = True
    for _ in range(iters):
        if not active.any():
            break
        # the sums over the rays of the lines still moving (a bin's sum runs in the rays' order either way)
        sel = active[line]
        ds, ls = d[sel], line[sel]
        dw = ds * w[sel][:, None]
        S = np.stack([np.bincount(ls, dw[:, a] * ds[:, b], G) for a in range(3) for b in range(3)], 1).reshape(G, 3, 3)
        n_new = np.linalg.eigh(S[active])[1][:, :, 0]
        if not first:
            n_new = np.where((np.sum(n_new * n[active], axis=1) < 0)[:, None], -n_new, n_new)
            done = row_norm(n_new - n[active]) < tol
        else:
            done = np.zeros(len(n_new), dtype=bool)
        n[active] = n_new
        m = mask & active[line]
        w[m] = 1.0 / np.maximum(row_norm(np.einsum("mk,mkj->mj", n[line[m]], Jd[m])), 1e-300) ** 2
        idx = np.flatnonzero(active)
        active[idx[done]] = False
        first = False
    return n


def plane_covariances(n, rays, line, mask, sigma):
    """:func:`plane_covariance` of ``G`` lines' normals ``n (G, 3)`` at once, each from its rays in
    ``mask`` (``line (M,)``: each ray's line), with pixel noise ``sigma (G,)``."""
    G = len(n)
    e1, e2 = tangent_basis(n)
    E = np.stack([e1, e2], axis=2)  # (G, 3, 2)
    nl = n[line]
    w = 1.0 / np.maximum(row_norm(np.einsum("mk,mkj->mj", nl, rays.Jd)), 1e-300)
    A = np.einsum("mi,mij->mj", rays.d, E[line]) * (w * mask)[:, None]
    AtA = np.stack([np.bincount(line, A[:, a] * A[:, b], G) for a in range(2) for b in range(2)], 1).reshape(G, 2, 2)
    return E @ np.linalg.pinv(AtA) @ E.transpose(0, 2, 1) * (sigma**2)[:, None, None]
