"""3-D lines from the pixels of one non-central catadioptric image; families of parallel lines;
vanishing points from image curves.

A non-central camera sees a 3-D line from many viewpoints at once (the reflection
points), so one image fixes the whole line, position included (Miraldo, Eiras,
Ramalingam, CVPR 2018, Sec. 5.4, who found the route brittle). The fit here:

1. **Linear start.** Each pixel's reflected ray, Pluecker ``(d_j, o_j x d_j)``, meets the
   line ``(s, m)``: ``s . (o_j x d_j) + d_j . m = 0``, homogeneous and linear in
   ``(s, m)``. The two smallest right singular vectors span the candidates; the
   Pluecker constraint ``s . m = 0`` on their combination is a quadratic whose two real
   roots are lines meeting every ray. Axial rigs (camera on the mirror axis, and every
   sphere rig: all rays meet the line through the camera and the sphere's centre) have
   that axis as a second exact solution; the candidate with the smaller image error
   is kept. Four pixels are the minimal set (RANSAC).
   Near-central rigs make that system nearly rank-deficient (all rays nearly meet at
   one point); lines in the plane through that point that best holds the rays are
   added as candidates.
2. **Refinement** by ``scipy.optimize.least_squares`` over the line (4 DOF: direction in
   its tangent plane; the foot of the perpendicular from the rays' centre in inverse
   distance coordinates) and one depth per pixel: residual ``project(q + lambda_j s) - uv_j``
   (the image branch nearest the observed pixel), sparse analytic Jacobian from
   Fermat's principle (or finite differences with ``jac_sparsity``).
3. **Robustness**: RANSAC over minimal sets, a robust loss, inliers by image distance,
   then a plain least-squares polish on the inliers so that the reported covariance
   (Schur complement over the depths) describes the estimator actually used.

Central cameras (every ray through one viewpoint) see a line only through its
interpretation plane: its position and its direction within that plane are lost,
and the fits raise :class:`CatadioptricError` (use :func:`fit_interpretation_plane`;
parallel lines still give their direction and vanishing points). See docs/linefit.md.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.optimize import least_squares

from ._checks import CatadioptricError, as_float_array, as_scalar
from .cameras import CatadioptricCamera

__all__ = [
    "LineFit", "FamilyFit", "CurveVanishingPoints", "InterpretationPlane",
    "fit_line", "fit_parallel_lines", "vanishing_points_from_curves", "fit_interpretation_plane",
    "direction_from_planes",
    "line_candidates", "image_distances", "project_with_jacobian", "segment_pixels", "family_pixels",
    "accuracy_table", "REFERENCE_SEGMENTS", "REFERENCE_FAMILIES",
]

_LOSSES = ("linear", "soft_l1", "huber", "cauchy", "arctan")
_RAYLEIGH_MEDIAN = np.sqrt(2.0 * np.log(2.0))  # median of |e| for a 2-D Gaussian error of unit sigma


# --------------------------------------------------------------------------- results
@dataclass
class LineFit:
    """A 3-D line fitted to the pixels of its image (mirror frame M, metres).

    ``direction`` (unit ``s``), ``moment`` (``m = q x s``), ``point`` (``q``, the point of
    the line closest to the origin of M). Per input pixel (M of them): ``depths``
    (``point + depths[j] * direction`` is the point pixel j sees), ``points (M, 3)``,
    ``uv_fit (M, 2)`` (its image, the branch nearest the pixel), ``distances`` (pixels),
    ``inliers`` (bool). ``rms``: root mean square image distance over the inliers.
    ``sigma``: pixel noise used for the covariances (given, or estimated from the
    inlier residuals). ``direction_cov (3, 3)`` (rank 2, tangent to the unit sphere) and
    ``pluecker_cov (6, 6)`` of ``(s, m)``; ``dof`` = inliers - 4 (two residuals and one depth
    per pixel, four line parameters). ``n_hypotheses``: candidate lines scored; ``nfev``:
    residual evaluations of the least-squares stages.
    The direction is oriented from the first inlier's point towards the last one's.
    """

    direction: np.ndarray
    moment: np.ndarray
    point: np.ndarray
    depths: np.ndarray
    points: np.ndarray
    uv_fit: np.ndarray
    distances: np.ndarray
    inliers: np.ndarray
    rms: float
    sigma: float
    direction_cov: np.ndarray
    pluecker_cov: np.ndarray
    dof: int
    n_hypotheses: int = 0
    nfev: int = 0

    @property
    def pluecker(self) -> np.ndarray:
        """``(s, m)`` as a 6-vector."""
        return np.concatenate([self.direction, self.moment])

    @property
    def moment_cov(self) -> np.ndarray:
        return self.pluecker_cov[3:, 3:]

    @property
    def direction_std(self) -> float:
        """Root of the trace of ``direction_cov``: the direction's standard error in radians."""
        return float(np.sqrt(max(np.trace(self.direction_cov), 0.0)))


@dataclass
class FamilyFit:
    """Parallel 3-D lines fitted jointly: one ``direction`` (unit, ``direction_cov (3, 3)``),
    per line a ``moment`` and ``point`` ``(L, 3)``; per line lists (one entry per pixel set)
    of ``depths``, ``points``, ``uv_fit``, ``distances``, ``inliers``. ``rms`` over all inliers,
    ``rms_per_line (L,)``; ``sigma`` as in :class:`LineFit`; ``pluecker_cov (L, 6, 6)`` of each
    line's ``(s, m)``; ``cov`` is the covariance of the (2 + 2 L) parameters of the fit (the
    direction's tangent coordinates, then each line's angle and inverse distance about
    the rays' centre, see ``_Problem``) after the Schur complement over the depths;
    ``dof`` = inliers - 2 - 2 L. The direction is oriented as line 0's first inlier to its
    last one."""

    direction: np.ndarray
    moments: np.ndarray
    points: np.ndarray
    depths: list
    line_points: list
    uv_fit: list
    distances: list
    inliers: list
    rms: float
    rms_per_line: np.ndarray
    sigma: float
    direction_cov: np.ndarray
    pluecker_cov: np.ndarray
    cov: np.ndarray
    dof: int
    nfev: int = 0

    @property
    def n_lines(self) -> int:
        return len(self.moments)

    @property
    def direction_std(self) -> float:
        return float(np.sqrt(max(np.trace(self.direction_cov), 0.0)))

    def line(self, i: int) -> tuple[np.ndarray, np.ndarray]:
        """``(point, direction)`` of line ``i``."""
        return self.points[i], self.direction


@dataclass
class CurveVanishingPoints:
    """Vanishing points of a family of parallel lines found from their image curves.

    ``direction`` and ``direction_cov`` from the joint fit (``family``). ``uv (K, 2)``,
    ``sign (K,)`` (+1 the point of ``+direction``, -1 of ``-direction``, 0 empty), ``visible``,
    ``in_image`` as :meth:`CatadioptricCamera.vanishing_points` with ``which="both"``.
    ``individual`` holds each line's own fit; ``individual_uv (L, K, 2)`` the vanishing
    point of each individually fitted direction (oriented like the joint one) matched
    to each joint point (same sign, nearest pixel; NaN when that line's curve has none
    there). ``spread_max (K,)`` and ``spread_rms (K,)``: max and rms pixel distance of the
    individual points from the joint one (NaN where none matched). ``uv_cov (K, 2, 2)``:
    the joint point's covariance in pixels, propagated from ``direction_cov``.
    Central cameras: ``family`` is None, ``individual`` holds each curve's
    :class:`InterpretationPlane` and ``individual_uv (L (L - 1) / 2, K, 2)`` the vanishing points
    of each pair of curves (where the two fitted curves cross).
    """

    direction: np.ndarray
    direction_cov: np.ndarray
    uv: np.ndarray
    sign: np.ndarray
    visible: np.ndarray
    in_image: np.ndarray
    uv_cov: np.ndarray
    individual_uv: np.ndarray
    spread_max: np.ndarray
    spread_rms: np.ndarray
    family: FamilyFit | None
    individual: list

    def observable(self) -> np.ndarray:
        """Indices of the vanishing points that are visible and on the image."""
        return np.nonzero(self.visible & self.in_image)[0]


@dataclass
class InterpretationPlane:
    """The plane through a central camera's viewpoint that holds a 3-D line:
    unit ``normal``, ``viewpoint``, ``normal_cov (3, 3)``, ``rms`` (pixels), ``inliers``."""

    normal: np.ndarray
    viewpoint: np.ndarray
    normal_cov: np.ndarray
    rms: float
    distances: np.ndarray
    inliers: np.ndarray


# --------------------------------------------------------------------------- small helpers
def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _tangent_basis(s):
    """Two unit vectors ``e1, e2`` with ``(e1, e2, s)`` right-handed orthonormal, for unit ``s (..., 3)``."""
    s = np.asarray(s, dtype=float)
    a = np.where((np.abs(s[..., 0]) < 0.8)[..., None], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    e1 = _unit(np.cross(a, s))
    e2 = np.cross(s, e1)
    return e1, e2


def _check_camera(cam, what: str):
    if not isinstance(cam, CatadioptricCamera):
        raise CatadioptricError(f"cam: expected a CatadioptricCamera, got {type(cam).__name__}")
    if cam.is_central:
        raise CatadioptricError(
            f"cam: the camera is central (every ray passes through the viewpoint "
            f"{np.round(cam.viewpoint, 6).tolist()}): one image fixes only the plane through the viewpoint "
            f"that holds the line, not {what}; use fit_interpretation_plane (and vanishing_points_from_curves "
            f"for two or more parallel lines)"
        )


def _check_uv(uv, name: str, min_pixels: int = 5) -> np.ndarray:
    a = as_float_array(uv, name, 2)
    if a.ndim != 2:
        raise CatadioptricError(f"{name}: expected an array of shape (M, 2), got an array of shape {a.shape}")
    if len(a) < min_pixels:
        raise CatadioptricError(f"{name}: expected at least {min_pixels} pixels, got {len(a)}")
    return a


def _check_options(loss, f_scale, pixel_sigma, inlier_threshold):
    if loss not in _LOSSES:
        raise CatadioptricError(f"loss: expected one of {list(_LOSSES)}, got {loss!r}")
    f_scale = as_scalar(f_scale, "f_scale", positive=True)
    if pixel_sigma is not None:
        pixel_sigma = as_scalar(pixel_sigma, "pixel_sigma", positive=True)
    if inlier_threshold is not None:
        inlier_threshold = as_scalar(inlier_threshold, "inlier_threshold", positive=True)
    return f_scale, pixel_sigma, inlier_threshold


def _check_fit_options(jac, max_trials, f_scale, pixel_sigma, inlier_threshold) -> float:
    """Checks shared by the fits; returns the RANSAC inlier threshold in pixels."""
    if jac not in ("analytic", "2-point", "3-point"):
        raise CatadioptricError(f"jac: expected 'analytic', '2-point' or '3-point', got {jac!r}")
    if not (isinstance(max_trials, (int, np.integer)) and max_trials >= 1):
        raise CatadioptricError(f"max_trials: expected a positive integer, got {max_trials!r}")
    if inlier_threshold is not None:
        return inlier_threshold
    return 3.5 * pixel_sigma if pixel_sigma is not None else 3.0 * f_scale


def _rng(seed):
    if isinstance(seed, np.random.Generator):
        return seed
    if seed is None or isinstance(seed, (int, np.integer)):
        return np.random.default_rng(seed)
    raise CatadioptricError(f"seed: expected an int, None or a numpy Generator, got {type(seed).__name__}")


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


# --------------------------------------------------------------------------- linear solver
@dataclass
class _RayFrame:
    """Rays of the valid pixels in a normalised frame: origin ``x0`` (the point nearest all
    rays), moment scale ``eps`` (rms distance of the rays from ``x0``)."""

    o: np.ndarray
    d: np.ndarray
    x0: np.ndarray
    eps: float


def _ray_frame(cam, o, d) -> _RayFrame:
    proj = np.eye(3) - d[:, :, None] * d[:, None, :]
    A = proj.sum(axis=0)
    b = np.einsum("nij,nj->i", proj, o)
    try:
        x0 = np.linalg.solve(A, b)
        if not np.all(np.isfinite(x0)) or np.linalg.norm(x0) > 1e3 * cam.mirror.scale:
            raise np.linalg.LinAlgError
    except np.linalg.LinAlgError:
        x0 = np.mean(o, axis=0)
    mom = np.cross(o - x0, d)
    eps = float(np.sqrt(np.mean(np.sum(mom**2, axis=-1))))
    eps = max(eps, 1e-9 * cam.mirror.scale)
    return _RayFrame(o, d, x0, eps)


def _candidates_from_rays(frame: _RayFrame, o, d):
    """Candidate lines ``(s, m)`` meeting rays ``o, d (S, k, 3)`` (k >= 4); returns ``L (S, 3, 6)``
    (unit s, Pluecker exact) and ``ok (S, 3)``. Candidates: the two real roots of the
    Pluecker quadratic on the span of the two smallest right singular vectors (or its
    best real approximation), and the smallest singular vector made Pluecker."""
    o = o - frame.x0
    rows = np.concatenate([np.cross(o, d) / frame.eps, d], axis=-1)  # unknowns (eps s, m')
    rows = rows / np.maximum(np.linalg.norm(rows, axis=-1, keepdims=True), 1e-300)
    _, _, Vt = np.linalg.svd(rows, full_matrices=rows.shape[-2] < 6)
    v1, v2 = Vt[:, -1, :], Vt[:, -2, :]
    a1, b1, a2, b2 = v1[:, :3], v1[:, 3:], v2[:, :3], v2[:, 3:]
    q11 = np.sum(a1 * b1, axis=-1)
    q22 = np.sum(a2 * b2, axis=-1)
    q12 = 0.5 * (np.sum(a1 * b2, axis=-1) + np.sum(a2 * b1, axis=-1))
    Q = np.stack([np.stack([q11, q12], -1), np.stack([q12, q22], -1)], -2)
    lam, U = np.linalg.eigh(Q)  # ascending
    real = lam[:, 0] * lam[:, 1] <= 0
    sq0 = np.sqrt(np.abs(lam[:, 1]))  # weight of eigvec 0
    sq1 = np.sqrt(np.abs(lam[:, 0]))
    c_plus = U[:, :, 0] * sq0[:, None] + U[:, :, 1] * sq1[:, None]
    c_minus = U[:, :, 0] * sq0[:, None] - U[:, :, 1] * sq1[:, None]
    # no real root: the combination nearest to isotropic (eigenvector of smaller |eigenvalue|)
    small = np.where((np.abs(lam[:, 0]) < np.abs(lam[:, 1]))[:, None], U[:, :, 0], U[:, :, 1])
    c_plus = np.where(real[:, None], c_plus, small)
    combos = np.stack([c_plus, c_minus, np.tile([1.0, 0.0], (len(v1), 1))], axis=1)  # (S, 3, 2)
    y = combos[..., 0:1] * v1[:, None, :] + combos[..., 1:2] * v2[:, None, :]
    s = y[..., :3] / frame.eps
    mp = y[..., 3:]
    ok = np.ones(s.shape[:2], dtype=bool)
    ok[:, 1] = real
    ns = np.linalg.norm(s, axis=-1)
    ok &= ns > 1e-12 * np.maximum(np.linalg.norm(mp, axis=-1), 1e-300)
    with np.errstate(divide="ignore", invalid="ignore"):
        s = s / ns[..., None]
        mp = mp / ns[..., None]
        mp = mp - np.sum(s * mp, axis=-1, keepdims=True) * s  # exact Pluecker
    m = mp + np.cross(frame.x0, s)
    L = np.concatenate([s, m], axis=-1)
    ok &= np.all(np.isfinite(L), axis=-1)
    return L, ok


def _plane_candidates(frame: _RayFrame, o, d, n_angles: int, default_distance: float):
    """Near-central candidates for rays ``o, d (S, k, 3)`` (k >= 2): the lines in the plane through
    ``x0`` that holds the rays' directions best, with ``n_angles`` directions spread over
    the range that keeps every ray on one side (a line seen from ``x0`` spans 180 degrees)
    and the offset from ``x0`` that best meets the rays (``default_distance`` when that
    is not positive). Returns ``L (S, n_angles, 6)`` and ``ok``."""
    _, _, Vt = np.linalg.svd(d, full_matrices=d.shape[-2] < 3)
    n = Vt[:, -1, :]
    a, b = _tangent_basis(n)
    th = np.arctan2(np.einsum("skj,sj->sk", d, b), np.einsum("skj,sj->sk", d, a))
    ths = np.sort(th, axis=1)
    gaps = np.diff(np.concatenate([ths, ths[:, :1] + 2 * np.pi], axis=1), axis=1)
    g = np.argmax(gaps, axis=1)
    rows = np.arange(len(ths))
    start = ths[rows, (g + 1) % ths.shape[1]]
    span = 2 * np.pi - gaps[rows, g]
    free = np.maximum(np.pi - span, 0.0)
    frac = (np.arange(n_angles) + 0.5) / n_angles
    phi = (start + span)[:, None] + frac[None, :] * free[:, None]  # (S, n_angles)
    s = np.cos(phi)[..., None] * a[:, None, :] + np.sin(phi)[..., None] * b[:, None, :]
    u = np.cross(n[:, None, :], s)
    dm = np.mean(d, axis=1)
    u = u * np.where(np.sum(u * dm[:, None, :], axis=-1) < 0, -1.0, 1.0)[..., None]
    w = np.cross(u, s)  # q' = h u  =>  m' = h (u x s) = h w
    Mom = np.cross(o - frame.x0, d)  # (S, k, 3)
    sm = np.einsum("sai,ski->sak", s, Mom)
    dw = np.einsum("sai,ski->sak", w, d)
    with np.errstate(invalid="ignore", divide="ignore"):
        h = -np.sum(sm * dw, axis=-1) / np.sum(dw * dw, axis=-1)
    bad = ~np.isfinite(h) | (h <= 0.1 * default_distance) | (h > 1e2 * default_distance)
    h = np.where(bad, default_distance, h)
    q = frame.x0 + h[..., None] * u
    L = np.concatenate([s, np.cross(q, s)], axis=-1)
    ok = np.all(np.isfinite(L), axis=-1) & (span < np.pi)[:, None]
    return L, ok


def _all_candidates(cam, frame, o, d, n_angles=8):
    """Every candidate from one set of rays ``(k, 3)``: ``(n, 6)``."""
    L1, ok1 = _candidates_from_rays(frame, o[None], d[None])
    L2, ok2 = _plane_candidates(frame, o[None], d[None], n_angles, 10.0 * cam.mirror.scale)
    return np.concatenate([L1[0][ok1[0]], L2[0][ok2[0]]])


def line_candidates(cam: CatadioptricCamera, uv) -> np.ndarray:
    """Lines ``(n, 6)`` (Pluecker ``(s, m)``, unit ``s``) meeting the back-projected rays of pixels
    ``uv (M, 2)`` (M >= 4): the roots of the Pluecker constraint on the two-dimensional
    near-null space of ``s . (o_j x d_j) + d_j . m = 0`` and the least-squares null vector
    (see the module docstring), then the near-central candidates (lines in the plane
    through the rays' centre that holds the rays). The true line is among them for exact
    pixels; with noise they are starting points. Pixels that do not see the world are
    ignored."""
    _check_camera(cam, "the line")
    uv = _check_uv(uv, "uv", 4)
    rays = cam.backproject(uv)
    if int(rays.valid.sum()) < 4:
        raise CatadioptricError(f"uv: expected at least 4 pixels that see the world, got {int(rays.valid.sum())}")
    o, d = rays.origins[rays.valid], rays.directions[rays.valid]
    fr = _ray_frame(cam, o, d)
    return _all_candidates(cam, fr, o, d)


# --------------------------------------------------------------------------- image distances for fixed lines
def _closest_depths(q, s, o, d):
    """Parameter along ``q + lambda s`` of the point closest to the ray ``o + t d``
    (broadcast; unit ``s``, ``d``)."""
    w0 = q - o
    b = np.sum(s * d, axis=-1)
    dd = np.sum(s * w0, axis=-1)
    e = np.sum(d * w0, axis=-1)
    den = np.maximum(1.0 - b * b, 1e-12)
    return (b * e - dd) / den


def _depth_refine(cam, q, s, uv, lam, iters: int = 4, step_cap=None):
    """Gauss-Newton on the depth of each pixel on fixed lines: ``q, s (..., 3)``, ``uv (..., 2)``,
    ``lam (...)`` broadcast together. Returns ``lam``, ``dist`` (pixels, inf where no image),
    ``uv_fit``, ``visible``."""
    shape = np.broadcast_shapes(q.shape[:-1], s.shape[:-1], uv.shape[:-1], np.shape(lam))
    q = np.broadcast_to(q, shape + (3,)).reshape(-1, 3)
    s = np.broadcast_to(s, shape + (3,)).reshape(-1, 3)
    uvf = np.broadcast_to(uv, shape + (2,)).reshape(-1, 2)
    lam = np.broadcast_to(lam, shape).reshape(-1).copy()
    if step_cap is None:
        step_cap = np.linalg.norm(q + lam[:, None] * s, axis=-1) * 0.5 + cam.mirror.scale
    for it in range(iters + 1):
        P = q + lam[:, None] * s
        uvp, G, vis = project_with_jacobian(cam, P, uvf)
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
    uv = _check_uv(uv, "uv", 1)
    rays = cam.backproject(uv)
    lam0 = _closest_depths(q, s, np.nan_to_num(rays.origins), np.nan_to_num(rays.directions))
    lam, dist, _, _ = _depth_refine(cam, q, s, uv, lam0, iters)
    dist = np.where(rays.valid, dist, np.inf)
    return dist, lam


def _score_lines(cam, L, uv, o, d, iters=3):
    """Image distances ``(H, M)`` of pixels to lines ``L (H, 6)`` and the depths."""
    s = L[:, :3]
    q = np.cross(s, L[:, 3:])
    lam0 = _closest_depths(q[:, None, :], s[:, None, :], o[None], d[None])
    lam, dist, _, _ = _depth_refine(cam, q[:, None, :], s[:, None, :], uv[None], lam0, iters)
    return dist, lam


# --------------------------------------------------------------------------- the joint least-squares problem
class _Problem:
    """Lines sharing one direction, in inverse-distance coordinates about a centre ``x0`` (the
    point nearest all rays). Unknowns ``x = [a, b, (alpha_i, rho_i) per line, mu_j per pixel]``:

    * direction ``s = unit(s0 + a e1 + b e2)`` (``e1, e2`` orthonormal, normal to ``s0``);
    * line i: foot of the perpendicular from ``x0`` at ``x0 + u_i / rho_i``,
      ``u_i = cos(alpha_i) e1 + sin(alpha_i) e2``; ``rho_i`` is the inverse distance;
    * pixel j of line i sees ``P_j = x0 + (u_i + mu_j s) / rho_i`` (``mu_j`` is the tangent of
      the angle at ``x0`` between the perpendicular and the point).

    A near-central camera barely sees ``rho_i``: the image of a far line depends on its
    plane through ``x0`` (``alpha_i``, ``s``) and hardly on its distance. In these
    coordinates that weak direction is smooth up to ``rho -> 0`` (the line at infinity)
    instead of running off to infinity. Residual: the image of ``P_j`` (branch nearest
    ``uv_j``) minus ``uv_j``."""

    def __init__(self, cam, uv, owner, n_lines, x0, s0, q0, lam0):
        self.cam = cam
        self.uv = uv
        self.owner = owner
        self.L = n_lines
        self.x0c = np.asarray(x0, dtype=float)
        self.s0 = _unit(np.asarray(s0, dtype=float))
        self.e1, self.e2 = _tangent_basis(self.s0)
        q0 = np.asarray(q0, dtype=float).reshape(n_lines, 3)
        v = q0 - self.x0c
        along = v @ self.s0
        foot = v - along[:, None] * self.s0  # from x0 to the foot, normal to s0
        dist = np.maximum(np.linalg.norm(foot, axis=-1), 1e-9 * cam.mirror.scale)
        self.rho0 = 1.0 / dist
        self.alpha0 = np.arctan2(foot @ self.e2, foot @ self.e1)
        self.mu0 = (np.asarray(lam0, dtype=float) + along[owner]) * self.rho0[owner]
        self.N = len(uv)
        self.np = 2 + 2 * n_lines
        self.n = self.np + self.N
        self.rho_min = 1e-6 / cam.mirror.scale
        self.penalty = 2.0 * float(np.hypot(cam.pinhole.width, cam.pinhole.height))
        self._cache_x = None
        self.nfev = 0
        rows = np.repeat(np.arange(2 * self.N), 5)
        cols = np.empty((self.N, 2, 5), dtype=np.int64)
        cols[:, :, 0] = 0
        cols[:, :, 1] = 1
        cols[:, :, 2] = (2 + 2 * owner)[:, None]
        cols[:, :, 3] = (3 + 2 * owner)[:, None]
        cols[:, :, 4] = (self.np + np.arange(self.N))[:, None]
        self._rows, self._cols = rows, cols.reshape(-1)

    def x0(self):
        lines = np.stack([self.alpha0, np.maximum(self.rho0, 2 * self.rho_min)], axis=1).reshape(-1)
        return np.concatenate([np.zeros(2), lines, self.mu0])

    def bounds(self):
        lo = np.full(self.n, -np.inf)
        lo[3:self.np:2] = self.rho_min
        return lo, np.full(self.n, np.inf)

    def _parts(self, x):
        v = self.s0 + x[0] * self.e1 + x[1] * self.e2
        nv = np.linalg.norm(v)
        s = v / nv
        al = x[2:self.np:2]
        rho = x[3:self.np:2]
        u = np.cos(al)[:, None] * self.e1 + np.sin(al)[:, None] * self.e2
        return s, nv, al, rho, u, x[self.np:]

    def unpack(self, x):
        """``(s, q (L, 3), lam (N,), nv)``: the feet of the perpendiculars and depths from them."""
        s, nv, al, rho, u, mu = self._parts(x)
        return s, self.x0c + u / rho[:, None], mu / rho[self.owner], nv

    def _eval(self, x):
        if self._cache_x is not None and np.array_equal(x, self._cache_x):
            return self._cache
        s, nv, al, rho, u, mu = self._parts(x)
        rj = rho[self.owner]
        P = self.x0c + (u[self.owner] + mu[:, None] * s) / rj[:, None]
        uvp, G, vis = project_with_jacobian(self.cam, P, self.uv)
        self.nfev += 1
        self._cache_x = x.copy()
        self._cache = (s, nv, al, rho, u, mu, P, uvp, G, vis)
        return self._cache

    def residuals(self, x):
        uvp = self._eval(x)[7]
        e = uvp - self.uv
        bad = ~np.all(np.isfinite(e), axis=-1)
        e[bad] = self.penalty
        return e.reshape(-1)

    def jac_blocks(self, x):
        """Per pixel ``(N, 2, 5)``: derivatives by a, b, alpha_i, rho_i, mu_j."""
        s, nv, al, rho, u, mu, P, uvp, G, vis = self._eval(x)
        ds_da = (self.e1 - s * (s @ self.e1)) / nv
        ds_db = (self.e2 - s * (s @ self.e2)) / nv
        rj = rho[self.owner]
        alj = al[self.owner]
        du = -np.sin(alj)[:, None] * self.e1 + np.cos(alj)[:, None] * self.e2
        dP = np.empty((self.N, 3, 5))
        dP[:, :, 0] = (mu / rj)[:, None] * ds_da
        dP[:, :, 1] = (mu / rj)[:, None] * ds_db
        dP[:, :, 2] = du / rj[:, None]
        dP[:, :, 3] = -(P - self.x0c) / rj[:, None]
        dP[:, :, 4] = s / rj[:, None]
        J = G @ dP
        J[~np.all(np.isfinite(J), axis=(1, 2))] = 0.0
        return J

    def jacobian(self, x):
        J = self.jac_blocks(x)
        M = sp.csr_matrix((J.reshape(-1), (self._rows, self._cols)), shape=(2 * self.N, self.n))
        return M

    def sparsity(self):
        return sp.csr_matrix((np.ones(len(self._rows)), (self._rows, self._cols)), shape=(2 * self.N, self.n))

    def solve(self, loss, f_scale, jac="analytic", max_nfev=150):
        kw = dict(loss=loss, f_scale=f_scale, x_scale="jac", method="trf", ftol=1e-6, xtol=1e-10, gtol=1e-10,
                  max_nfev=max_nfev, bounds=self.bounds())
        if jac == "analytic":
            kw["jac"] = self.jacobian
            kw["tr_solver"] = "lsmr"
        else:
            kw["jac"] = jac
            kw["jac_sparsity"] = self.sparsity()
            kw["tr_solver"] = "lsmr"
        res = least_squares(self.residuals, self.x0(), **kw)
        return res.x

    def schur_cov(self, x, keep):
        """``(np, np)`` inverse of the normal matrix of the line parameters after eliminating the
        depths of the pixels in ``keep`` (unit pixel variance)."""
        J = self.jac_blocks(x)[keep]
        A = np.zeros((len(J), 2, self.np))
        own = self.owner[keep]
        A[:, :, 0:2] = J[:, :, 0:2]
        idx = np.arange(len(J))
        A[idx, :, 2 + 2 * own] = J[:, :, 2]
        A[idx, :, 3 + 2 * own] = J[:, :, 3]
        b = J[:, :, 4]
        Npp = np.einsum("nki,nkj->ij", A, A)
        Atb = np.einsum("nki,nk->ni", A, b)
        D = np.sum(b * b, axis=-1)
        D = np.where(D > 0, D, np.inf)
        S = Npp - np.einsum("ni,nj->ij", Atb / D[:, None], Atb)
        # a direction the pixels do not constrain (e.g. a line coplanar with the axis of an
        # axial rig) must come out with an enormous variance, not the zero of a pseudo-inverse
        sc = np.sqrt(np.maximum(np.diag(Npp), 1e-300))
        w, V = np.linalg.eigh(0.5 * (S + S.T) / np.outer(sc, sc))
        w = np.maximum(w, 1e-15 * max(w.max(), 1e-300))
        return (V / w) @ V.T / np.outer(sc, sc)


def _canonical(s, q, lam, owner):
    """Points of the lines nearest the origin, depths shifted to match."""
    t = np.sum(q * s, axis=-1)
    return q - t[:, None] * s, lam + t[owner]


def _solve_family(cam, uv_all, o, d, owner, n_lines, s0, q0, lam0, *, loss, f_scale, pixel_sigma,
                  inlier_threshold, jac="analytic", start_mask=None, x0=None, names=None):
    """Robust fit, inlier classification, least-squares polish on the inliers, covariance.

    ``uv_all (N, 2)`` pixels that see the world, ``o, d (N, 3)`` their rays, ``owner (N,)``
    their line (``names``: the argument each line's pixels came from, for errors). The
    first stage (``loss``) uses the pixels of ``start_mask`` (default all) with depths
    ``lam0``. The inliers are the pixels within the threshold of the fitted image
    (``inlier_threshold``, else ``3.5 pixel_sigma``, else ``3 max(f_scale, 1.2 sigma_r)`` with
    ``sigma_r`` from the median distance); a plain least-squares polish on them is
    repeated (at most three times) until they settle. Returns a dict."""
    names = names or [f"line {i}" for i in range(n_lines)]
    N = len(uv_all)
    use = np.ones(N, dtype=bool) if start_mask is None else np.asarray(start_mask, dtype=bool).copy()
    nfev = 0
    s = _unit(np.asarray(s0, dtype=float))
    q = np.asarray(q0, dtype=float).reshape(n_lines, 3)
    lam = np.asarray(lam0, dtype=float).copy()
    xc = _ray_frame(cam, o, d).x0 if x0 is None else np.asarray(x0, dtype=float)

    def solve(mask, loss_, s, q, lam):
        pb = _Problem(cam, uv_all[mask], owner[mask], n_lines, xc, s, q, lam[mask])
        x = pb.solve(loss_, f_scale, jac)
        s, q, lam_m, _ = pb.unpack(x)
        q, lam_m = _canonical(s, q, lam_m, owner[mask])
        lam = _closest_depths(q[owner], s, o, d)
        lam[mask] = lam_m
        return s, q, lam, pb.nfev

    def classify(s, q, lam, solved):
        """Distances of every pixel to the fitted images (depths of the pixels outside the
        solved set refined first) and the inliers."""
        P = q[owner] + lam[:, None] * s
        uvp, _, vis = project_with_jacobian(cam, P, uv_all)
        rest = ~solved
        if rest.any():
            lam = lam.copy()
            lam[rest], _, uvp[rest], vis[rest] = _depth_refine(cam, q[owner[rest]], s, uv_all[rest], lam[rest],
                                                               iters=2)
        dist = np.linalg.norm(uvp - uv_all, axis=-1)
        dist = np.where(np.isfinite(dist), dist, np.inf)
        thr = inlier_threshold
        if thr is None:
            d_in = dist[solved & np.isfinite(dist)]
            sig = float(np.median(d_in) / _RAYLEIGH_MEDIAN) if len(d_in) else f_scale
            thr = 3.5 * pixel_sigma if pixel_sigma is not None else 3.0 * max(f_scale, 1.2 * sig)
        new = dist <= thr
        for i in range(n_lines):
            if int(np.sum(new & (owner == i))) < 3:
                raise CatadioptricError(
                    f"{names[i]}: keeps fewer than 3 inlier pixels (threshold {thr:.3g} px); "
                    f"the pixels do not look like the image of one 3-D line")
        return lam, new, dist, uvp, vis, thr

    s, q, lam, k = solve(use, loss, s, q, lam)
    nfev += k
    lam, inl, dist, uvp, vis, thr = classify(s, q, lam, use)
    polished = loss == "linear" and np.array_equal(inl, use)
    for _round in range(3):  # least-squares polish on the inliers until they settle
        if polished:
            break
        s, q, lam, k = solve(inl, "linear", s, q, lam)
        nfev += k
        lam, new, dist, uvp, vis, thr = classify(s, q, lam, inl)
        polished = np.array_equal(new, inl)
        inl = new  # after the last round: the inliers of the final state
    # the chart re-centred at the solution (parameters zero) for the covariance
    pb = _Problem(cam, uv_all[inl], owner[inl], n_lines, xc, s, q, lam[inl])
    x = pb.x0()
    e = (uvp - uv_all)[inl]
    cov_unit = pb.schur_cov(x, np.ones(pb.N, dtype=bool))
    n_in = int(inl.sum())
    dof = n_in - pb.np
    rss = float(np.sum(e**2))
    if pixel_sigma is not None:
        sigma = pixel_sigma
    else:
        sigma = float(np.sqrt(rss / dof)) if dof > 0 else float("nan")
    cov = sigma**2 * cov_unit
    E = np.stack([pb.e1, pb.e2], axis=1)
    dir_cov = E @ cov[:2, :2] @ E.T
    # Pluecker (s, m) of each line by (a, b, alpha_i, rho_i) at the chart centre
    s_, _, al, rho, u, _ = pb._parts(x)
    jp = []
    for i in range(n_lines):
        qi = pb.x0c + u[i] / rho[i]
        du = -np.sin(al[i]) * pb.e1 + np.cos(al[i]) * pb.e2
        Jp = np.zeros((6, 4))
        Jp[:3, 0], Jp[:3, 1] = pb.e1, pb.e2
        Jp[3:, 0], Jp[3:, 1] = np.cross(qi, pb.e1), np.cross(qi, pb.e2)
        Jp[3:, 2] = np.cross(du / rho[i], s_)
        Jp[3:, 3] = np.cross(-u[i] / rho[i] ** 2, s_)
        sub = [0, 1, 2 + 2 * i, 3 + 2 * i]
        jp.append(Jp @ cov[np.ix_(sub, sub)] @ Jp.T)
    return dict(s=s, q=q, lam=lam, dist=dist, uv_fit=uvp, visible=vis, inliers=inl, cov=cov, dir_cov=dir_cov,
                pluecker_cov=jp, sigma=sigma, dof=dof, rss=rss, nfev=nfev, threshold=thr)


# --------------------------------------------------------------------------- RANSAC
@dataclass
class _Pixels:
    """The pixels that see the world, their rays and the rays' derivatives by the pixel
    (``Jo``, ``Jd (M, 3, 2)``) for the linearised image distance."""

    uv: np.ndarray
    o: np.ndarray
    d: np.ndarray
    Jo: np.ndarray
    Jd: np.ndarray


def _pixels(cam, uv) -> _Pixels:
    rays = cam.backproject(uv)
    h = 0.25
    Jo = np.empty(uv.shape[:-1] + (3, 2))
    Jd = np.empty(uv.shape[:-1] + (3, 2))
    for k in range(2):
        e = np.zeros(2)
        e[k] = h
        rp, rm = cam.backproject(uv + e), cam.backproject(uv - e)
        Jo[..., k] = (rp.origins - rm.origins) / (2 * h)
        Jd[..., k] = (rp.directions - rm.directions) / (2 * h)
    return _Pixels(uv, rays.origins, rays.directions, Jo, Jd), rays.valid


def _linear_distances(px: _Pixels, L):
    """First-order image distances ``(H, M)`` from pixels to lines ``L (H, 6)``: the point ``X`` of
    the line nearest each pixel's ray, at depth ``rho`` along it, is off the ray by ``dX``;
    the pixel displacement that moves the ray's point at depth ``rho`` by ``dX`` is
    ``pinv(Jo + rho Jd) dX``. Inf where ``X`` is behind the reflection point."""
    s = L[:, None, :3]
    q = np.cross(L[:, :3], L[:, 3:])[:, None, :]
    lam = _closest_depths(q, s, px.o[None], px.d[None])
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


def _ransac(cam, frame, px: _Pixels, rng, thr, max_trials, sample_size=4, batch=64):
    """Best line ``(6,)`` over random sets (MSAC cost ``sum min(dist^2, thr^2)`` with the
    linearised image distance): each sample gives the two lines of the 4-point Pluecker
    solver and a near-central line from 3 more pixels. Then a local optimisation (every
    candidate from the inliers of the best). Returns ``(L, inlier mask, hypotheses)``."""
    M = len(px.uv)
    o, d = px.o, px.d

    def score(L):
        dist = _linear_distances(px, L)
        return np.sum(np.minimum(dist**2, thr**2), axis=1), np.sum(dist <= thr, axis=1)

    L = _all_candidates(cam, frame, o, d)
    cost, cnt = score(L)
    j = int(np.argmin(cost))
    best_L, best_cost, best_cnt = L[j], cost[j], cnt[j]
    n_hyp = len(cost)
    trials, needed = 0, max_trials
    while trials < needed:
        nb = int(min(batch, needed - trials))
        perm = np.argsort(rng.random((nb, M)), axis=1)
        idx = perm[:, :sample_size]
        L, ok = _candidates_from_rays(frame, o[idx], d[idx])
        L, ok = L[:, :2], ok[:, :2]  # a minimal set: the two roots only
        idx3 = perm[:, sample_size:sample_size + 3] if M >= sample_size + 3 else perm[:, :3]
        Lp, okp = _plane_candidates(frame, o[idx3], d[idx3], 1, 10.0 * cam.mirror.scale)
        L = np.concatenate([L[ok], Lp[okp]])
        trials += nb
        if len(L) == 0:
            continue
        n_hyp += len(L)
        cost, cnt = score(L)
        j = int(np.argmin(cost))
        if cost[j] < best_cost:
            best_L, best_cost, best_cnt = L[j], cost[j], cnt[j]
        w = best_cnt / M
        if w >= 1:
            needed = trials
        elif w > 0:
            needed = min(max_trials, int(np.ceil(np.log(0.01) / np.log1p(-w**sample_size))))
    for _ in range(3):  # local optimisation
        inl = _linear_distances(px, best_L[None])[0] <= thr
        if inl.sum() < 5:
            break
        L = _all_candidates(cam, frame, o[inl], d[inl])
        if len(L) == 0:
            break
        n_hyp += len(L)
        cost, _ = score(L)
        j = int(np.argmin(cost))
        if cost[j] >= best_cost:
            break
        best_L, best_cost = L[j], cost[j]
    return best_L, _linear_distances(px, best_L[None])[0] <= thr, n_hyp


def _best_linear(cam, frame, px: _Pixels):
    """The candidate from all pixels with the smallest rms image distance (first-order distances
    for all candidates, exact ones for the few within a factor 3 of the best)."""
    L = _all_candidates(cam, frame, px.o, px.d)
    if len(L) == 0:
        raise CatadioptricError("uv: the linear solver found no line meeting the pixels' rays")
    lin = _linear_distances(px, L)
    lin_rms = np.sqrt(np.mean(np.minimum(lin, 1e6) ** 2, axis=1))
    order = np.argsort(lin_rms)
    keep = order[: max(1, int(np.sum(lin_rms[order[:4]] <= 3.0 * lin_rms[order[0]] + 1e-9)))]
    if len(keep) == 1:
        return L[keep[0]], len(L)
    dist, _ = _score_lines(cam, L[keep], px.uv, px.o, px.d, iters=1)
    rms = np.sqrt(np.mean(np.minimum(dist, 1e6) ** 2, axis=1))
    return L[keep[int(np.argmin(rms))]], len(L)


def _prepare(cam, uv, name):
    px, valid = _pixels(cam, uv)
    if int(valid.sum()) < 5:
        raise CatadioptricError(
            f"{name}: expected at least 5 pixels that see the world through the mirror, got {int(valid.sum())} "
            f"of {len(uv)}")
    sel = lambda a: a[valid]
    return valid, _Pixels(sel(px.uv), sel(px.o), sel(px.d), sel(px.Jo), sel(px.Jd))


def _orient(lam, inl):
    """Flip the direction so that the first inlier's depth is below the last one's."""
    j = np.nonzero(inl)[0]
    return -1.0 if lam[j[-1]] < lam[j[0]] else 1.0


def _initial_line(cam, px: _Pixels, *, ransac, rng, thr, max_trials):
    frame = _ray_frame(cam, px.o, px.d)
    if ransac:
        L, mask, n_hyp = _ransac(cam, frame, px, rng, thr, max_trials)
        if mask.sum() < 5:
            mask = np.ones(len(px.uv), dtype=bool)
    else:
        L, n_hyp = _best_linear(cam, frame, px)
        mask = np.ones(len(px.uv), dtype=bool)
    s = L[:3]
    q = np.cross(s, L[3:])
    return s, q, mask, n_hyp


# --------------------------------------------------------------------------- public fits
def fit_line(cam: CatadioptricCamera, uv, *, loss: str = "soft_l1", f_scale: float = 1.0, ransac: bool = True,
             seed=0, pixel_sigma=None, inlier_threshold=None, max_trials: int = 200,
             jac: str = "analytic") -> LineFit:
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
    ``"2-point"``/``"3-point"`` (finite differences with ``jac_sparsity``).

    Raises :class:`CatadioptricError` for central cameras (the position is not observable)
    and for bad input.
    """
    _check_camera(cam, "the line's position and direction")
    uv = _check_uv(uv, "uv", 5)
    f_scale, pixel_sigma, inlier_threshold = _check_options(loss, f_scale, pixel_sigma, inlier_threshold)
    thr = _check_fit_options(jac, max_trials, f_scale, pixel_sigma, inlier_threshold)
    rng = _rng(seed)
    ok, px = _prepare(cam, uv, "uv")
    s, q, mask, n_hyp = _initial_line(cam, px, ransac=ransac, rng=rng, thr=thr, max_trials=int(max_trials))
    lam0 = _closest_depths(q, s, px.o, px.d)
    owner = np.zeros(len(px.uv), dtype=np.int64)
    r = _solve_family(cam, px.uv, px.o, px.d, owner, 1, s, q[None], lam0, loss=loss, f_scale=f_scale,
                      pixel_sigma=pixel_sigma, inlier_threshold=inlier_threshold, jac=jac, start_mask=mask,
                      names=["uv"])
    return _line_result(r, ok, len(uv), n_hyp)


def _line_result(r, ok, M, n_hyp=0, line=0, owner=None):
    own = np.zeros(int(ok.sum()), dtype=np.int64) if owner is None else owner
    sel = own == line
    s, q = r["s"], r["q"][line]
    lam = r["lam"][sel]
    inl_v = r["inliers"][sel]
    sign = _orient(lam, inl_v)
    s = sign * s
    lam = sign * lam
    full = lambda v, fill, tail=(): _scatter(ok, v, fill, M, tail)
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


def _scatter(ok, v, fill, M, tail=()):
    out = np.full((M,) + tail, fill, dtype=np.asarray(v).dtype if not isinstance(fill, float) else float)
    out[ok] = v
    return out


def _moment_candidates(frame, s, o, d, scale):
    """Lines along a fixed unit direction ``s`` that meet rays ``o, d (k, 3)``: the linear
    least-squares moment (``m . s = 0``, ``s . (o_j x d_j) + d_j . m = 0``; good for strongly
    non-central rays) and lines in the plane through ``x0`` that holds the rays, at the
    least-squares offset and at 3, 10 and 30 times the mirror ``scale`` (a near-central
    camera hardly sees the offset). Returns ``(n, 6)``."""
    e1, e2 = _tangent_basis(s)
    Mom = np.cross(o - frame.x0, d)
    A = np.stack([d @ e1, d @ e2], axis=-1)
    rhs = -(Mom @ s)
    ab = np.linalg.lstsq(A, rhs, rcond=None)[0]
    out = [np.concatenate([s, ab[0] * e1 + ab[1] * e2 + np.cross(frame.x0, s)])]
    _, _, Vt = np.linalg.svd(d, full_matrices=len(d) < 3)
    u = np.cross(Vt[-1], s)
    nu = np.linalg.norm(u)
    u = u / nu if nu > 1e-12 else e1
    if u @ np.mean(d, axis=0) < 0:
        u = -u
    w = np.cross(u, s)
    dw = d @ w
    h = -np.sum((Mom @ s) * dw) / max(np.sum(dw * dw), 1e-300)
    hs = [3.0 * scale, 10.0 * scale, 30.0 * scale]
    if np.isfinite(h) and scale < h < 1e3 * scale:
        hs.append(h)
    for h in hs:
        out.append(np.concatenate([s, np.cross(frame.x0 + h * u, s)]))
    return np.array(out)


def _check_sets(uv_sets):
    if isinstance(uv_sets, np.ndarray) and uv_sets.ndim == 3:
        uv_sets = list(uv_sets)
    if not isinstance(uv_sets, (list, tuple)) or len(uv_sets) == 0:
        raise CatadioptricError(
            f"uv_sets: expected a non-empty list of (M_i, 2) pixel arrays, got {type(uv_sets).__name__}"
            + (f" of length {len(uv_sets)}" if hasattr(uv_sets, "__len__") else ""))
    return [_check_uv(u, f"uv_sets[{i}]", 5) for i, u in enumerate(uv_sets)]


def fit_parallel_lines(cam: CatadioptricCamera, uv_sets, *, loss: str = "soft_l1", f_scale: float = 1.0,
                       ransac: bool = True, seed=0, pixel_sigma=None, inlier_threshold=None,
                       max_trials: int = 200, jac: str = "analytic") -> FamilyFit:
    """Fit parallel 3-D lines, one per pixel set ``uv_sets[i] (M_i, 2)``, sharing one direction.

    Unknowns: the direction (2 DOF), each line's point in the plane normal to it (2 DOF
    per line) and one depth per pixel; residuals and options as :func:`fit_line`. The
    start: each set's inliers by RANSAC, then the direction that best explains every set
    among the intersection of the sets' near-central planes (the planes through the
    point nearest all rays that hold each set's rays: parallel lines' planes meet along
    the common direction) and the sets' own linear solutions, each line's moment by
    linear least squares for that direction.
    """
    _check_camera(cam, "the lines' positions and direction")
    sets = _check_sets(uv_sets)
    f_scale, pixel_sigma, inlier_threshold = _check_options(loss, f_scale, pixel_sigma, inlier_threshold)
    thr = _check_fit_options(jac, max_trials, f_scale, pixel_sigma, inlier_threshold)
    rng = _rng(seed)
    prepared = [_prepare(cam, u, f"uv_sets[{i}]") for i, u in enumerate(sets)]
    pxs = [p[1] for p in prepared]
    o_all = np.concatenate([p.o for p in pxs])
    d_all = np.concatenate([p.d for p in pxs])
    frame = _ray_frame(cam, o_all, d_all)
    masks, own_lines = [], []
    for px in pxs:
        if ransac:
            Lb, mk, _ = _ransac(cam, frame, px, rng, thr, int(max_trials))
            if mk.sum() < 5:
                mk = np.ones(len(px.uv), dtype=bool)
        else:
            Lb = _best_linear(cam, frame, px)[0]
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
            Lc = _moment_candidates(frame, s, px.o[mk], px.d[mk], cam.mirror.scale)
            dist = _linear_distances(px, Lc)
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
    lam0 = _closest_depths(q0[owner], s0, o_all, d_all)
    r = _solve_family(cam, uv_all, o_all, d_all, owner, len(pxs), s0, q0, lam0, loss=loss, f_scale=f_scale,
                      pixel_sigma=pixel_sigma, inlier_threshold=inlier_threshold, jac=jac,
                      start_mask=np.concatenate(masks), x0=frame.x0, names=[f"uv_sets[{i}]" for i in range(len(pxs))])
    s, q = r["s"], r["q"]
    sign = _orient(r["lam"][owner == 0], r["inliers"][owner == 0])
    s = sign * s
    lam = sign * r["lam"]
    depths, pts, uvf, dists, inls, rms_l = [], [], [], [], [], []
    for i, (ok, _) in enumerate(prepared):
        sel = owner == i
        M = len(sets[i])
        dep = _scatter(ok, lam[sel], np.nan, M)
        depths.append(dep)
        pts.append(q[i] + dep[:, None] * s)
        uvf.append(_scatter(ok, r["uv_fit"][sel], np.nan, M, (2,)))
        dists.append(_scatter(ok, r["dist"][sel], np.inf, M))
        inls.append(_scatter(ok, r["inliers"][sel], False, M))
        rms_l.append(float(np.sqrt(np.mean(r["dist"][sel][r["inliers"][sel]] ** 2))))
    rms = float(np.sqrt(np.mean(r["dist"][r["inliers"]] ** 2)))
    return FamilyFit(direction=s, moments=np.cross(q, s), points=q, depths=depths, line_points=pts, uv_fit=uvf,
                     distances=dists, inliers=inls, rms=rms, rms_per_line=np.array(rms_l), sigma=r["sigma"],
                     direction_cov=r["dir_cov"], pluecker_cov=np.array(r["pluecker_cov"]), cov=r["cov"],
                     dof=int(r["dof"]), nfev=int(r["nfev"]))


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

    Central cameras (``cam.is_central``; at least 2 curves): each curve gives only its
    interpretation plane (:func:`fit_interpretation_plane`), the direction is the one normal
    to all planes (:func:`direction_from_planes`), ``family`` is None, ``individual`` holds
    the planes and ``individual_uv`` one row per pair of curves: the vanishing points of
    the pair's own direction (where the two fitted curves cross).
    """
    if isinstance(cam, CatadioptricCamera) and cam.is_central:
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
    e1, e2 = _tangent_basis(s)
    h = 1e-6
    J = np.full(uv.shape + (2,), np.nan)
    for c, e in enumerate((e1, e2)):
        vpp = cam.vanishing_points(_unit(s + h * e), which="both")
        vpm = cam.vanishing_points(_unit(s - h * e), which="both")
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


def direction_from_planes(normals, normal_covs):
    """The direction common to planes with unit ``normals (L, 3)`` (L >= 2) and covariances
    ``normal_covs (L, 3, 3)``: minimises ``sum (n_i . s)^2 / (s^T C_i s)`` (reweighted
    eigenvector). Returns ``(s, cov (3, 3))``, ``s`` unit (sign arbitrary)."""
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
    e1, e2 = _tangent_basis(s)
    E = np.stack([e1, e2], axis=1)
    A = n @ E  # (L, 2): d(n_i . s) / d(tangent coordinates)
    cov = E @ np.linalg.pinv(np.einsum("l,li,lj->ij", w, A, A)) @ E.T
    return s, cov


def _central_vanishing_points(cam, uv_sets, **options):
    """Central camera: each curve gives its interpretation plane; the direction is normal to all of
    them; each pair of curves meets at the vanishing points of the pair's own direction."""
    allowed = {"f_scale", "ransac", "seed", "pixel_sigma", "inlier_threshold", "max_trials"}
    opts = {k: v for k, v in options.items() if k in allowed}
    sets = _check_sets(uv_sets)
    if len(sets) < 2:
        raise CatadioptricError(f"uv_sets: a central camera needs at least 2 curves (one gives only a plane), "
                                f"got {len(sets)}")
    planes = [fit_interpretation_plane(cam, u, **opts) for u in sets]
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


# --------------------------------------------------------------------------- central cameras
def fit_interpretation_plane(cam: CatadioptricCamera, uv, *, f_scale: float = 1.0, ransac: bool = True, seed=0,
                             pixel_sigma=None, inlier_threshold=None, max_trials: int = 200) -> InterpretationPlane:
    """What one image of a central camera says about a 3-D line: the plane through the
    viewpoint that holds it (``normal``, unit; the line's direction is normal to it).

    Pixels ``uv (M, 2)`` (M >= 3). Minimises the first-order image distance of each pixel
    to the plane's image, ``|n . d_j| / |Jd_j^T n|`` (``d_j`` the pixel's ray direction,
    ``Jd_j`` its derivative by the pixel), by reweighted eigenvector iterations, after
    RANSAC over pairs of pixels (``n = d_1 x d_2``). ``normal_cov`` from the same
    linearisation (sigma from the residuals unless ``pixel_sigma`` is given). Two or
    more parallel lines give their direction as the common normal of their planes.
    """
    if not isinstance(cam, CatadioptricCamera):
        raise CatadioptricError(f"cam: expected a CatadioptricCamera, got {type(cam).__name__}")
    if not cam.is_central:
        raise CatadioptricError("cam: expected a central camera (cam.is_central); a non-central camera sees the "
                                "whole line: use fit_line")
    uv = _check_uv(uv, "uv", 3)
    f_scale, pixel_sigma, inlier_threshold = _check_options("linear", f_scale, pixel_sigma, inlier_threshold)
    rng = _rng(seed)
    px, valid = _pixels(cam, uv)
    if int(valid.sum()) < 3:
        raise CatadioptricError(f"uv: expected at least 3 pixels that see the world, got {int(valid.sum())}")
    d, Jd = px.d[valid], px.Jd[valid]

    def dist(n):  # (H, M) first-order pixel distances to planes with unit normals n (H, 3)
        num = np.abs(n @ d.T)
        den = np.linalg.norm(np.einsum("mki,hk->hmi", Jd, n), axis=-1)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(den > 0, num / den, np.inf)

    thr = inlier_threshold if inlier_threshold is not None else (
        3.5 * pixel_sigma if pixel_sigma is not None else 3.0 * f_scale)
    M = len(d)
    inl = np.ones(M, dtype=bool)
    if ransac and M > 3:
        best, best_cost = None, np.inf
        for _ in range(int(np.ceil(max_trials / 64))):
            idx = np.argsort(rng.random((64, M)), axis=1)[:, :2]
            n = np.cross(d[idx[:, 0]], d[idx[:, 1]])
            nn = np.linalg.norm(n, axis=-1)
            n = n[nn > 1e-12] / nn[nn > 1e-12, None]
            if len(n) == 0:
                continue
            cost = np.sum(np.minimum(dist(n) ** 2, thr**2), axis=1)
            j = int(np.argmin(cost))
            if cost[j] < best_cost:
                best, best_cost = n[j], cost[j]
        if best is not None:
            inl = dist(best[None])[0] <= thr
            if inl.sum() < 3:
                inl = np.ones(M, dtype=bool)
    def refine(inl):
        w, n = np.ones(M), None
        for _ in range(50):
            A = np.einsum("m,mi,mj->ij", w * inl, d, d)
            n_new = np.linalg.eigh(A)[1][:, 0]
            if n is not None and n_new @ n < 0:
                n_new = -n_new
            w = 1.0 / np.maximum(np.linalg.norm(np.einsum("mki,k->mi", Jd, n_new), axis=-1), 1e-300) ** 2
            done = n is not None and np.linalg.norm(n_new - n) < 1e-14
            n = n_new
            if done:
                break
        return n, w

    n, w = refine(inl)
    if ransac:  # inliers of the refined plane (threshold from a robust sigma unless given)
        r = dist(n[None])[0]
        thr2 = thr
        if inlier_threshold is None and pixel_sigma is None:
            thr2 = 3.0 * max(f_scale, 1.2 * float(np.median(r[inl])) / 0.6745)
        new = r <= thr2
        if new.sum() >= 3 and not np.array_equal(new, inl):
            inl = new
            n, w = refine(inl)
    r = dist(n[None])[0]
    e1, e2 = _tangent_basis(n)
    E = np.stack([e1, e2], axis=1)
    # residual_j = (n . d_j) sqrt(w_j): derivative by the tangent coordinates of n is sqrt(w_j) d_j . e_k
    Jt = (d[inl] @ E) * np.sqrt(w[inl])[:, None]
    k = int(inl.sum())
    dof = k - 2
    rss = float(np.sum(r[inl] ** 2))
    sigma = pixel_sigma if pixel_sigma is not None else (float(np.sqrt(rss / dof)) if dof > 0 else float("nan"))
    cov = E @ np.linalg.pinv(Jt.T @ Jt) @ E.T * sigma**2
    full = _scatter(valid, r, np.inf, len(uv))
    return InterpretationPlane(normal=n, viewpoint=cam.viewpoint, normal_cov=cov,
                               rms=float(np.sqrt(np.mean(r[inl] ** 2))), distances=full,
                               inliers=_scatter(valid, inl, False, len(uv)))


# --------------------------------------------------------------------------- synthetic data
def segment_pixels(cam: CatadioptricCamera, a, b, n: int, *, sigma: float = 0.0, rng=None):
    """Pixels of ``n`` points spread evenly along the 3-D segment ``a``-``b`` (mirror frame).

    Keeps the points with a valid image on the image rectangle; where a point has several,
    the one nearest the previous kept pixel (so that the pixels follow one branch of the
    curve). Adds Gaussian noise of ``sigma`` pixels (``rng``: a Generator or seed).
    Returns ``(uv (n', 2), points (n', 3))``."""
    a = as_float_array(a, "a", 3)
    b = as_float_array(b, "b", 3)
    if a.shape != (3,) or b.shape != (3,):
        raise CatadioptricError(f"a, b: expected 3-vectors, got shapes {a.shape} and {b.shape}")
    if not (isinstance(n, (int, np.integer)) and n >= 1):
        raise CatadioptricError(f"n: expected a positive integer, got {n!r}")
    sigma = as_scalar(sigma, "sigma")
    if sigma < 0:
        raise CatadioptricError(f"sigma: expected a non-negative number, got {sigma!r}")
    t = np.linspace(0.0, 1.0, int(n))
    P = a + t[:, None] * (b - a)
    pr = cam.project(P)
    good = pr.valid & pr.in_image
    uv, pts, prev = [], [], None
    for i in range(len(P)):
        k = np.nonzero(good[i])[0]
        if len(k) == 0:
            continue
        cand = pr.uv[i, k]
        j = 0 if prev is None else int(np.argmin(np.sum((cand - prev) ** 2, axis=-1)))
        prev = cand[j]
        uv.append(cand[j])
        pts.append(P[i])
    uv = np.array(uv).reshape(-1, 2)
    pts = np.array(pts).reshape(-1, 3)
    if sigma > 0 and len(uv):
        uv = uv + _rng(rng).normal(0.0, sigma, uv.shape)
    return uv, pts


# --------------------------------------------------------------------------- measured accuracy
# Reference scenes of docs/linefit.md (tests/test_linefit.py uses the same numbers): per rig a
# segment close to the mirror (end points in M, metres) and the pixel noise "unit" that puts its
# fitted direction's standard error near 0.4 degrees; and a family of parallel lines whose +s
# vanishing point is a given pixel, each line through the point at a given depth on the ray of
# a given pixel.
REFERENCE_SEGMENTS = {
    "sphere": (((0.223, -0.192, 0.186), (-0.313, 0.025, -0.152)), 0.5),
    "hyperboloid_9pct": (((0.381, -0.37, -0.096), (-0.476, 0.125, 0.22)), 0.1),
    "ellipsoid": (((-0.251, -0.54, -0.038), (0.486, 0.343, -0.046)), 0.03),
}
REFERENCE_FAMILIES = {
    "hyperboloid_9pct": ((330, 60), [(120, 240), (520, 240), (320, 420), (200, 380)], [0.4, 0.5, 0.6, 0.45]),
    "sphere": ((250, 70), [(150, 250), (470, 230), (330, 380), (420, 120)], [0.3, 0.4, 0.35, 0.5]),
    "ellipsoid": ((150, 200), [(320, 120), (460, 330), (300, 400), (420, 200)], [0.4, 0.5, 0.6, 0.45]),
    "hyperboloid_central": ((480, 160), [(150, 250), (470, 330), (330, 400), (420, 120)], [0.5, 0.6, 0.4, 0.7]),
    "ellipsoid_central": ((480, 160), [(150, 250), (470, 330), (330, 400), (420, 120)], [0.5, 0.6, 0.4, 0.7]),
}


def family_pixels(cam: CatadioptricCamera, vp_pixel, line_pixels, depths, *, n: int = 50, phi=(-0.6, 1.45)):
    """Synthetic parallel lines: the direction ``s`` is the one whose ``+s`` vanishing point is
    ``vp_pixel``; line i passes through the point at ``depths[i]`` on the ray of ``line_pixels[i]``.
    Points ``q_i + tan(phi) s`` for ``n`` angles evenly spread over ``phi`` (so the curves run
    into the vanishing point), kept where they have exactly one valid image on the image;
    lines with fewer than 15 pixels are dropped. Returns ``(s, [uv_i], [q_i])``."""
    s = cam.backproject(np.asarray(vp_pixel, dtype=float)).directions
    rays = cam.backproject(np.asarray(line_pixels, dtype=float))
    t = np.tan(np.linspace(phi[0], phi[1], int(n)))
    sets, points = [], []
    for o, d, depth in zip(rays.origins, rays.directions, depths):
        q = o + depth * d
        pr = cam.project(q + t[:, None] * s)
        ok = pr.valid[:, 0] & pr.in_image[:, 0] & (pr.valid.sum(axis=1) == 1)
        if ok.sum() >= 15:
            sets.append(pr.uv[ok, 0])
            points.append(q)
    return s, sets, points


def _angle_deg(s, t):
    return float(np.degrees(np.arccos(np.clip(abs(s @ t) / np.linalg.norm(s) / np.linalg.norm(t), -1, 1))))


def _predicted_direction_std(cam, a, b, n=100):
    """Direction standard error (degrees per pixel of noise) of a segment's fit at the truth."""
    uv, pts = segment_pixels(cam, a, b, n)
    if len(uv) < 0.8 * n:
        return None
    s = _unit(b - a)
    r = cam.backproject(uv)
    x0 = _ray_frame(cam, r.origins, r.directions).x0
    q = a - (a @ s) * s
    pb = _Problem(cam, uv, np.zeros(len(uv), dtype=np.int64), 1, x0, s, q[None], (pts - q) @ s)
    C = pb.schur_cov(pb.x0(), np.ones(len(uv), dtype=bool))
    return float(np.degrees(np.sqrt(C[0, 0] + C[1, 1])))


def accuracy_table(*, trials: int = 40, family_seeds: int = 10, random_segments: int = 150, seed: int = 0,
                   out=print) -> dict:
    """Measure and print the accuracy tables of docs/linefit.md (markdown). Takes a few minutes.

    1. Conditioning: the predicted direction error at 1 px of noise for random segments
       near each rig (100 pixels each), from the covariance at the true line.
    2. Single lines (reference segments): median errors over ``trials`` noisy fits per
       noise level, the median predicted standard error and the ratio of the Monte Carlo
       trace of the direction covariance to the median predicted one.
    3. Families and vanishing points at 1 px (reference families, ``family_seeds`` noise draws).
    Returns the numbers as a dict."""
    from .rigs import preset

    rng = np.random.default_rng(seed)
    res = {"conditioning": {}, "single": {}, "family": {}}
    out("### Conditioning: predicted direction error of one line at 1 px noise (degrees)\n")
    out("| rig | segments | median | 10th percentile | best |")
    out("|---|---|---|---|---|")
    for name in ("sphere", "hyperboloid_9pct", "hyperboloid", "ellipsoid"):
        cam = preset(name)
        g = cam.pinhole.pixel_grid(10).reshape(-1, 2)
        r = cam.backproject(g)
        dirs = r.directions[r.valid]
        vals = []
        for _ in range(random_segments):
            v = dirs[rng.integers(len(dirs))]
            dist = rng.uniform(0.08, 0.3)
            s = _unit(np.cross(v, rng.normal(size=3)))
            half = rng.uniform(1.0, 4.0) * dist
            x = _predicted_direction_std(cam, v * dist - half * s, v * dist + half * s)
            if x is not None:
                vals.append(x)
        vals = np.array(vals)
        res["conditioning"][name] = vals
        out(f"| {name} | {len(vals)} | {np.median(vals):.3g} | {np.percentile(vals, 10):.3g} | {vals.min():.3g} |")
    out("\n### Single lines: reference segments, 100 pixels, median over "
        f"{trials} noise draws (plain least squares)\n")
    out("| rig | sigma (px) | direction error (deg) | predicted std (deg) | MC / predicted trace "
        "| position error (mm) |")
    out("|---|---|---|---|---|---|")
    for name, ((a, b), unit) in REFERENCE_SEGMENTS.items():
        cam = preset(name)
        a, b = np.array(a), np.array(b)
        uv, _ = segment_pixels(cam, a, b, 100)
        s = _unit(b - a)
        mid = 0.5 * (a + b)
        for sigma in sorted({unit * k for k in (0.25, 0.5, 1.0, 2.0)} | {1.0}):
            ds, ang, pos, pred = [], [], [], []
            for t in range(trials):
                noisy = uv + np.random.default_rng(1000 + t).normal(0.0, sigma, uv.shape)
                try:
                    f = fit_line(cam, noisy, ransac=False, loss="linear")
                except CatadioptricError:
                    continue
                sf = f.direction if f.direction @ s >= 0 else -f.direction
                ds.append(sf - s)
                ang.append(_angle_deg(f.direction, s))
                pos.append(np.linalg.norm(np.cross(mid - f.point, f.direction)))
                pred.append(np.trace(f.direction_cov))
            ratio = float(np.trace(np.cov(np.array(ds).T)) / np.median(pred))
            row = dict(direction_deg=float(np.median(ang)), predicted_deg=float(np.degrees(np.sqrt(np.median(pred)))),
                       mc_ratio=ratio, position_mm=1e3 * float(np.median(pos)), n=len(ang))
            res["single"][(name, sigma)] = row
            out(f"| {name} | {sigma:.4g} | {row['direction_deg']:.3g} | {row['predicted_deg']:.3g} | {ratio:.2f} "
                f"| {row['position_mm']:.3g} |")
    out(f"\n### Families of 4 parallel lines and their vanishing points, 1 px noise, median over {family_seeds} "
        "draws\n")
    out("| rig | family direction error (deg) | predicted std (deg) | single-line direction error (deg) "
        "| +s vanishing point error (px) | predicted std (px) | spread of single fits (max, px) |")
    out("|---|---|---|---|---|---|---|")
    for name, spec in REFERENCE_FAMILIES.items():
        cam = preset(name)
        s, sets, _ = family_pixels(cam, *spec)
        vp_pixel = np.array(spec[0], dtype=float)
        fam, fam_sd, single, vp_err, vp_sd, spread = [], [], [], [], [], []
        for t in range(family_seeds):
            rg = np.random.default_rng(2000 + t)
            noisy = [u + rg.normal(0.0, 1.0, u.shape) for u in sets]
            v = vanishing_points_from_curves(cam, noisy)
            fam.append(_angle_deg(v.direction, s))
            fam_sd.append(np.degrees(np.sqrt(np.trace(v.direction_cov))))
            if v.family is not None:
                single += [_angle_deg(f.direction, s) for f in v.individual if f is not None]
            k = [i for i in v.observable() if v.sign[i] > 0]
            if k:
                j = k[int(np.argmin(np.linalg.norm(v.uv[k] - vp_pixel, axis=-1)))]
                vp_err.append(np.linalg.norm(v.uv[j] - vp_pixel))
                vp_sd.append(np.sqrt(np.trace(v.uv_cov[j])))
                spread.append(v.spread_max[j])
        med = lambda x: float(np.nanmedian(x)) if len(x) else float("nan")
        row = dict(family_deg=med(fam), family_pred_deg=med(fam_sd), single_deg=med(single), vp_px=med(vp_err),
                   vp_pred_px=med(vp_sd), spread_px=med(spread), lines=len(sets))
        res["family"][name] = row
        single_txt = f"{row['single_deg']:.3g}" if single else "- (central)"
        out(f"| {name} | {row['family_deg']:.3g} | {row['family_pred_deg']:.3g} | {single_txt} | {row['vp_px']:.3g} "
            f"| {row['vp_pred_px']:.3g} | {row['spread_px']:.3g} |")
    return res
