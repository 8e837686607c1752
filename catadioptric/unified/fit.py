"""The unified central model's parameters for a rig: exact for a central rig
(:func:`unified_from_central`, a pinhole at one focus of an ellipsoid or a two-sheet hyperboloid),
and the best central approximation of a non-central one (:func:`fit_unified`, the model fitted to
the rig's exact reflected rays). The model itself: :mod:`catadioptric.unified.model`;
docs/unified.md states both with their derivations.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from .._checks import CatadioptricError, as_float_array
from ..cameras import CatadioptricCamera
from ..models.base import image_size
from ..solvers.reflection import reflect
from .model import DEFAULT_DEPTHS, UnifiedCamera

__all__ = ["UnifiedFit", "unified_from_central", "fit_unified"]


def _rotation_taking(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The smallest rotation taking unit vector ``a`` to unit vector ``b``."""
    v = np.cross(a, b)
    c = float(np.dot(a, b))
    s = float(np.linalg.norm(v))
    if s < 1e-15:
        if c > 0:
            return np.eye(3)
        # half turn about any axis orthogonal to a
        axis = np.cross(a, [1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 1.0, 0.0])
        axis /= np.linalg.norm(axis)
        return 2.0 * np.outer(axis, axis) - np.eye(3)
    k = v / s
    Kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + s * Kx + (1 - c) * Kx @ Kx


def _frame_with_z(z: np.ndarray) -> np.ndarray:
    """A rotation whose third row is the unit vector ``z``."""
    return _rotation_taking(z, np.array([0.0, 0.0, 1.0]))


def _rq_pinned(M: np.ndarray):
    """``M = lambda K Q`` with K upper triangular, K[2,2] = 1, K[0,0] > 0, Q a rotation, lambda > 0
    (the sign of M's overall scale is kept: callers choose it)."""
    from scipy.linalg import rq

    U, Q = rq(M)
    d1 = np.sign(U[0, 0])
    d3 = np.sign(U[2, 2])
    d2 = d1 * d3 * np.sign(np.linalg.det(Q))
    D = np.diag([d1, d2, d3])
    U = U @ D
    Q = D @ Q
    lam = U[2, 2]
    K = U / lam
    K[1, 0] = K[2, 0] = K[2, 1] = 0.0
    K[2, 2] = 1.0
    return K, Q, lam


def _conic_parameters(mirror):
    """Centre z0, semi-axes alpha (along) and beta (across), focal half-distance f, eccentricity e,
    semi-latus rectum l and gamma (+1 ellipsoid, -1 hyperboloid) of a mirror of revolution."""
    A, B, C = mirror.A, mirror.B, mirror.C
    z0 = -B / (2 * A)
    Kc = C + B * B / (4 * A)
    alpha2 = abs(Kc / A)
    beta2 = abs(Kc)
    if mirror.kind == "hyperboloid":
        f = np.sqrt(alpha2 + beta2)
        gamma = -1.0
    else:
        f = np.sqrt(max(alpha2 - beta2, 0.0))
        gamma = 1.0
    alpha = np.sqrt(alpha2)
    return z0, alpha, np.sqrt(beta2), f, f / alpha, beta2 / alpha, gamma


def _patch_edge_points(mirror) -> np.ndarray:
    """Points of the mirror patch's meridian (x >= 0, y = 0) at z_min, z_max and between, where the
    surface exists."""
    zs = np.linspace(mirror.z_min, mirror.z_max, 9)
    r2 = mirror.radius_squared(zs)
    ok = r2 >= -1e-12 * mirror.scale ** 2  # a vertex at a patch end can round to a tiny negative r^2
    return np.stack([np.sqrt(np.maximum(r2[ok], 0.0)), np.zeros(ok.sum()), zs[ok]], axis=-1)


def unified_from_central(cam: CatadioptricCamera) -> UnifiedCamera:
    """The exact unified model of a central rig: a pinhole at one focus of an ellipsoid or a
    two-sheet hyperboloid; the viewpoint is the other focus.

    With the mirror's semi-axes alpha (along the axis) and beta (across), focal half-distance f,
    eccentricity e = f / alpha, semi-latus rectum l = beta^2 / alpha and focal distance d = 2 f:
    ``xi = 2 e / (1 + e^2)`` and, in the sphere frame whose z axis points from the viewpoint to
    the pinhole, the pinhole sees ``r - F1 = R diag(1, 1, k) (X_s + xi e3)`` with
    ``|k| = (alpha^2 + f^2) / beta^2`` (R the signed distance from the viewpoint to the mirror
    point). Hence pixels ``~ K_pin R_pin R_S^T diag(1, 1, k) p``; its RQ decomposition gives
    ``K`` and ``R_tilt`` (identity when the optical axis lies along the mirror axis). Agrees with
    ``cam.project`` / ``cam.backproject`` to rounding (docs/unified.md, tests/test_unified.py).
    """
    if not isinstance(cam, CatadioptricCamera):
        raise CatadioptricError(f"cam: expected a CatadioptricCamera, got {type(cam).__name__}")
    m = cam.mirror
    if m.kind not in ("ellipsoid", "hyperboloid") or cam.viewpoint is None:
        foci = m.foci
        dist = min((float(np.linalg.norm(cam.center - f)) for f in foci), default=float("nan"))
        raise CatadioptricError(
            f"cam: expected a central rig (pinhole at a focus of an ellipsoid or two-sheet hyperboloid), got a "
            f"{m.kind} mirror with the camera {dist:.6g} m from the nearest focus"
            + ("" if foci else " (the mirror has no foci on its axis)")
        )
    z0, alpha, beta, f, e, l, gamma = _conic_parameters(m)
    foci = m.foci
    i1 = int(np.argmin([np.linalg.norm(cam.center - F) for F in foci]))
    F1, F2 = np.asarray(foci[i1], float), np.asarray(foci[1 - i1], float)  # pinhole, viewpoint
    d = 2.0 * f
    a_hat = (F1 - F2) / d
    # branch: the sign of R (world points beyond the mirror point, R > 0, or beyond the viewpoint)
    pts = _patch_edge_points(m)
    r = pts[len(pts) // 2]
    inc = r - F1
    out = reflect(inc, m.normal(r))
    sgnR = 1.0 if np.dot(out, r - F2) > 0 else -1.0
    s = sgnR * (r - F2) / np.linalg.norm(r - F2)
    Rsigned = sgnR * np.linalg.norm(r - F2)
    mu = l / Rsigned + gamma * e * np.dot(s, a_hat)
    if abs(abs(mu) - 1.0) > 1e-6:  # pragma: no cover - the focal property guarantees |mu| = 1
        raise CatadioptricError(f"cam: the mirror point does not satisfy the focal property (mu = {mu!r})")
    mu = float(np.sign(mu))
    k = 1.0 + gamma * e * d / l
    xi = -mu * d / (l + gamma * e * d)
    R_S = _frame_with_z(a_hat)
    flip = np.eye(3)
    if xi < 0:
        # rotate the sphere frame half a turn about x: p' = diag(1, -1, -1) p, xi' = -xi
        flip = np.diag([1.0, -1.0, -1.0])
        R_S = flip @ R_S
        xi = -xi
    H = cam.pinhole.K @ cam.R_cam_from_mirror @ R_S.T @ flip @ np.diag([1.0, 1.0, k]) @ flip
    # pixel ~ R H p and the pinhole's depth is R (H p)_z: keep the sign of R so that
    # (R_tilt p)_z > 0 exactly where the point is in front of the pinhole
    K, Q, _ = _rq_pinned(sgnR * H)
    g = Q[:, 2]
    if np.max(np.abs(g - [0.0, 0.0, 1.0])) <= 1e-14:
        R_swing = np.eye(3)  # the optical axis lies along the mirror axis: the pure unified model
    else:
        R_swing = _rotation_taking(np.array([0.0, 0.0, 1.0]), g)
    Rz = R_swing.T @ Q  # a rotation about z: commutes with the shift by xi e3
    R_S = Rz @ R_S
    # the patch's field of view: z_s of the viewing directions of the patch's meridian
    sdir = sgnR * (pts - F2)
    sdir /= np.linalg.norm(sdir, axis=-1, keepdims=True)
    zs = (sdir @ R_S.T)[:, 2]
    pad = 1e-12  # rounding at the rim: pixels on the patch's edge stay valid in both models
    zr = (max(-1.0, float(zs.min()) - pad), min(1.0, float(zs.max()) + pad))
    return UnifiedCamera(xi, K, R_S, F2, R_swing, cam.pinhole.width, cam.pinhole.height, zr)


# ----------------------------------------------------------------------------- fitting
@dataclass
class UnifiedFit:
    """The best central approximation of a rig (:func:`fit_unified`).

    ``camera`` is the fitted :class:`UnifiedCamera`; residuals are pixel distances between the
    fitted model's image of each sample point and the exact pixel it came from. ``rms_px``,
    ``max_px``, ``median_px`` over all samples; ``per_depth`` maps each depth (metres, "inf") to
    its rms and max; ``n_pixels`` and ``n_points`` count the samples; ``initial`` is the start
    (the exact model of the nearest central configuration when there is one)."""

    camera: UnifiedCamera
    rms_px: float
    max_px: float
    median_px: float
    per_depth: dict
    n_pixels: int
    n_points: int
    nfev: int
    success: bool
    message: str
    initial: UnifiedCamera
    depths: tuple
    tilt: bool

    def to_dict(self) -> dict:
        return {
            "camera": self.camera.to_dict(),
            "rms_px": self.rms_px,
            "max_px": self.max_px,
            "median_px": self.median_px,
            "per_depth": self.per_depth,
            "n_pixels": self.n_pixels,
            "n_points": self.n_points,
            "nfev": self.nfev,
            "success": self.success,
            "message": self.message,
            "depths_m": [("inf" if not np.isfinite(t) else float(t)) for t in self.depths],
            "tilt": self.tilt,
        }


def _normalised_plane(xi, R, c, Rt, X, w):
    """Homogeneous points ``(X, w)`` on the unit sphere, shifted by xi and tilted: ``q`` (before K)."""
    Y = (X - w[:, None] * c) @ R.T
    p = Y / np.linalg.norm(Y, axis=-1, keepdims=True)
    p[:, 2] += xi
    return p @ Rt.T


def _project_homogeneous(xi, K, R, c, Rt, X, w):
    """Pixels of homogeneous points ``(X, w)`` (w = 1 finite, 0 at infinity), no checks."""
    q = _normalised_plane(xi, R, c, Rt, X, w)
    x = q[:, 0] / q[:, 2]
    y = q[:, 1] / q[:, 2]
    return np.stack([K[0, 0] * x + K[0, 1] * y + K[0, 2], K[1, 1] * y + K[1, 2]], axis=-1), q[:, 2]


def _linear_K(xi, R, c, Rt, X, w, uv):
    """The K (fx, s, cx, fy, cy) minimising the pixel residuals for fixed xi, R, c, R_tilt (linear)."""
    q = _normalised_plane(xi, R, c, Rt, X, w)
    x = q[:, 0] / q[:, 2]
    y = q[:, 1] / q[:, 2]
    one = np.ones_like(x)
    a, *_ = np.linalg.lstsq(np.stack([x, y, one], -1), uv[:, 0], rcond=None)
    b, *_ = np.linalg.lstsq(np.stack([y, one], -1), uv[:, 1], rcond=None)
    return np.array([[a[0], a[1], a[2]], [0.0, b[0], b[1]], [0.0, 0.0, 1.0]])


def _is_model(cam) -> bool:
    from ..models.base import CentralCamera

    return isinstance(cam, CentralCamera)


def _samples(cam: CatadioptricCamera, step: int, depths):
    if _is_model(cam):  # a calibration's model: the pixels of its region (its formula's own range)
        uv = cam.pixel_grid(step)
        ok = cam.region()[::step, ::step].reshape(-1)
        uv = uv.reshape(-1, 2)
    else:
        uv = cam.pinhole.pixel_grid(step).reshape(-1, 2)
        ok = True
    rays = cam.backproject(uv)
    ok = rays.valid & ok
    uv, o, d = uv[ok], rays.origins[ok], rays.directions[ok]
    Xs, ws, uvs, tags = [], [], [], []
    for t in depths:
        if np.isfinite(t):
            Xs.append(o + t * d)
            ws.append(np.ones(len(d)))
        else:
            Xs.append(d)
            ws.append(np.zeros(len(d)))
        uvs.append(uv)
        tags.append(np.full(len(d), float(t)))
    return len(uv), np.concatenate(Xs), np.concatenate(ws), np.concatenate(uvs), np.concatenate(tags), o, d


def _generic_initial(cam: CatadioptricCamera, X, w, uv, origins, dirs) -> UnifiedCamera:
    """A start for rigs without a nearby central configuration: the point closest to all the
    exact rays as viewpoint, the sphere's z axis toward the pinhole, a coarse scan over xi with K
    solved linearly for each."""
    # least-squares point closest to the lines origins + t dirs
    P = np.eye(3)[None] - dirs[:, :, None] * dirs[:, None, :]
    A = P.sum(0)
    b = np.einsum("nij,nj->i", P, origins)
    c = np.linalg.solve(A, b)
    z = np.asarray(cam.axis, float) if _is_model(cam) else cam.center - c
    R = _frame_with_z(z / np.linalg.norm(z))
    best = None
    for xi in np.linspace(0.0, 1.5, 16):
        K = _linear_K(xi, R, c, np.eye(3), X, w, uv)
        if not (np.all(np.isfinite(K)) and K[0, 0] != 0 and K[1, 1] != 0):
            continue
        res, _ = _project_homogeneous(xi, K, R, c, np.eye(3), X, w)
        cost = np.nanmean(np.sum((res - uv) ** 2, -1))
        if best is None or cost < best[0]:
            Rk = R
            if K[0, 0] < 0:  # the same model with the sphere turned half a turn about z: fx > 0
                Rz = np.diag([-1.0, -1.0, 1.0])
                K, Rk = K @ Rz, Rz @ R
                K[2, 2] = 1.0
            best = (cost, xi, K, Rk)
    _, xi, K, R = best
    return UnifiedCamera(xi, K, R, c, np.eye(3), *image_size(cam))


def _nearest_central_initial(cam: CatadioptricCamera) -> Optional[UnifiedCamera]:
    if _is_model(cam):
        return None
    m = cam.mirror
    if m.kind not in ("ellipsoid", "hyperboloid") or len(m.foci) != 2:
        return None
    F = min(m.foci, key=lambda F: float(np.linalg.norm(cam.center - F)))
    try:
        central = CatadioptricCamera(m, cam.pinhole, F, cam.R_cam_from_mirror)
        return unified_from_central(central)
    except CatadioptricError:
        return None


def fit_unified(cam: CatadioptricCamera, *, step: int = 8, depths=DEFAULT_DEPTHS, tilt: bool = False,
                initial: Optional[UnifiedCamera] = None, max_nfev: int = 400) -> UnifiedFit:
    """The best central (unified-model) approximation of the rig ``cam``, by least squares. ``cam``
    may also be a calibration's camera model (:mod:`catadioptric.models`: how far OCamCalib's or
    Kalibr's model of a camera is from Mei's; its viewpoint is the origin, its region's pixels are
    sampled).

    Samples: the centres of every ``step``-th pixel (rows and columns) whose exact back-projected
    ray is valid; along each exact reflected ray, the points at ``depths`` metres from its mirror
    point (``inf``: the ray's point at infinity). Minimised: the sum over all samples of the
    squared pixel distance between the model's image of the sample point and the pixel it came
    from (``scipy.optimize.least_squares``, trust-region reflective, ``xi >= 0``), over xi, the
    five entries of K (fx, fy, skew, cx, cy), the viewpoint (3) and the sphere's orientation (3),
    plus, with ``tilt=True``, the tilt ``R_tilt`` (2: a rotation about an axis in the x-y plane).
    With ``tilt=False`` the result is a pure Mei model (OpenCV omnidir, :meth:`UnifiedCamera.to_omnidir`).

    Start: ``initial`` when given; else the exact model of the same pinhole moved to the nearest
    focus (ellipsoid, hyperboloid; for tilt=False its tilt is folded into K by a linear fit);
    else a generic start (viewpoint closest to all rays, scan of xi).
    """
    from scipy.optimize import least_squares
    from scipy.spatial.transform import Rotation

    if not (isinstance(cam, CatadioptricCamera) or _is_model(cam)):
        raise CatadioptricError(f"cam: expected a CatadioptricCamera or a camera model of catadioptric.models, got "
                                f"{type(cam).__name__}")
    if not (isinstance(step, (int, np.integer)) and step >= 1):
        raise CatadioptricError(f"step: expected a positive integer, got {step!r}")
    dep = as_float_array(depths, "depths", finite=False).reshape(-1)
    if dep.size == 0 or np.any(np.isnan(dep)) or np.any(dep <= 0):
        raise CatadioptricError(f"depths: expected positive depths in metres (inf allowed), got {dep.tolist()}")
    if initial is not None and not isinstance(initial, UnifiedCamera):
        raise CatadioptricError(f"initial: expected a UnifiedCamera or None, got {type(initial).__name__}")
    n_pix, X, w, uv, tags, ray_o, ray_d = _samples(cam, int(step), dep)
    if n_pix < 10:
        raise CatadioptricError(
            f"cam: expected a rig whose image sees the mirror at 10 or more sampled pixels, got {n_pix} (step={step})"
        )
    init = initial if initial is not None else _nearest_central_initial(cam)
    if init is None:
        init = _generic_initial(cam, X, w, uv, ray_o, ray_d)
    R0, c0, xi0 = init.R_sphere_from_mirror, init.center, init.xi
    Rt0 = init.R_tilt if tilt else np.eye(3)
    K0 = init.K if (tilt or init.is_pure) else _linear_K(xi0, R0, c0, Rt0, X, w, uv)
    scale = 1.0 if _is_model(cam) else cam.mirror.scale

    def unpack(x):
        xi = x[0]
        K = np.array([[x[1], x[3], x[4]], [0.0, x[2], x[5]], [0.0, 0.0, 1.0]])
        c = c0 + scale * x[6:9]
        R = Rotation.from_rotvec(x[9:12]).as_matrix() @ R0
        Rt = (Rotation.from_rotvec([x[12], x[13], 0.0]).as_matrix() @ Rt0) if tilt else np.eye(3)
        return xi, K, c, R, Rt

    def residuals(x):
        xi, K, c, R, Rt = unpack(x)
        pr, den = _project_homogeneous(xi, K, R, c, Rt, X, w)
        r = pr - uv
        # samples the model cannot image get a large, smooth penalty instead of a NaN
        bad = ~(np.isfinite(r).all(-1) & (den > 0))
        r = np.where(bad[:, None], 1e3, r)
        return r.reshape(-1)

    x0 = np.concatenate([[xi0, K0[0, 0], K0[1, 1], K0[0, 1], K0[0, 2], K0[1, 2]], np.zeros(6),
                         np.zeros(2) if tilt else []])
    lb = np.full_like(x0, -np.inf)
    lb[0] = 0.0
    x0[0] = max(x0[0], 0.0)
    sol = least_squares(residuals, x0, bounds=(lb, np.full_like(x0, np.inf)), x_scale="jac", method="trf",
                        xtol=1e-15, ftol=1e-15, gtol=1e-15, max_nfev=max_nfev)
    xi, K, c, R, Rt = unpack(sol.x)
    if K[0, 0] < 0:  # the same model with the sphere turned half a turn about z
        Rz = np.diag([-1.0, -1.0, 1.0])
        K = K @ Rz
        K[2, 2] = 1.0
        R = Rz @ R
        Rt = Rz @ Rt @ Rz
    fitted = UnifiedCamera(xi, K, R, c, Rt, *image_size(cam))
    pr, den = _project_homogeneous(xi, K, R, c, Rt, X, w)
    err = np.linalg.norm(pr - uv, axis=-1)
    err = np.where(np.isfinite(err) & (den > 0), err, np.inf)
    per = {}
    for t in dep:
        sel = tags == t
        key = "inf" if not np.isfinite(t) else f"{t:g}"
        per[key] = {"rms_px": float(np.sqrt(np.mean(err[sel] ** 2))), "max_px": float(np.max(err[sel]))}
    return UnifiedFit(fitted, float(np.sqrt(np.mean(err ** 2))), float(np.max(err)), float(np.median(err)), per,
                      int(n_pix), int(len(err)), int(sol.nfev), bool(sol.success), str(sol.message), init,
                      tuple(float(t) for t in dep), bool(tilt))
