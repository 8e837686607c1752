"""The public non-central fits: :func:`fit_line` (one line) and :func:`fit_parallel_lines` (a
family sharing one direction)."""
from __future__ import annotations

import numpy as np

from .._checks import CatadioptricError
from ..cameras import CatadioptricCamera
from ._common import (
    as_rng,
    check_camera,
    check_distinct,
    check_fit_options,
    check_min_distance,
    check_options,
    check_uv,
    scatter,
)
from .distances import closest_depths, linear_distances
from .linear import moment_candidates, ray_frame
from .problem import FamilyPixels, FamilyStart, SolveOptions, solve_family
from .ransac import best_linear, initial_line, msac_line, prepare_pixels
from .results import FamilyFit, LineFit


# --------------------------------------------------------------------------- public fits
def fit_line(cam: CatadioptricCamera, uv, *, loss: str = "soft_l1", f_scale: float = 1.0, ransac: bool = True,
             seed=0, pixel_sigma=None, inlier_threshold=None, max_trials: int = 200,
             jac: str = "analytic", min_distance=None) -> LineFit:
    """Fit the 3-D line whose image passes through pixels ``uv (M, 2)`` (M >= 5) of a non-central camera.

    Minimises the image distance of the pixels to the line's image: unknowns the line
    (4 DOF) and one depth per pixel, residual ``project(q + lambda_j s) - uv_j`` (the image
    branch nearest the pixel). ``ransac``: hypotheses from minimal sets of 4 pixels
    (linear solver) and near-central lines from 3 more, MSAC-scored by first-order image
    distance, ``max_trials`` samples at most (``seed``: int, None or a Generator); without
    it, the best linear candidate from all pixels. Then ``least_squares`` with ``loss`` /
    ``f_scale`` (pixels; set ``f_scale`` near the pixel noise) from the best hypothesis,
    inliers by image distance (``inlier_threshold`` pixels; default ``3 max(f_scale, sigma)``
    with sigma estimated robustly, or ``3.5 pixel_sigma``), and a plain least-squares
    polish on the inliers. ``pixel_sigma``: known pixel noise for the covariance (default:
    estimated from the inlier residuals). ``jac``: ``"analytic"`` (Fermat's principle) or
    ``"2-point"``/``"3-point"`` (finite differences with ``jac_sparsity``). ``min_distance``:
    the line keeps at least this distance (metres; default twice the mirror's scale) from
    the point nearest all the pixels' rays. Near a near-central rig's viewpoint every ray
    nearly meets every line: there a line fits any noisy pixels, and without the bound the
    least-squares optimum of a near-central rig can run into it (docs/linefit.md).

    Raises :class:`CatadioptricError` for central cameras (the position is not observable)
    and for bad input.
    """
    check_camera(cam, "the line's position and direction")
    uv = check_uv(uv, "uv", 5)
    f_scale, pixel_sigma, inlier_threshold = check_options(loss, f_scale, pixel_sigma, inlier_threshold)
    thr = check_fit_options(jac, max_trials, f_scale, pixel_sigma, inlier_threshold)
    dmin = check_min_distance(min_distance, cam)
    rng = as_rng(seed)
    ok, px = prepare_pixels(cam, uv, "uv")
    check_distinct(px.uv, "uv")
    s, q, mask, n_hyp = initial_line(cam, px, ransac=ransac, rng=rng, thr=thr, max_trials=int(max_trials),
                                     dmin=dmin)
    lam0 = closest_depths(q, s, px.o, px.d)
    owner = np.zeros(len(px.uv), dtype=np.int64)
    options = SolveOptions(loss=loss, f_scale=f_scale, pixel_sigma=pixel_sigma, inlier_threshold=inlier_threshold,
                           jac=jac, min_distance=dmin)
    r = solve_family(FamilyPixels(cam, px.uv, px.o, px.d, owner, 1, names=["uv"]),
                     FamilyStart(s, q[None], lam0, mask=mask), options)
    return _line_result(r, ok, len(uv), n_hyp)


def _orient(lam, inl):
    """Flip the direction so that the first inlier's depth is below the last one's."""
    j = np.nonzero(inl)[0]
    return -1.0 if lam[j[-1]] < lam[j[0]] else 1.0


def _line_result(r, ok, M, n_hyp=0, line=0, owner=None):
    own = np.zeros(int(ok.sum()), dtype=np.int64) if owner is None else owner
    sel = own == line
    s, q = r["s"], r["q"][line]
    lam = r["lam"][sel]
    inl_v = r["inliers"][sel]
    sign = _orient(lam, inl_v)
    s = sign * s
    lam = sign * lam
    full = lambda v, fill, tail=(): scatter(ok, v, fill, M, tail)
    depths = full(lam, np.nan)
    points = q + depths[:, None] * s
    m = np.cross(q, s)
    C = r["pluecker_cov"][line]  # (s, m) -> (-s, -m) leaves it unchanged
    dist_v = r["dist"][sel]
    rms = float(np.sqrt(np.mean(dist_v[inl_v] ** 2)))
    return LineFit(direction=s, moment=m, point=q, depths=depths, points=points,
                   uv_fit=full(r["uv_fit"][sel], np.nan, (2,)), distances=full(dist_v, np.inf),
                   inliers=full(inl_v, False), rms=rms, sigma=r["sigma"], direction_cov=C[:3, :3],
                   pluecker_cov=C, dof=int(r["dof"]), n_hypotheses=n_hyp, nfev=int(r["nfev"]))


def check_sets(uv_sets):
    """The pixel sets of :func:`fit_parallel_lines` checked, as a list of ``(M_i, 2)`` float arrays."""
    if isinstance(uv_sets, np.ndarray) and uv_sets.ndim == 3:
        uv_sets = list(uv_sets)
    if not isinstance(uv_sets, (list, tuple)) or len(uv_sets) == 0:
        raise CatadioptricError(
            f"uv_sets: expected a non-empty list of (M_i, 2) pixel arrays, got {type(uv_sets).__name__}"
            + (f" of length {len(uv_sets)}" if hasattr(uv_sets, "__len__") else ""))
    return [check_uv(u, f"uv_sets[{i}]", 5) for i, u in enumerate(uv_sets)]


def fit_parallel_lines(cam: CatadioptricCamera, uv_sets, *, loss: str = "soft_l1", f_scale: float = 1.0,
                       ransac: bool = True, seed=0, pixel_sigma=None, inlier_threshold=None,
                       max_trials: int = 200, jac: str = "analytic", min_distance=None) -> FamilyFit:
    """Fit parallel 3-D lines, one per pixel set ``uv_sets[i] (M_i, 2)``, sharing one direction.

    Unknowns: the direction (2 DOF), each line's point in the plane normal to it (2 DOF
    per line) and one depth per pixel; residuals and options as :func:`fit_line`. The
    start: each set's inliers by RANSAC, then the direction that best explains every set
    among the intersection of the sets' near-central planes (the planes through the
    point nearest all rays that hold each set's rays: parallel lines' planes meet along
    the common direction) and the sets' own linear solutions, each line's moment by
    linear least squares for that direction. ``min_distance`` as in :func:`fit_line`.
    """
    check_camera(cam, "the lines' positions and direction")
    sets = check_sets(uv_sets)
    f_scale, pixel_sigma, inlier_threshold = check_options(loss, f_scale, pixel_sigma, inlier_threshold)
    thr = check_fit_options(jac, max_trials, f_scale, pixel_sigma, inlier_threshold)
    dmin = check_min_distance(min_distance, cam)
    rng = as_rng(seed)
    prepared = [prepare_pixels(cam, u, f"uv_sets[{i}]") for i, u in enumerate(sets)]
    for i, (_, px) in enumerate(prepared):
        check_distinct(px.uv, f"uv_sets[{i}]")
    pxs = [p[1] for p in prepared]
    o_all = np.concatenate([p.o for p in pxs])
    d_all = np.concatenate([p.d for p in pxs])
    frame = ray_frame(cam, o_all, d_all, dmin)
    masks, own_lines = [], []
    for px in pxs:
        if ransac:
            Lb, mk, _ = msac_line(cam, frame, px, rng, thr, int(max_trials))
            if mk.sum() < 5:
                mk = np.ones(len(px.uv), dtype=bool)
        else:
            Lb = best_linear(cam, frame, px)[0]
            mk = np.ones(len(px.uv), dtype=bool)
        masks.append(mk)
        own_lines.append(Lb)
    # candidate directions
    cands = [L[:3] for L in own_lines]
    if len(pxs) >= 2:
        normals = np.array([np.linalg.svd(px.d[mk], full_matrices=False)[2][-1] for px, mk in zip(pxs, masks)])
        cands.append(np.linalg.svd(normals)[2][-1])
    best = None
    for s in cands:
        lines, cost = [], 0.0
        for px, mk in zip(pxs, masks):
            Lc = moment_candidates(frame, s, px.o[mk], px.d[mk], cam.mirror.scale)
            dist = linear_distances(px, Lc)
            c = np.sum(np.minimum(dist**2, thr**2), axis=1)
            j = int(np.argmin(c))
            lines.append(Lc[j])
            cost += c[j]
        if best is None or cost < best[0]:
            best = (cost, s, lines)
    _, s0, lines = best
    q0 = np.array([np.cross(L[:3], L[3:]) for L in lines])
    owner = np.concatenate([np.full(len(px.uv), i, dtype=np.int64) for i, px in enumerate(pxs)])
    uv_all = np.concatenate([px.uv for px in pxs])
    lam0 = closest_depths(q0[owner], s0, o_all, d_all)
    options = SolveOptions(loss=loss, f_scale=f_scale, pixel_sigma=pixel_sigma, inlier_threshold=inlier_threshold,
                           jac=jac, min_distance=dmin)
    data = FamilyPixels(cam, uv_all, o_all, d_all, owner, len(pxs), names=[f"uv_sets[{i}]" for i in range(len(pxs))],
                        x0=frame.x0)
    r = solve_family(data, FamilyStart(s0, q0, lam0, mask=np.concatenate(masks)), options)
    s, q = r["s"], r["q"]
    sign = _orient(r["lam"][owner == 0], r["inliers"][owner == 0])
    s = sign * s
    lam = sign * r["lam"]
    depths, pts, uvf, dists, inls, rms_l = [], [], [], [], [], []
    for i, (ok, _) in enumerate(prepared):
        sel = owner == i
        M = len(sets[i])
        dep = scatter(ok, lam[sel], np.nan, M)
        depths.append(dep)
        pts.append(q[i] + dep[:, None] * s)
        uvf.append(scatter(ok, r["uv_fit"][sel], np.nan, M, (2,)))
        dists.append(scatter(ok, r["dist"][sel], np.inf, M))
        inls.append(scatter(ok, r["inliers"][sel], False, M))
        rms_l.append(float(np.sqrt(np.mean(r["dist"][sel][r["inliers"][sel]] ** 2))))
    rms = float(np.sqrt(np.mean(r["dist"][r["inliers"]] ** 2)))
    return FamilyFit(direction=s, moments=np.cross(q, s), points=q, depths=depths, line_points=pts, uv_fit=uvf,
                     distances=dists, inliers=inls, rms=rms, rms_per_line=np.array(rms_l), sigma=r["sigma"],
                     direction_cov=r["dir_cov"], pluecker_cov=np.array(r["pluecker_cov"]), cov=r["cov"],
                     dof=int(r["dof"]), nfev=int(r["nfev"]))


