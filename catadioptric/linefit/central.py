"""Central cameras: a line's interpretation plane from one image (:func:`fit_interpretation_plane`)
and the direction common to several planes (:func:`direction_from_planes`)."""
from __future__ import annotations

import numpy as np

from .._checks import CatadioptricError, as_float_array
from ..cameras import CatadioptricCamera
from ._common import check_options, check_uv, as_rng, scatter, tangent_basis
from .._numeric import cross, row_norm
from .planes import Rays, pixel_rays_with_jacobian, plane_covariances, plane_distances, refine_planes
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
    of ``cam`` and ``uv``). Many lines at once: :func:`fit_interpretation_planes`.
    """
    planes, failures = fit_interpretation_planes(cam, [uv], f_scale=f_scale, ransac=ransac, seed=seed,
                                                 pixel_sigma=pixel_sigma, inlier_threshold=inlier_threshold,
                                                 max_trials=max_trials, directions_only=directions_only, rays=rays)
    if failures:
        raise CatadioptricError(failures[0])
    return planes[0]


def fit_interpretation_planes(cam, uv_sets, *, f_scale: float = 1.0, ransac: bool = True, seed=0,
                              pixel_sigma=None, inlier_threshold=None, max_trials: int = 200,
                              directions_only: bool = False, rays=None) -> tuple[dict, dict]:
    """:func:`fit_interpretation_plane` of many lines at once, one pixel set ``uv_sets[i] (M_i, 2)``
    per line: ``(planes, failures)``, ``{i: InterpretationPlane}`` and ``{i: reason}`` (a line
    with fewer than 3 pixels that see the world). Each line's answer is the one
    :func:`fit_interpretation_plane` gives it alone, its RANSAC samples drawn as it draws them (an
    int ``seed``: every line from that seed; a Generator: one line after another); the arithmetic
    runs over every line's pixels together. ``rays``: the rays of all the pixels, the sets one
    after another, if already computed."""
    from ..models.base import CentralCamera
    from ..unified import UnifiedCamera

    if not isinstance(cam, (CatadioptricCamera, UnifiedCamera, CentralCamera)):
        raise CatadioptricError(f"cam: expected a CatadioptricCamera, a UnifiedCamera or a camera model of "
                                f"catadioptric.models, got {type(cam).__name__}")
    if isinstance(cam, CatadioptricCamera) and not cam.is_central and not directions_only:
        raise CatadioptricError("cam: expected a central camera (cam.is_central); a non-central camera sees the "
                                "whole line: use fit_line (or directions_only=True for the approximate plane)")
    f_scale, pixel_sigma, inlier_threshold = check_options("linear", f_scale, pixel_sigma, inlier_threshold)
    as_rng(seed)  # a seed of the wrong kind is named even when no line draws samples
    sets, failures = [], {}
    for i, uv in enumerate(uv_sets):
        try:
            sets.append(check_uv(uv, "uv", 3))
        except CatadioptricError as exc:
            if len(uv_sets) == 1:
                raise
            failures[i] = str(exc)
            sets.append(np.zeros((0, 2)))
    sizes = np.array([len(u) for u in sets])
    all_uv = np.concatenate(sets) if len(sets) else np.zeros((0, 2))
    # a pixel at the edge of the mirror's image has no ray derivative (a neighbour misses the mirror)
    if rays is None:
        rays = pixel_rays_with_jacobian(cam, all_uv)
    elif len(rays.uv) != len(all_uv):
        raise CatadioptricError(f"rays: expected the rays of the {len(all_uv)} pixels uv, got {len(rays.uv)}")
    line_of = np.repeat(np.arange(len(sets)), sizes)
    n_ok = np.bincount(line_of[rays.ok], minlength=len(sets))
    for i in np.flatnonzero(n_ok < 3):
        failures.setdefault(int(i), f"uv: expected at least 3 pixels that see the world, got {int(n_ok[i])}")
    good = np.array([i for i in range(len(sets)) if i not in failures], dtype=int)
    if not len(good):
        return {}, failures
    keep = rays.ok & np.isin(line_of, good)
    R = rays.take(keep)
    line = np.searchsorted(good, line_of[keep])  # each kept ray's index among the good lines
    G = len(good)
    thr = inlier_threshold if inlier_threshold is not None else (
        3.5 * pixel_sigma if pixel_sigma is not None else 3.0 * f_scale)
    counts = np.bincount(line, minlength=G)
    inl = np.ones(len(line), dtype=bool)
    if ransac:
        best = _ransac_planes(R, line, counts, seed, thr, max_trials)
        has = np.all(np.isfinite(best), axis=1)
        if has.any():
            new = _distances(best, R, line) <= thr
            enough = np.bincount(line, new.astype(float), G) >= 3
            use = has & enough
            inl = np.where(use[line], new, True)
    n = refine_planes(R, line, inl, G)
    if ransac:  # inliers of the refined plane (threshold from a robust sigma unless given)
        r = _distances(n, R, line)
        thr2 = np.full(G, float(thr))
        if inlier_threshold is None and pixel_sigma is None:
            med = _line_medians(r, line, inl, G)
            thr2 = 3.0 * np.maximum(f_scale, 1.2 * med / 0.6745)
        new = r <= thr2[line]
        enough = np.bincount(line, new.astype(float), G) >= 3
        changed = np.bincount(line, (new != inl).astype(float), G) > 0
        again = enough & changed
        if again.any():
            inl = np.where(again[line], new, inl)
            n = np.where(again[:, None], refine_planes(R, line, inl, G, lines=again), n)
    r = _distances(n, R, line)
    k = np.bincount(line, inl.astype(float), G)
    rss = np.bincount(line, np.where(inl, r**2, 0.0), G)
    with np.errstate(invalid="ignore", divide="ignore"):
        sigma = np.full(G, float(pixel_sigma)) if pixel_sigma is not None else np.where(
            k - 2 > 0, np.sqrt(rss / (k - 2)), np.nan)
    cov = plane_covariances(n, R, line, inl, sigma)
    rms = np.sqrt(rss / k)
    starts = np.concatenate([[0], np.cumsum(sizes)])
    viewpoint = cam.viewpoint
    planes = {}
    for g, i in enumerate(good):
        ok_i = rays.ok[starts[i]:starts[i + 1]]
        m = line == g
        planes[int(i)] = InterpretationPlane(normal=n[g], viewpoint=viewpoint, normal_cov=cov[g], rms=float(rms[g]),
                                             distances=scatter(ok_i, r[m], np.inf, int(sizes[i])),
                                             inliers=scatter(ok_i, inl[m], False, int(sizes[i])))
    return planes, failures


def _distances(n, rays, line):
    """Each ray's first-order image distance (pixels) to its line's plane, normals ``n (G, 3)``."""
    nl = n[line]
    num = np.abs(np.sum(nl * rays.d, axis=1))
    den = row_norm(np.einsum("mk,mkj->mj", nl, rays.Jd))
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(den > 0, num / den, np.inf)


def _line_medians(r, line, mask, G):
    """The median of ``r`` over each line's rays in ``mask`` ``(G,)``."""
    from scipy import ndimage

    lab = np.where(mask, line + 1, 0)
    return np.asarray(ndimage.median(r, labels=lab, index=np.arange(1, G + 1)), float).reshape(G)


def _ransac_planes(rays, line, counts, seed, thr, max_trials):
    """RANSAC's best plane ``(G, 3)`` per line (NaN where it has none: 3 rays, or no pair spans a
    plane): hypotheses from pairs of rays, ``max_trials`` rounded up to batches of 64, the samples
    of each line drawn as :func:`fit_interpretation_plane` draws them; the best by the truncated
    cost ``sum min(r^2, thr^2)``, the first of equals."""
    G = len(counts)
    starts = np.concatenate([[0], np.cumsum(counts)])
    order = np.argsort(line, kind="stable")
    d = rays.d[order]
    rng_shared = seed if isinstance(seed, np.random.Generator) else None
    rounds = int(np.ceil(max_trials / 64))
    pairs = np.zeros((G, 64 * rounds, 2), dtype=int)
    sampled = counts > 3
    for g in np.flatnonzero(sampled):
        rng = rng_shared if rng_shared is not None else as_rng(seed)
        M = int(counts[g])
        # the first two of each row's random order (argsort's [:, :2], found without sorting the rest)
        idx = np.concatenate([np.argpartition(rng.random((64, M)), 1, axis=1)[:, :2] for _ in range(rounds)])
        pairs[g] = starts[g] + idx
    hyp = cross(d[pairs[..., 0]], d[pairs[..., 1]])  # (G, T, 3)
    nn = row_norm(hyp)
    usable = (nn > 1e-12) & sampled[:, None]
    hyp = hyp / np.where(usable, nn, 1.0)[..., None]
    # every hypothesis of a line against that line's rays (one product per line)
    sorted_rays = Rays(rays.uv[order], d, rays.Jd[order], rays.ok[order])
    cost = np.zeros(hyp.shape[:2])
    for g in np.flatnonzero(sampled):
        dist = plane_distances(hyp[g], sorted_rays.take(slice(starts[g], starts[g + 1])))
        cost[g] = np.sum(np.minimum(dist**2, thr**2), axis=1)
    cost = np.where(usable, cost, np.inf)
    j = np.argmin(cost, axis=1)
    best = hyp[np.arange(G), j]
    return np.where(np.isfinite(cost[np.arange(G), j])[:, None], best, np.nan)
