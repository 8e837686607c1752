"""Two-view refinement of a relative pose from the pixels of lines: rotation, metric translation,
family directions and lines, jointly, by minimising the pixel distances in both views.

The unknowns (pose, family directions, lines in inverse-distance coordinates, one depth per
pixel) are in :mod:`catadioptric.pose.two_view_problem`. The residuals (:attr:`TwoViewOptions.residuals`)
are by default each pixel's first-order image distance to its line, from its ray
(:mod:`catadioptric.pose.two_view_rays`: each depth solved in closed form at every evaluation,
no projection), or the exact distance to the image of the line's point at the pixel's depth
(the depths then unknowns, eliminated in closed form at every step: each touches two
residuals). Each Levenberg-Marquardt step solves one dense system of ``6 + 2 F + 2 L`` unknowns. A robust
(Cauchy) reweighting is followed by a plain least-squares polish on the inliers, whose
inverse Schur complement gives the covariance of ``(w, t)``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._checks import CatadioptricError
from ..linefit._common import HALF_NORMAL_MEDIAN
from ._kernels import reduced_normal_equations
from .meetings import check_corners
from .two_view_problem import MU_MAX, Problem
from .two_view_rays import RayProblem

__all__ = ["TwoViewData", "TwoViewStart", "TwoViewOptions", "TwoViewFit", "refine_two_view", "RESIDUALS",
           "check_residuals"]

#: the residuals a two-view refinement can minimise (:attr:`TwoViewOptions.residuals`), and their problems
RESIDUALS = {"first_order": RayProblem, "image": Problem}


def check_residuals(value) -> str:
    """``value`` if it names residuals of :data:`RESIDUALS`; otherwise a one-line error naming it."""
    if not isinstance(value, str) or value not in RESIDUALS:
        raise CatadioptricError(f"residuals: expected one of {', '.join(map(repr, RESIDUALS))}, got {value!r}")
    return value


@dataclass(frozen=True)
class TwoViewData:
    """What a two-view refinement explains: the cameras ``cam_a``, ``cam_b``, the pixels
    ``uv_a (Na, 2)`` with ``owner_a (Na,)`` (the line each pixel images), likewise for B, and
    ``line_family (L,)``: each line's family (an index into the start's directions).

    ``centres``: ``(c_A, c_B)``, each view's point nearest its rays (None: from the pixels' rays).
    ``corners (K, 2)``: pairs of lines (indices into the lines, of different families) whose
    meeting rays were inliers of stage 1's translation
    (:func:`~catadioptric.pose.central.translation_direction_from_crossings`), each with the
    deviation ``corner_sigma (K,)`` of its epipolar residual there (None: no meetings;
    :func:`refine_two_view` says how they are used)."""

    cam_a: object
    cam_b: object
    uv_a: np.ndarray
    owner_a: np.ndarray
    uv_b: np.ndarray
    owner_b: np.ndarray
    line_family: np.ndarray
    centres: tuple | None = None
    corners: np.ndarray | None = None
    corner_sigma: np.ndarray | None = None


@dataclass(frozen=True)
class TwoViewStart:
    """Where a two-view refinement starts: ``x_B = R x_A + t`` (metres), the families'
    ``directions (F, 3)`` in A and a point of each line in A, ``points (L, 3)``."""

    R: np.ndarray
    t: np.ndarray
    directions: np.ndarray
    points: np.ndarray


@dataclass(frozen=True, kw_only=True)
class TwoViewOptions:
    """How :func:`refine_two_view` refines (its docstring has the figures behind each default)."""

    #: the pixel scale of the robust stage (pixels; its Cauchy loss's ``c2`` is in units of it)
    sigma_cost: float = 1.0
    #: known pixel noise for the inliers and the covariance (None: estimated from the inliers)
    pixel_sigma: float | None = None
    #: the first stage robust (Cauchy); False: plain least squares there too
    robust: bool = True
    #: the Cauchy loss's scale, squared, in units of ``sigma_cost``
    c2: float = 9.0
    #: the robust stage's steps at most (the polish stops when both have taken twice this)
    max_iter: int = 50
    #: inliers after the robust stage: pixels (and meetings) within this many deviations
    inlier_sigmas: float = 3.5
    #: each stage stops when a step lowers its cost by less than this (chi-square units)
    tol_chi2: float = 0.01
    #: the pixels' residuals: "first_order", each pixel's first-order image distance to its line,
    #: from its ray, no projection (:mod:`~catadioptric.pose.two_view_rays`); "image", the exact
    #: distance to the image of the line's point at the pixel's depth, a depth per pixel carried
    #: as an unknown (:mod:`~catadioptric.pose.two_view_problem`; slower)
    residuals: str = "first_order"
    #: with "image" residuals: each step's images continued from the last accepted state's
    #: reflection points (False: every image searched anew each time, slower)
    warm_start: bool = True
    #: with "image" residuals: each trial step judged at its depths re-solved (slower, not better
    #: on the benchmark)
    settle_depths: bool = False
    #: both stages hold the scene's scale where the start's translation puts it
    hold_scale: bool = False
    #: a held scale is freed after the polish when the deviation of its logarithm is below this
    release_scale: float = 0.05



@dataclass
class TwoViewFit:
    """The refined two-view geometry.

    ``R``, ``t``: ``x_B = R x_A + t`` (metres); ``cov (6, 6)``: covariance of ``(w, t)`` (left
    rotation vector, then translation). ``directions (F, 3)`` in A; ``points (L, 3)``: each
    line's point nearest the origin of A. ``sigma``: pixel noise (given, or estimated from
    the inliers), ``cost``: the robust cost ``sum rho(|e_j|^2 / sigma_cost^2)`` of the robust
    stage (comparable between candidates refined with the same ``sigma_cost``),
    ``rms_px (2,)``: inlier rms per view, ``inliers_a``, ``inliers_b`` (masks over the pixels
    given), ``n_pixels (2,)`` inliers per view, ``iterations``, ``line_family (L,)``: each line's
    family. Set by :func:`~catadioptric.pose.scale.refine_far_or_free`: ``scale_held`` (the
    rotation and the scene's shape from the fit with the scene held far, the pixels not fixing
    its scale), ``far_gap`` (the far fit's cost on every pixel minus the free one's,
    :func:`~catadioptric.pose.scale.common_gap`) and ``scale_std`` (the free fit's relative
    deviation of the baseline's length); nan when not compared."""

    R: np.ndarray
    t: np.ndarray
    cov: np.ndarray
    directions: np.ndarray
    points: np.ndarray
    sigma: float
    cost: float
    rms_px: np.ndarray
    inliers_a: np.ndarray
    inliers_b: np.ndarray
    n_pixels: np.ndarray
    iterations: int
    line_family: np.ndarray | None = None
    scale_held: bool = False
    far_gap: float = float("nan")
    scale_std: float = float("nan")


def _weights(e, sigma, c2, robust, mask):
    r2 = np.sum(e**2, axis=1) / sigma**2
    ok = np.isfinite(r2) & mask
    r2 = np.where(ok, r2, 0.0)
    w = np.where(ok, 1.0 / (1.0 + r2 / c2) if robust else 1.0, 0.0)
    cost = float(np.sum(np.where(ok, c2 * np.log1p(r2 / c2) if robust else r2, 0.0)))
    # a pixel whose point has no image costs as much as a far outlier
    cost += float(np.sum(mask & ~np.isfinite(np.sum(e**2, axis=1)))) * (c2 * np.log1p(1e4 / c2) if robust else 1e4)
    return w, cost


def _corner_system(pb, R, y, sigma, c2, robust, cmask):
    """The meeting lines' share of the normal equations and of the cost: ``(Sc, gc, cost)``, in the
    pixels' units (``S`` sums squared pixel residuals; a corner's residual is in units of its own
    deviation, so it enters times ``sigma^2``)."""
    r, J = pb.corner_terms(R, y)
    if len(r) == 0:
        return None, None, 0.0
    w, cost = _weights(r[:, None], 1.0, c2, robust, cmask)
    Jw = J * w[:, None]
    return sigma**2 * (Jw.T @ J), sigma**2 * (Jw.T @ r), cost


def _corner_cost(pb, R, y, c2, robust, cmask):
    """The meeting lines' share of the cost alone (that of :func:`_corner_system`, the same bits)."""
    r = pb.corner_residuals(R, y)
    if len(r) == 0:
        return 0.0
    return _weights(r[:, None], 1.0, c2, robust, cmask)[1]


def _normal_equations(pb, A, b, e, w, lam):
    """Schur complement over the depths: ``S dy = -g`` and the depth back-substitution terms.

    With ``W`` the weights, per pixel ``Hmm = w b'b`` (damped: ``Hmm_d = Hmm (1 + lam)``),
    ``Hym = w A'b``, ``gm = w b'e``; its block ``w A'A - Hym Hym' / Hmm_d`` of ``S`` and
    ``w A'e - Hym gm / Hmm_d`` of ``g`` go to its columns ``pb.cols``
    (:func:`catadioptric.pose._kernels.reduced_normal_equations`, one compiled pass)."""
    return reduced_normal_equations(np.ascontiguousarray(A, dtype=float), np.ascontiguousarray(b, dtype=float),
                                    np.ascontiguousarray(e, dtype=float), np.ascontiguousarray(w, dtype=float),
                                    float(lam), pb.cols, int(pb.ny))


def _damped_solve(S, g, lam):
    """``dy`` of ``(S + lam diag) dy = -g``, Jacobi-scaled (unknowns of very different units:
    radians, metres, inverse distances); an unknown with no information does not move."""
    d = np.diag(S).copy()
    sc = np.sqrt(np.maximum(d, 1e-12 * max(d.max(), 1e-300)))
    S_n = S / np.outer(sc, sc) + np.eye(len(d)) * (lam + 1e-15)
    try:
        return -np.linalg.solve(S_n, g / sc) / sc
    except np.linalg.LinAlgError:
        return -np.linalg.lstsq(S_n, g / sc, rcond=None)[0] / sc


def _solve_step(pb, A, b, e, w, lam, y, mu, hold_scale=False, extra=(None, None)):
    """The damped Gauss-Newton step ``(dy, dmu)``. Unknowns that the step pushes against their
    bounds (:meth:`~catadioptric.pose.two_view_problem.Problem.pushed_bounds`; a depth at ``+-MU_MAX`` pushed outwards) are held on
    them and the step solved again, until it pushes against no other: moved across and clipped
    back by :meth:`~catadioptric.pose.two_view_problem.Problem.apply`, they would leave the rest of the step inconsistent, and
    Levenberg-Marquardt would crawl. A line the step carries past ``rho_min`` (beyond infinity:
    its pixels pull it to the other side) is moved onto that bound and the rest of the step solved
    with it there; rejected, such a step used to shrink until it stopped short of the bound, and
    the next pushed again (the sphere's refinements ran to their cap; validate/NOTES.md,
    2026-11-29 (late)). ``hold_scale``: the scene's scale (``sigma``) is held from the start."""
    Sc, gc = extra
    S, g, Hym, gm, Hmm_d = _normal_equations(pb, A, b, e, w, lam)
    if Sc is not None:
        S, g = S + Sc, g + gc
    held = (np.zeros(pb.L, dtype=bool), np.zeros(pb.L, dtype=bool), bool(hold_scale))
    T = pb.bound_chart(y, held)
    dy = _damped_solve(S, g, lam) if T is None else T @ _damped_solve(T.T @ S @ T, T.T @ g, lam)
    dmu = -(gm + np.sum(Hym * dy[pb.cols], axis=1)) / Hmm_d
    stuck = np.zeros(len(mu), dtype=bool)
    i_rho = 7 + 2 * pb.F + 2 * np.arange(pb.L)
    onto = np.zeros(pb.ny)  # lines the step carries past rho_min: moved onto it, then held there
    for _ in range(8):
        upper, lower, scale = pb.pushed_bounds(y, dy)
        past = (y[i_rho] + dy[i_rho] < pb.rho_min) & (y[i_rho] > pb.rho_min * (1 + 1e-9))
        onto[i_rho[past]] = pb.rho_min - y[i_rho[past]]
        lower = lower | (onto[i_rho] != 0.0)
        held2 = (held[0] | upper, held[1] | lower, held[2] or scale)
        stuck2 = stuck | ((np.abs(mu) >= MU_MAX * (1 - 1e-12)) & (dmu * mu > 0))
        if all(np.array_equal(p, q) for p, q in zip(held, held2)) and np.array_equal(stuck, stuck2):
            break
        if not np.array_equal(stuck, stuck2):  # a depth held: no depth column for its pixel
            S, g, Hym, gm, Hmm_d = _normal_equations(pb, A, np.where(stuck2[:, None], 0.0, b), e, w, lam)
            if Sc is not None:
                S, g = S + Sc, g + gc
        held, stuck = held2, stuck2
        T = pb.bound_chart(y, held)
        dy = _damped_solve(S, g, lam) if T is None else T @ _damped_solve(T.T @ S @ T, T.T @ (g + S @ onto), lam) + onto
        dmu = np.where(stuck, 0.0, -(gm + np.sum(Hym * dy[pb.cols], axis=1)) / Hmm_d)
    return dy, dmu


def _depth_step(mu, e, b):
    """Each pixel's depth after one Gauss-Newton step on it alone (residuals ``e``, depth column
    ``b``), moved at most by its own size plus one and kept within ``+-MU_MAX``."""
    bb = np.sum(b * b, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        dmu = np.where(bb > 0, -np.sum(b * np.nan_to_num(e), axis=1) / bb, 0.0)
    cap = np.abs(mu) + 1.0
    return np.clip(mu + np.clip(dmu, -cap, cap), -MU_MAX, MU_MAX)


def _settle_depths(pb, R, y, mu):
    """One Gauss-Newton step on each pixel's depth alone (the other unknowns fixed), before the joint
    steps: the depths are the most nonlinear unknowns (a pixel near a vanishing point moves little
    with its depth). Returns ``(mu, e, A, b)`` at the new depths."""
    e, A, b = pb.evaluate(R, y, mu)
    mu = _depth_step(mu, e, b)
    e, A, b = pb.evaluate(R, y, mu)
    return mu, e, A, b


def _trial(pb, R, y, mu, settle):
    """A trial state's residuals and the state :meth:`~catadioptric.pose.two_view_problem.Problem.jacobian` needs, ``(mu, e, state)``.
    With ``settle``, each pixel's depth is first moved by one Gauss-Newton step on its own
    (:func:`_depth_step`) at the trial's other unknowns: the joint step moves each depth only as
    far as its linearisation says, and the linearisation is poor (the image of a point moves along
    its curve nonlinearly with its depth). Judged at the depths it left, a step that moves the
    lines' directions or the scene's scale is rejected at small damping and Levenberg-Marquardt
    zig-zags along a near-central rig's flat scale (a variable-projection step on the depths)."""
    e, state = pb.residuals(R, y, mu)
    if settle:
        mu = _depth_step(mu, e, pb.depth_column(R, y, state))
        e, state = pb.residuals(R, y, mu)
    return mu, e, state


def _predicted_decrease(A, b, e, w, step, pb, sigma, corners):
    """The cost decrease the linearised residuals promise for ``step = (dy, dmu)``, in the cost's
    units (the robust loss's slope at each pixel is its weight ``w``); ``corners``: ``(Sc, gc)`` of
    :func:`_corner_system` (None: no meetings)."""
    dy, dmu = step
    e0 = np.nan_to_num(e)
    de = np.einsum("nij,nj->ni", A, dy[pb.cols]) + b * dmu[:, None]
    pred = -float(np.sum(w * np.sum(de * (2.0 * e0 + de), axis=1)))
    Sc, gc = corners
    if Sc is not None:
        pred -= float(2.0 * gc @ dy + dy @ Sc @ dy)
    return pred / sigma**2


def _lm(pb, R, y, mu, sigma, c2, robust, mask, max_iter, tol_chi2, settle=False, hold_scale=False, cmask=None):
    """Levenberg-Marquardt, its damping set by each step's gain ratio (the cost's decrease over the
    one the linearised residuals promised; Nielsen's rule: after an accepted step the damping is
    multiplied by ``max(1/3, 1 - (2 ratio - 1)^3)``, down to 1e-15, after rejected ones by 2, 4,
    8, ...). The damping must be free to fall far: the flat direction of a near-central rig (the
    scene's scale) has an eigenvalue many orders below the diagonal it is damped with. A fixed
    tenfold fall after every accepted step (and rise after every rejected one) had every other
    step rejected where the cost's valley curves (1.3 times the trial steps on 32 benchmark draws
    at 1 and 2 px; validate/NOTES.md, 2026-11-29).
    Stops when a step lowers the cost (chi-square units: residuals over ``sigma``) by less than
    ``tol_chi2``: along that flat direction the steps go on lowering the cost by thousandths of a
    unit, a difference the pixels cannot tell apart, and used to run to ``max_iter``. ``settle``:
    each trial's depths re-solved before it is judged (:func:`_trial`); ``hold_scale``: the scene's
    scale held (:func:`_solve_step`)."""
    if cmask is None:
        cmask = np.ones(len(pb.corners), dtype=bool)
    mu, e, A, b = _settle_depths(pb, R, y, mu)
    w, cost = _weights(e, sigma, c2, robust, mask)
    Sc, gc, cc = _corner_system(pb, R, y, sigma, c2, robust, cmask)
    cost += cc
    lam, nu = 1e-5, 2.0
    it = 0
    for it in range(1, max_iter + 1):
        improved = False
        for _ in range(12):
            dy, dmu = _solve_step(pb, A, b, e, w, lam, y, mu, hold_scale, (Sc, gc))
            R2, y2, mu2 = pb.apply(R, y, mu, dy, dmu)
            mu2, e2, state2 = _trial(pb, R2, y2, mu2, settle)
            _, cost2 = _weights(e2, sigma, c2, robust, mask)
            cost2 += _corner_cost(pb, R2, y2, c2, robust, cmask)
            if cost2 <= cost:
                improved = True
                break
            lam, nu = lam * nu, 2.0 * nu
        if not improved:
            break
        pred = _predicted_decrease(A, b, e, w, (dy, dmu), pb, sigma, (Sc, gc))
        ratio = min((cost - cost2) / pred, 1.0) if pred > 0 else 1.0
        lam, nu = max(lam * max(1.0 / 3.0, 1.0 - (2.0 * ratio - 1.0) ** 3), 1e-15), 2.0
        rel = (cost - cost2) / max(cost, 1e-300)
        cost_before = cost
        R, y, mu, e = R2, y2, mu2, e2
        A, b = pb.jacobian(R, y, mu, state2)
        w, cost = _weights(e, sigma, c2, robust, mask)
        Sc, gc, cc = _corner_system(pb, R, y, sigma, c2, robust, cmask)
        cost += cc
        if rel < 1e-10 or cost_before - cost < tol_chi2:
            break
    return R, y, mu, cost, it


def refine_two_view(data: TwoViewData, start: TwoViewStart, options: TwoViewOptions = TwoViewOptions()) -> TwoViewFit:
    """Refine ``x_B = R x_A + t`` and the lines jointly from the pixels of both views.

    ``data``: the cameras, pixels, their lines and the lines' families (:class:`TwoViewData`);
    ``start``: the pose, family directions and a point of each line (:class:`TwoViewStart`);
    ``options``: :class:`TwoViewOptions`, whose fields are these. ``sigma_cost``: the pixel scale of the robust
    stage (Cauchy, ``c2`` in units of it); ``pixel_sigma``: known pixel noise for the covariance
    (default: estimated from the inliers). Inliers after the robust stage: pixels within
    ``inlier_sigmas`` times the robust noise estimate (or ``pixel_sigma``); then a plain
    least-squares polish on them. Each stage stops when a step lowers its cost by less than
    ``tol_chi2`` (chi-square units); the robust stage after at most ``max_iter`` steps, the polish
    when the two have taken ``2 max_iter`` (with exact pixels the robust stage's cost, in units of
    a floor of ``sigma_cost``, stops early and the polish goes on to the last digits).
    ``residuals``: "first_order" (default), each pixel's first-order image distance to its line
    from its ray (:class:`~catadioptric.pose.two_view_rays.RayProblem`: each depth solved in
    closed form at every evaluation, no projection); "image", the exact distance to the image of
    the line's point at the pixel's depth (a depth per pixel carried as an unknown). Their
    rotations are not told apart on the benchmark; the first is the faster, the second tells the
    scene's scale better where the pixels tell it at all (the first's leans far; validate/NOTES.md,
    2026-11-30). With "image": ``warm_start``: each step's images continued from the last accepted state's reflection points
    (:func:`catadioptric.projection.project_from`); False: every image searched anew each time
    (slower: 1.32x the time over 8 benchmark draws at 2 px, ``bench/bench_refinement.py --cold``;
    the same minimum, though along a near-central rig's flat scale the two may stop apart: 0.172
    and 0.195 degree on sphere pair 1, equal to 1e-3 degree on the other 7). ``settle_depths``:
    each trial step judged at its depths re-solved (:func:`_trial`); its rotations are not told
    apart from the default's on the benchmark (160 draws at 1 and 2 px: better in 75, Wilcoxon
    p = 0.19) and it takes 0.99-1.74x the time (``bench/bench_refinement.py --settle``), so off by
    default.

    ``data.corners (K, 2)``: pairs of lines (indices into ``start.points``, of different families) whose
    meeting rays were inliers of stage 1's translation
    (:func:`~catadioptric.pose.central.translation_direction_from_crossings`), each with the
    deviation ``corner_sigma (K,)`` of its epipolar residual there: the rays from each view's
    centre that meet both lines must lie in one plane with the baseline
    (:meth:`~catadioptric.pose.two_view_problem.Problem.corner_terms`), robust in the first stage, kept in the polish while within
    ``inlier_sigmas`` of deviations that follow the pixels' noise (exact pixels: rays that passed
    stage 1's threshold without their lines meeting are then left out). The lines alone tell a
    near-central rig's translation direction poorly; on the benchmark's first 20 hyperbolic pairs
    at 2 px its median error fell from 2.2 to 0.7 degree with them. The ``cost`` reported is then
    the pixels' alone (candidates with different meetings are ranked by their pixels).

    ``hold_scale``: both stages hold the scene's scale (the baseline's length with every line's
    distance) where ``start.t`` puts it, and free it after the polish only if the pixels fix it
    (deviation of its logarithm below ``release_scale``). :func:`~catadioptric.pose.relative_pose`
    holds it through :func:`~catadioptric.pose.scale.refine_far_or_free`, with the scene moved
    far away and ``release_scale=0``, and compares that fit with the free one. Held where the
    start's scale search put it (mostly a bound of its range, 0.25 or 64 m) it gave the
    hyperbolic pairs 0-19 at 2 px 0.143 degree (0.291 free), but on the box scene of
    tests/test_relative_pose.py at 1 px, held at 64 m, 1.24 degree (0.07 free).
    """
    o = options
    check_residuals(o.residuals)
    cam_a, cam_b, line_family = data.cam_a, data.cam_b, data.line_family
    uv_a = np.asarray(data.uv_a, float).reshape(-1, 2)
    uv_b = np.asarray(data.uv_b, float).reshape(-1, 2)
    owner_a = np.asarray(data.owner_a, int).reshape(-1)
    owner_b = np.asarray(data.owner_b, int).reshape(-1)
    if len(uv_b) < 3:
        raise CatadioptricError(f"uv_b: expected pixels of lines seen in both views, got {len(uv_b)}")
    uv = np.concatenate([uv_a, uv_b])
    owner = np.concatenate([owner_a, owner_b])
    view = np.concatenate([np.zeros(len(uv_a), int), np.ones(len(uv_b), int)])
    centres = data.centres
    if centres is None:
        centres = (_rays_centre(cam_a, uv_a), _rays_centre(cam_b, uv_b))
    corners, corner_sigma = check_corners(data.corners, data.corner_sigma, np.asarray(line_family, int).reshape(-1))
    R = np.asarray(start.R, float)
    pb = RESIDUALS[o.residuals](cam_a, cam_b, np.asarray(start.directions, float), np.asarray(start.points, float),
                                line_family, uv, owner, view, centres, R, start.t, o.warm_start, corners, corner_sigma)
    y = pb.start()
    # starting depths: each pixel's ray closest to its line (B's rays moved into A)
    s, _, _, rho, u, _, _, k = pb.parts(y)
    q = pb.ca + k * u / rho[:, None]
    t = pb.translation(R, y)
    ra, rb = cam_a.backproject(uv_a), cam_b.backproject(uv_b)
    rays_o = np.concatenate([ra.origins, (rb.origins - t) @ R])
    rays_d = np.concatenate([ra.directions, rb.directions @ R])
    ql, sl = q[owner], s[pb.fam[owner]]
    rays_o, rays_d = np.nan_to_num(rays_o), np.nan_to_num(rays_d)
    w0 = ql - rays_o
    bb = np.sum(sl * rays_d, 1)
    lam0 = (bb * np.sum(rays_d * w0, 1) - np.sum(sl * w0, 1)) / np.maximum(1 - bb * bb, 1e-12)
    mu = np.clip(lam0 * rho[owner] / k, -MU_MAX, MU_MAX)
    mask = np.ones(len(uv), dtype=bool)
    sigma_cost, c2, pixel_sigma, inlier_sigmas = o.sigma_cost, o.c2, o.pixel_sigma, o.inlier_sigmas
    R, y, mu, cost, it1 = _lm(pb, R, y, mu, sigma_cost, c2, o.robust, mask, o.max_iter, o.tol_chi2, o.settle_depths,
                              o.hold_scale)
    e, _, _ = pb.evaluate(R, y, mu, jac=False)
    if len(pb.corners):
        cost = _weights(e, sigma_cost, c2, o.robust, mask)[1]
    dist = np.linalg.norm(e, axis=1)
    fin = np.isfinite(dist)
    if pixel_sigma is not None:
        noise = pixel_sigma
    else:
        sig = float(np.median(dist[fin]) / HALF_NORMAL_MEDIAN) if fin.any() else sigma_cost
        noise = max(sig, 1e-9 * sigma_cost)
    # the meetings' deviations follow the pixels' noise where it is below the robust stage's scale
    # (exact pixels: the rays that passed stage 1's threshold without meeting are then outliers)
    pb.corner_sigma = pb.corner_sigma * min(1.0, noise / sigma_cost)
    cmask = np.abs(pb.corner_residuals(R, y)) <= inlier_sigmas
    inl = fin & (dist <= inlier_sigmas * noise)
    if inl[view == 1].sum() < 3:
        inl = fin
    # with exact pixels the polish goes on to the last digits
    tol_polish = o.tol_chi2 * min(1.0, noise / sigma_cost) ** 2
    R, y, mu, _, it2 = _lm(pb, R, y, mu, noise, c2, False, inl, 2 * o.max_iter - it1, tol_polish, o.settle_depths,
                           o.hold_scale, cmask)
    S, sigma, dist, inl = _information(pb, R, y, mu, inl, cmask, c2, pixel_sigma)
    cov_y = _covariance(S, sigma)
    if o.hold_scale and np.sqrt(cov_y[5, 5]) < o.release_scale:
        # the pixels fix the scale: freed, where Levenberg-Marquardt no longer crawls along a valley
        R, y, mu, _, it3 = _lm(pb, R, y, mu, noise, c2, False, inl, 2 * o.max_iter, tol_polish, o.settle_depths,
                               False, cmask)
        it2 += it3
        S, sigma, dist, inl = _information(pb, R, y, mu, inl, cmask, c2, pixel_sigma)
        cov_y = _covariance(S, sigma)
    Jwt = pb.jacobian_wt(R, y)
    cov = Jwt @ cov_y[:6, :6] @ Jwt.T
    s, _, _, rho, u, _, _, k = pb.parts(y)
    q = pb.ca + k * u / rho[:, None]
    sl = s[pb.fam]
    q = q - np.sum(q * sl, 1, keepdims=True) * sl
    rms = np.array([float(np.sqrt(np.mean(dist[inl & (view == v)] ** 2))) if np.any(inl & (view == v)) else np.nan
                    for v in (0, 1)])
    return TwoViewFit(R=R, t=pb.translation(R, y), cov=cov, directions=s, points=q, sigma=sigma, cost=cost,
                      rms_px=rms, inliers_a=inl[view == 0], inliers_b=inl[view == 1],
                      n_pixels=np.array([int(np.sum(inl & (view == v))) for v in (0, 1)]), iterations=it1 + it2,
                      line_family=pb.fam.copy())


def _information(pb, R, y, mu, inl, cmask, c2, pixel_sigma):
    """The information ``S`` on the unknowns at a state (pixels: the inliers ``inl`` still imaged;
    meetings: ``cmask``), the pixel noise (given, or from the residuals), each pixel's distance and
    the inliers kept."""
    e, A, b = pb.evaluate(R, y, mu)
    dist = np.linalg.norm(e, axis=1)
    inl = inl & np.isfinite(dist)
    S, _, _, _, _ = _normal_equations(pb, A, b, np.nan_to_num(e), inl.astype(float), 0.0)
    dof = int(inl.sum()) - pb.ny  # two residuals and one depth per pixel
    rss = float(np.sum(dist[inl] ** 2))
    sigma = pixel_sigma if pixel_sigma is not None else (float(np.sqrt(rss / dof)) if dof > 0 else float("nan"))
    Sc = _corner_system(pb, R, y, sigma, c2, False, cmask)[0]
    if Sc is not None and np.isfinite(sigma):
        S = S + Sc
    return S, sigma, dist, inl


def _covariance(S, sigma):
    """Inverse of the information on the unknowns the pixels see, times ``sigma^2``; an unknown they
    do not see at all (zero information) gets an infinite variance, one they barely see an
    enormous one."""
    seen = np.diag(S) > 0
    cov_y = np.full(S.shape, np.nan)
    np.fill_diagonal(cov_y, np.inf)
    sc = np.sqrt(np.diag(S)[seen])
    ev, V = np.linalg.eigh(S[np.ix_(seen, seen)] / np.outer(sc, sc))
    ev = np.maximum(ev, 1e-15 * max(ev.max(), 1e-300))
    cov_y[np.ix_(seen, seen)] = (V / ev) @ V.T / np.outer(sc, sc) * sigma**2
    return cov_y


def _rays_centre(cam, uv) -> np.ndarray:
    """The point nearest the rays of pixels ``uv``."""
    r = cam.backproject(uv)
    o, d = r.origins[r.valid], r.directions[r.valid]
    if len(o) < 2:
        return np.zeros(3)
    P = np.eye(3) - d[:, :, None] * d[:, None, :]
    c = np.linalg.lstsq(P.sum(0), np.einsum("nij,nj->i", P, o), rcond=None)[0]
    return c if np.all(np.isfinite(c)) and np.linalg.norm(c) < 1e3 * cam.mirror.scale else np.mean(o, axis=0)
