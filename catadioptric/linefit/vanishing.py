"""Vanishing points of a family of parallel lines from their image curves, with covariances and
the spread of the individually fitted curves."""
from __future__ import annotations

import numpy as np

from .._checks import CatadioptricError
from ..cameras import CatadioptricCamera
from ._common import tangent_basis, unit_vectors
from .central import direction_from_planes, fit_interpretation_planes
from .fits import check_sets, fit_line, fit_parallel_lines
from .results import CurveVanishingPoints


# --------------------------------------------------------------------------- vanishing points from curves
def _match_vps(ref_uv, ref_sign, ref_vis, uv, sign, vis):
    """For each reference entry (K,), the entry of ``uv (K', 2)`` with the same sign, visible,
    nearest in pixels (NaN when none)."""
    out = np.full(ref_uv.shape, np.nan)
    for k in range(len(ref_uv)):
        if ref_sign[k] == 0 or not ref_vis[k]:
            continue
        c = np.nonzero((sign == ref_sign[k]) & vis)[0]
        if len(c) == 0:
            continue
        j = c[int(np.argmin(np.sum((uv[c] - ref_uv[k]) ** 2, axis=-1)))]
        out[k] = uv[j]
    return out


def vanishing_points_from_curves(cam: CatadioptricCamera, uv_sets, **options) -> CurveVanishingPoints:
    """Vanishing points of a family of parallel lines from their image curves.

    Fits the family jointly (:func:`fit_parallel_lines`, ``options`` passed on) and takes
    the vanishing points of its direction at both ends (``cam.vanishing_points(s,
    which="both")``: the points of ``+s`` and of ``-s`` with their flags); the joint point's
    pixel covariance follows from the direction's covariance. Each line is also fitted
    on its own (:func:`fit_line`); the vanishing points of its direction, oriented like
    the joint one, are matched to the joint points, and ``spread_max`` / ``spread_rms``
    say how far apart the individually fitted curves pass at each vanishing point (a
    line whose own fit fails counts as missing there).

    Central cameras (``cam.is_central``, or a camera model of :mod:`catadioptric.models`; at least 2 curves): each curve gives only its
    interpretation plane (:func:`fit_interpretation_plane`), the direction is the one normal
    to all planes (:func:`direction_from_planes`), ``family`` is None, ``individual`` holds
    the planes and ``individual_uv`` one row per pair of curves: the vanishing points of
    the pair's own direction (where the two fitted curves cross).
    """
    from ..models.base import CentralCamera

    if isinstance(cam, CentralCamera) or (isinstance(cam, CatadioptricCamera) and cam.is_central):
        return _central_vanishing_points(cam, uv_sets, **options)
    fam = fit_parallel_lines(cam, uv_sets, **options)
    s = fam.direction
    vp, uv_cov = _vps_with_cov(cam, s, fam.direction_cov)
    uv, sign, vis = vp.uv, vp.sign.astype(int), vp.visible
    indiv, uvs = [], []
    for u in uv_sets:
        try:
            f = fit_line(cam, u, **options)
        except CatadioptricError:
            indiv.append(None)
            uvs.append(np.full(uv.shape, np.nan))
            continue
        indiv.append(f)
        si = f.direction if f.direction @ s >= 0 else -f.direction
        v = cam.vanishing_points(si, which="both")
        uvs.append(_match_vps(uv, sign, vis, v.uv, v.sign, v.visible))
    return _curve_vps(s, fam.direction_cov, vp, uv_cov, uvs, fam, indiv)


def _vps_with_cov(cam, s, direction_cov):
    """Vanishing points of ``s`` (both ends) and their pixel covariances ``(K, 2, 2)``."""
    vp = cam.vanishing_points(s, which="both")
    uv, sign, vis = vp.uv, vp.sign.astype(int), vp.visible
    # propagate the direction covariance: d uv / d (tangent coordinates) by central differences
    e1, e2 = tangent_basis(s)
    h = 1e-6
    J = np.full(uv.shape + (2,), np.nan)
    for c, e in enumerate((e1, e2)):
        vpp = cam.vanishing_points(unit_vectors(s + h * e), which="both")
        vpm = cam.vanishing_points(unit_vectors(s - h * e), which="both")
        up = _match_vps(uv, sign, vis, vpp.uv, vpp.sign, vpp.visible)
        um = _match_vps(uv, sign, vis, vpm.uv, vpm.sign, vpm.visible)
        J[:, :, c] = (up - um) / (2 * h)
    E = np.stack([e1, e2], axis=1)
    C2 = E.T @ direction_cov @ E
    uv_cov = np.einsum("kij,jl,kml->kim", J, C2, J)
    return vp, uv_cov


def _curve_vps(s, direction_cov, vp, uv_cov, uvs, fam, indiv):
    uv = vp.uv
    ind_uv = np.array(uvs).reshape(len(uvs), *uv.shape)
    dist = np.linalg.norm(ind_uv - uv[None], axis=-1)
    have = np.isfinite(dist)
    with np.errstate(invalid="ignore"):
        spread_max = np.where(have.any(axis=0), np.max(np.where(have, dist, -np.inf), axis=0), np.nan)
        spread_rms = np.sqrt(np.sum(np.where(have, dist**2, 0.0), axis=0) / np.maximum(have.sum(axis=0), 1))
    spread_rms = np.where(have.any(axis=0), spread_rms, np.nan)
    return CurveVanishingPoints(direction=s, direction_cov=direction_cov, uv=uv, sign=vp.sign.astype(int),
                                visible=vp.visible, in_image=vp.in_image, uv_cov=uv_cov, individual_uv=ind_uv,
                                spread_max=spread_max, spread_rms=spread_rms, family=fam, individual=indiv)


def _central_vanishing_points(cam, uv_sets, **options):
    """Central camera: each curve gives its interpretation plane; the direction is normal to all of
    them; each pair of curves meets at the vanishing points of the pair's own direction."""
    allowed = {"f_scale", "ransac", "seed", "pixel_sigma", "inlier_threshold", "max_trials"}
    opts = {k: v for k, v in options.items() if k in allowed}
    sets = check_sets(uv_sets)
    if len(sets) < 2:
        raise CatadioptricError(f"uv_sets: a central camera needs at least 2 curves (one gives only a plane), "
                                f"got {len(sets)}")
    fits, failures = fit_interpretation_planes(cam, sets, **opts)
    if failures:
        raise CatadioptricError(failures[min(failures)])
    planes = [fits[i] for i in range(len(sets))]
    s, cov = direction_from_planes([p.normal for p in planes], [p.normal_cov for p in planes])
    rays = cam.backproject(sets[0][planes[0].inliers])
    d = rays.directions[rays.valid]
    if len(d) >= 2 and (d[-1] - d[0]) @ s < 0:  # oriented from the first pixel's view to the last one's
        s = -s
    vp, uv_cov = _vps_with_cov(cam, s, cov)
    sign = vp.sign.astype(int)
    uvs = []
    for i in range(len(planes)):
        for j in range(i + 1, len(planes)):
            sij = np.cross(planes[i].normal, planes[j].normal)
            if np.linalg.norm(sij) < 1e-12:
                uvs.append(np.full(vp.uv.shape, np.nan))
                continue
            sij = sij if sij @ s >= 0 else -sij
            v = cam.vanishing_points(sij, which="both")
            uvs.append(_match_vps(vp.uv, sign, vp.visible, v.uv, v.sign, v.visible))
    return _curve_vps(s, cov, vp, uv_cov, uvs, None, planes)


