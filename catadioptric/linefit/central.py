"""Central cameras: a line's interpretation plane from one image (:func:`fit_interpretation_plane`)
and the direction common to several planes (:func:`direction_from_planes`)."""
from __future__ import annotations

import numpy as np

from .._checks import CatadioptricError, as_float_array
from ..cameras import CatadioptricCamera
from ._common import check_options, check_uv, as_rng, scatter, tangent_basis
from .planes import pixel_rays_with_jacobian, plane_covariance, plane_distances, refine_plane
from .results import InterpretationPlane


def direction_from_planes(normals, normal_covs, *, covariance: bool = True):
    """The direction common to planes with unit ``normals (L, 3)`` (L >= 2) and covariances
    ``normal_covs (L, 3, 3)``: minimises ``sum (n_i . s)^2 / (s^T C_i s)`` (reweighted
    eigenvector). Returns ``(s, cov (3, 3))``, ``s`` unit (sign arbitrary); ``cov`` None without
    ``covariance``."""
    n = as_float_array(normals, "normals", 3)
    C = as_float_array(normal_covs, "normal_covs", (3, 3))
    if n.ndim != 2 or len(n) < 2 or C.shape != (len(n), 3, 3):
        raise CatadioptricError(f"normals, normal_covs: expected (L, 3) and (L, 3, 3) with L >= 2, got "
                                f"{n.shape} and {C.shape}")
    w = np.ones(len(n))
    s = None
    for _ in range(20):
        s_new = np.linalg.eigh(np.einsum("l,li,lj->ij", w, n, n))[1][:, 0]
        if s is not None and s_new @ s < 0:
            s_new = -s_new
        w = 1.0 / np.maximum(np.einsum("i,lij,j->l", s_new, C, s_new), 1e-300)
        done = s is not None and np.linalg.norm(s_new - s) < 1e-14
        s = s_new
        if done:
            break
    if not covariance:
        return s, None
    e1, e2 = tangent_basis(s)
    E = np.stack([e1, e2], axis=1)
    A = n @ E  # (L, 2): d(n_i . s) / d(tangent coordinates)
    cov = E @ np.linalg.pinv(np.einsum("l,li,lj->ij", w, A, A)) @ E.T
    return s, cov


# --------------------------------------------------------------------------- central cameras
def fit_interpretation_plane(cam, uv, *, f_scale: float = 1.0, ransac: bool = True, seed=0,
                             pixel_sigma=None, inlier_threshold=None, max_trials: int = 200,
                             directions_only: bool = False, rays=None) -> InterpretationPlane:
    """What one image of a central camera says about a 3-D line: the plane through the
    viewpoint that holds it (``normal``, unit; the line's direction is normal to it).
    ``cam``: a central :class:`CatadioptricCamera`, a :class:`~catadioptric.unified.UnifiedCamera` or a
    camera model of :mod:`catadioptric.models` (a calibration of another tool);
    with ``directions_only``, also a non-central camera, of whose rays only the directions count:
    the plane (through the rays' centre) that holds them, an approximation whose angular error is
    about the spread of the rays' origins over the line's distance (a start for exact fits).

    Pixels ``uv (M, 2)`` (M >= 3). Minimises the first-order image distance of each pixel
    to the plane's image, ``|n . d_j| / |Jd_j^T n|`` (``d_j`` the pixel's ray direction,
    ``Jd_j`` its derivative by the pixel; the model of :mod:`catadioptric.linefit.planes`), by
    reweighted eigenvector iterations, after
    RANSAC over pairs of pixels (``n = d_1 x d_2``). ``normal_cov`` from the same
    linearisation (sigma from the residuals unless ``pixel_sigma`` is given). Two or
    more parallel lines give their direction as the common normal of their planes.
    ``rays``: the pixels' rays if already computed (:func:`~catadioptric.linefit.planes.pixel_rays_with_jacobian`
    of ``cam`` and ``uv``; e.g. a slice of those of many lines' pixels, computed at once).
    """
    from ..models.base import CentralCamera
    from ..unified import UnifiedCamera

    if not isinstance(cam, (CatadioptricCamera, UnifiedCamera, CentralCamera)):
        raise CatadioptricError(f"cam: expected a CatadioptricCamera, a UnifiedCamera or a camera model of "
                                f"catadioptric.models, got {type(cam).__name__}")
    if isinstance(cam, CatadioptricCamera) and not cam.is_central and not directions_only:
        raise CatadioptricError("cam: expected a central camera (cam.is_central); a non-central camera sees the "
                                "whole line: use fit_line (or directions_only=True for the approximate plane)")
    uv = check_uv(uv, "uv", 3)
    f_scale, pixel_sigma, inlier_threshold = check_options("linear", f_scale, pixel_sigma, inlier_threshold)
    rng = as_rng(seed)
    # a pixel at the edge of the mirror's image has no ray derivative (a neighbour misses the mirror)
    if rays is None:
        rays = pixel_rays_with_jacobian(cam, uv)
    elif len(rays.uv) != len(uv):
        raise CatadioptricError(f"rays: expected the rays of the {len(uv)} pixels uv, got {len(rays.uv)}")
    valid = rays.ok
    if int(valid.sum()) < 3:
        raise CatadioptricError(f"uv: expected at least 3 pixels that see the world, got {int(valid.sum())}")
    rays = rays.take(valid)
    thr = inlier_threshold if inlier_threshold is not None else (
        3.5 * pixel_sigma if pixel_sigma is not None else 3.0 * f_scale)
    M = len(rays.d)
    inl = np.ones(M, dtype=bool)
    if ransac and M > 3:
        best, best_cost = None, np.inf
        for _ in range(int(np.ceil(max_trials / 64))):
            idx = np.argsort(rng.random((64, M)), axis=1)[:, :2]
            n = np.cross(rays.d[idx[:, 0]], rays.d[idx[:, 1]])
            nn = np.linalg.norm(n, axis=-1)
            n = n[nn > 1e-12] / nn[nn > 1e-12, None]
            if len(n) == 0:
                continue
            cost = np.sum(np.minimum(plane_distances(n, rays) ** 2, thr**2), axis=1)
            j = int(np.argmin(cost))
            if cost[j] < best_cost:
                best, best_cost = n[j], cost[j]
        if best is not None:
            inl = plane_distances(best, rays) <= thr
            if inl.sum() < 3:
                inl = np.ones(M, dtype=bool)
    n = refine_plane(rays.take(inl), iters=50, tol=1e-14)
    if ransac:  # inliers of the refined plane (threshold from a robust sigma unless given)
        r = plane_distances(n, rays)
        thr2 = thr
        if inlier_threshold is None and pixel_sigma is None:
            thr2 = 3.0 * max(f_scale, 1.2 * float(np.median(r[inl])) / 0.6745)
        new = r <= thr2
        if new.sum() >= 3 and not np.array_equal(new, inl):
            inl = new
            n = refine_plane(rays.take(inl), iters=50, tol=1e-14)
    r = plane_distances(n, rays)
    k = int(inl.sum())
    dof = k - 2
    rss = float(np.sum(r[inl] ** 2))
    sigma = pixel_sigma if pixel_sigma is not None else (float(np.sqrt(rss / dof)) if dof > 0 else float("nan"))
    cov = plane_covariance(n, rays.take(inl), sigma)
    full = scatter(valid, r, np.inf, len(uv))
    return InterpretationPlane(normal=n, viewpoint=cam.viewpoint, normal_cov=cov,
                               rms=float(np.sqrt(np.mean(r[inl] ** 2))), distances=full,
                               inliers=scatter(valid, inl, False, len(uv)))


