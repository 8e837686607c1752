"""Image distances from pixels to 3-D lines: exact (Gauss-Newton on each pixel's depth) and
first-order (linearised in the pixel, for RANSAC scoring)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._checks import CatadioptricError, as_float_array
from ..cameras import CatadioptricCamera
from ._common import check_uv
from .jacobian import project_with_jacobian


# --------------------------------------------------------------------------- image distances for fixed lines
def closest_depths(q, s, o, d):
    """Parameter along ``q + lambda s`` of the point closest to the ray ``o + t d``
    (broadcast; unit ``s``, ``d``)."""
    w0 = q - o
    b = np.sum(s * d, axis=-1)
    dd = np.sum(s * w0, axis=-1)
    e = np.sum(d * w0, axis=-1)
    den = np.maximum(1.0 - b * b, 1e-12)
    return (b * e - dd) / den


def depth_refine(cam, q, s, uv, lam, iters: int = 4, step_cap=None):
    """Gauss-Newton on the depth of each pixel on fixed lines: ``q, s (..., 3)``, ``uv (..., 2)``,
    ``lam (...)`` broadcast together; each step's images continued from the last step's reflection
    points (:func:`catadioptric.projection.project_from`). Returns ``lam``, ``dist`` (pixels, inf where no image),
    ``uv_fit``, ``visible``."""
    shape = np.broadcast_shapes(q.shape[:-1], s.shape[:-1], uv.shape[:-1], np.shape(lam))
    q = np.broadcast_to(q, shape + (3,)).reshape(-1, 3)
    s = np.broadcast_to(s, shape + (3,)).reshape(-1, 3)
    uvf = np.broadcast_to(uv, shape + (2,)).reshape(-1, 2)
    lam = np.broadcast_to(lam, shape).reshape(-1).copy()
    if step_cap is None:
        step_cap = np.linalg.norm(q + lam[:, None] * s, axis=-1) * 0.5 + cam.mirror.scale
    r = None
    for it in range(iters + 1):
        P = q + lam[:, None] * s
        # each step's images continued from the last step's reflection points (a step moves a
        # point along its line by a little; the search for every image where that fails)
        uvp, G, vis, r = project_with_jacobian(cam, P, uvf, mirror_points=True, start=r)
        e = uvp - uvf
        if it == iters:
            break
        J = np.einsum("nij,nj->ni", G, s)
        with np.errstate(invalid="ignore", divide="ignore"):
            step = -np.sum(J * e, axis=-1) / np.sum(J * J, axis=-1)
        step = np.where(np.isfinite(step), step, 0.0)
        lam = lam + np.clip(step, -step_cap, step_cap)
    dist = np.linalg.norm(e, axis=-1)
    dist = np.where(np.isfinite(dist), dist, np.inf)
    rs = lambda a, t=(): a.reshape(shape + t)
    return rs(lam), rs(dist), rs(uvp, (2,)), rs(vis)


def image_distances(cam: CatadioptricCamera, point, direction, uv, *, iters: int = 5):
    """Distance in pixels from each pixel ``uv (M, 2)`` to the image of the line through
    ``point`` along ``direction`` (a local minimum over the line's points, by Gauss-Newton on
    each pixel's depth from the point nearest its ray). Returns ``(distances (M,), depths (M,))``;
    inf where the pixel does not see the world or the line has no image near it."""
    if not isinstance(cam, CatadioptricCamera):
        raise CatadioptricError(f"cam: expected a CatadioptricCamera, got {type(cam).__name__}")
    q = as_float_array(point, "point", 3)
    s = as_float_array(direction, "direction", 3)
    if q.shape != (3,) or s.shape != (3,):
        raise CatadioptricError(f"point, direction: expected 3-vectors, got shapes {q.shape} and {s.shape}")
    if np.linalg.norm(s) == 0:
        raise CatadioptricError("direction: expected a non-zero vector, got zero")
    s = s / np.linalg.norm(s)
    uv = check_uv(uv, "uv", 1)
    rays = cam.backproject(uv)
    lam0 = closest_depths(q, s, np.nan_to_num(rays.origins), np.nan_to_num(rays.directions))
    lam, dist, _, _ = depth_refine(cam, q, s, uv, lam0, iters)
    dist = np.where(rays.valid, dist, np.inf)
    return dist, lam


def score_lines(cam, L, uv, o, d, iters=3):
    """Image distances ``(H, M)`` of pixels to lines ``L (H, 6)`` and the depths."""
    s = L[:, :3]
    q = np.cross(s, L[:, 3:])
    lam0 = closest_depths(q[:, None, :], s[:, None, :], o[None], d[None])
    lam, dist, _, _ = depth_refine(cam, q[:, None, :], s[:, None, :], uv[None], lam0, iters)
    return dist, lam


# --------------------------------------------------------------------------- RANSAC
@dataclass
class Pixels:
    """The pixels that see the world, their rays and the rays' derivatives by the pixel
    (``Jo``, ``Jd (M, 3, 2)``) for the linearised image distance."""

    uv: np.ndarray
    o: np.ndarray
    d: np.ndarray
    Jo: np.ndarray
    Jd: np.ndarray


def pixels_with_rays(cam, uv) -> Pixels:
    """The pixels ``uv`` with their rays and the rays' derivatives (:class:`Pixels`), and the mask of valid rays."""
    uv_f = np.asarray(uv, dtype=float)
    h = 0.25
    e = np.array([[0.0, 0.0], [h, 0.0], [-h, 0.0], [0.0, h], [0.0, -h]])
    # the pixel and its four neighbours in one back-projection (each row's ray is the one it gets alone)
    r = cam.backproject(uv_f[None] + e.reshape((5,) + (1,) * (uv_f.ndim - 1) + (2,)))
    o, d = r.origins, r.directions
    Jo = np.stack([(o[1] - o[2]) / (2 * h), (o[3] - o[4]) / (2 * h)], axis=-1)
    Jd = np.stack([(d[1] - d[2]) / (2 * h), (d[3] - d[4]) / (2 * h)], axis=-1)
    return Pixels(uv, o[0], d[0], Jo, Jd), r.valid[0]


def linear_distances(px: Pixels, L):
    """First-order image distances ``(H, M)`` from pixels to lines ``L (H, 6)``: the point ``X`` of
    the line nearest each pixel's ray, at depth ``rho`` along it, is off the ray by ``dX``;
    the pixel displacement that moves the ray's point at depth ``rho`` by ``dX`` is
    ``pinv(Jo + rho Jd) dX``. Inf where ``X`` is behind the reflection point."""
    s = L[:, None, :3]
    q = np.cross(L[:, :3], L[:, 3:])[:, None, :]
    lam = closest_depths(q, s, px.o[None], px.d[None])
    X = q + lam[..., None] * s
    v = X - px.o[None]
    rho = np.sum(v * px.d[None], axis=-1)
    dX = v - rho[..., None] * px.d[None]
    A = px.Jo[None] + rho[..., None, None] * px.Jd[None]  # (H, M, 3, 2)
    AtA = np.einsum("hmki,hmkj->hmij", A, A)
    Atb = np.einsum("hmki,hmk->hmi", A, dX)
    det = AtA[..., 0, 0] * AtA[..., 1, 1] - AtA[..., 0, 1] ** 2
    with np.errstate(invalid="ignore", divide="ignore"):
        du = (AtA[..., 1, 1] * Atb[..., 0] - AtA[..., 0, 1] * Atb[..., 1]) / det
        dv = (AtA[..., 0, 0] * Atb[..., 1] - AtA[..., 0, 1] * Atb[..., 0]) / det
        dist = np.hypot(du, dv)
    return np.where((rho > 0) & np.isfinite(dist), dist, np.inf)


