"""Rotations from matched directions: orthogonal Procrustes (weighted, closed form) and the
covariance-weighted, robust Gauss-Newton refinement used by the relative-pose solvers.

Convention: ``b ~ R a`` (``a`` in the first frame, ``b`` in the second); perturbations act on
the left, ``R(w) = exp([w]_x) R``, so the covariance of a rotation is that of the rotation
vector ``w`` in the second frame.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from .._checks import CatadioptricError, as_float_array, as_rotation
from .._numeric import cross

__all__ = ["with_floor", "rotation_from_directions", "rotation_angle_deg", "DirectionRotation", "refine_rotation",
           "exp_rotation", "skew", "information"]


def skew(v) -> np.ndarray:
    """``[v]_x`` for ``v (..., 3)``: ``skew(v) @ x == cross(v, x)``."""
    v = np.asarray(v, dtype=float)
    S = np.zeros(v.shape[:-1] + (3, 3))
    S[..., 0, 1], S[..., 0, 2] = -v[..., 2], v[..., 1]
    S[..., 1, 0], S[..., 1, 2] = v[..., 2], -v[..., 0]
    S[..., 2, 0], S[..., 2, 1] = -v[..., 1], v[..., 0]
    return S


def exp_rotation(w) -> np.ndarray:
    """The rotation matrix of the rotation vector ``w (3,)`` (axis times angle, radians)."""
    return Rotation.from_rotvec(np.asarray(w, dtype=float)).as_matrix()


def _unit_rows(v: np.ndarray, name: str) -> np.ndarray:
    scale = np.max(np.abs(v), axis=-1, keepdims=True)  # no overflow or underflow in the norm
    if np.any(scale == 0):
        i = int(np.nonzero(scale[..., 0] == 0)[0][0])
        raise CatadioptricError(f"{name}: expected non-zero directions, got a zero vector at row {i}")
    v = v / scale
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def rotation_from_directions(a, b, weights=None) -> np.ndarray:
    """The rotation ``R`` minimising ``sum_i w_i |b_i - R a_i|^2`` (orthogonal Procrustes, det +1).

    ``a, b (N, 3)``: the same directions in two frames, signs included (any length; normalised
    here). N >= 2 directions, not all parallel in ``a``; with N = 2 the cross product is added
    (the minimal case). ``weights (N,)``: non-negative, at least two positive.
    """
    a = as_float_array(a, "a", 3).reshape(-1, 3)
    b = as_float_array(b, "b", 3).reshape(-1, 3)
    if a.shape != b.shape:
        raise CatadioptricError(f"a, b: expected the same number of directions, got {len(a)} and {len(b)}")
    if len(a) < 2:
        raise CatadioptricError(f"a: expected at least 2 directions, got {len(a)}")
    a, b = _unit_rows(a, "a"), _unit_rows(b, "b")
    if weights is None:
        w = np.ones(len(a))
    else:
        w = as_float_array(weights, "weights").reshape(-1)
        if len(w) != len(a):
            raise CatadioptricError(f"weights: expected {len(a)} weights (one per direction), got {len(w)}")
        if np.any(w < 0):
            raise CatadioptricError(f"weights: expected non-negative weights, got {float(w[w < 0][0])!r}")
        if np.count_nonzero(w) < 2:
            raise CatadioptricError(f"weights: expected at least 2 positive weights, got {np.count_nonzero(w)}")
    if len(a) == 2:
        ca, cb = cross(a[0], a[1]), cross(b[0], b[1])
        if np.linalg.norm(ca) < 1e-12 or np.linalg.norm(cb) < 1e-12:
            raise CatadioptricError("a, b: expected two non-parallel directions, got parallel (or antiparallel) ones")
        a = np.vstack([a, ca / np.linalg.norm(ca)])
        b = np.vstack([b, cb / np.linalg.norm(cb)])
        w = np.r_[w, np.sqrt(w[0] * w[1])]
    sv = np.linalg.svd(a[w > 0], compute_uv=False)
    if sv[1] < 1e-9 * sv[0]:
        raise CatadioptricError("a: expected at least two non-parallel directions (with positive weight), "
                                "got parallel ones")
    H = (b * w[:, None]).T @ a
    U, _, Vt = np.linalg.svd(H)
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt)) or 1.0])
    return U @ D @ Vt


def rotation_angle_deg(R) -> float:
    """The angle of a rotation matrix in degrees (accurate at small angles and near 180)."""
    R = as_rotation(R, "R")
    sin = 0.5 * np.linalg.norm([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    return float(np.degrees(np.arctan2(sin, (np.trace(R) - 1) / 2)))


@dataclass
class DirectionRotation:
    """A rotation fitted to matched directions with covariances.

    ``R`` (``b_i ~ R a_i``), ``cov (3, 3)``: covariance of the left rotation vector; per
    direction ``chi2 (N,)`` (Mahalanobis square of ``b_i - R a_i``, 2 degrees of freedom) and the
    robust ``weights (N,)`` in [0, 1] of the last iteration; ``cost``: the robust sum
    ``sum rho(chi2_i)`` (Cauchy, ``rho(x) = c^2 log(1 + x / c^2)``)."""

    R: np.ndarray
    cov: np.ndarray
    chi2: np.ndarray
    weights: np.ndarray
    cost: float


def with_floor(d, cov, floor_deg: float):
    """Covariances ``cov (..., 3, 3)`` of unit directions ``d (..., 3)`` with an error of
    ``floor_deg`` degrees (standard deviation, any way across each direction) added: what a
    detected family's lines carry beyond their fitted covariance (the detector's biases, which its
    lines share). ``cov`` itself when the floor is 0."""
    if floor_deg == 0.0:
        return cov
    d = np.asarray(d, float)
    return cov + np.radians(floor_deg) ** 2 * (np.eye(3) - d[..., :, None] * d[..., None, :])


def information(b, C):
    """Weight matrices ``(N, 3, 3)``: pseudo-inverse of ``C_i`` on the plane normal to ``b_i``."""
    P = np.eye(3) - b[:, :, None] * b[:, None, :]
    Cp = P @ C @ P
    w, V = np.linalg.eigh(Cp)
    top = np.max(w, axis=-1, keepdims=True)
    keep = w > 1e-9 * top
    inv = np.where(keep, 1.0 / np.where(keep, w, 1.0), 0.0)
    return np.einsum("nij,nj,nkj->nik", V, inv, V)


def refine_rotation(a, b, cov_a, cov_b, R0=None, *, robust: bool = True, c2: float = 9.0,
                    iters: int = 30) -> DirectionRotation:
    """Gauss-Newton on ``R`` for matched unit directions ``b_i ~ R a_i`` with covariances.

    The residual ``b_i - R a_i`` has covariance ``cov_b_i + R cov_a_i R^T`` (rank 2); its
    Mahalanobis square is ``chi2_i``. With ``robust``, iteratively reweighted by the Cauchy
    weight ``1 / (1 + chi2_i / c2)`` so that a direction fitted far off (a badly fitted family)
    cannot pull the rotation. ``R0``: start (default: weighted Procrustes).
    """
    a = _unit_rows(as_float_array(a, "a", 3).reshape(-1, 3), "a")
    b = _unit_rows(as_float_array(b, "b", 3).reshape(-1, 3), "b")
    Ca = as_float_array(cov_a, "cov_a", (3, 3)).reshape(-1, 3, 3)
    Cb = as_float_array(cov_b, "cov_b", (3, 3)).reshape(-1, 3, 3)
    if not (len(a) == len(b) == len(Ca) == len(Cb)):
        raise CatadioptricError(f"a, b, cov_a, cov_b: expected the same count, got {len(a)}, {len(b)}, "
                                f"{len(Ca)}, {len(Cb)}")
    if R0 is None:
        tr = np.trace(Ca, axis1=1, axis2=2) + np.trace(Cb, axis1=1, axis2=2)
        R = rotation_from_directions(a, b, 1.0 / np.maximum(tr, 1e-300))
    else:
        R = as_rotation(R0, "R0")
    rw = np.ones(len(a))
    for _ in range(iters):
        Ra = a @ R.T
        W = information(b, Cb + R @ Ca @ R.T)
        r = b - Ra
        chi2 = np.einsum("ni,nij,nj->n", r, W, r)
        rw = 1.0 / (1.0 + chi2 / c2) if robust else np.ones(len(a))
        J = skew(Ra)  # d r / d w
        H = np.einsum("n,nki,nkl,nlj->ij", rw, J, W, J)
        g = np.einsum("n,nki,nkl,nl->i", rw, J, W, r)
        try:
            dw = -np.linalg.solve(H, g)
        except np.linalg.LinAlgError:
            dw = -np.linalg.lstsq(H, g, rcond=None)[0]
        R = exp_rotation(dw) @ R
        if np.linalg.norm(dw) < 1e-13:
            break
    Ra = a @ R.T
    W = information(b, Cb + R @ Ca @ R.T)
    r = b - Ra
    chi2 = np.einsum("ni,nij,nj->n", r, W, r)
    rw = 1.0 / (1.0 + chi2 / c2) if robust else np.ones(len(a))
    J = skew(Ra)
    H = np.einsum("n,nki,nkl,nlj->ij", rw, J, W, J)
    cov = np.linalg.pinv(H)
    chi2 = np.maximum(chi2, 0.0)
    cost = float(np.sum(c2 * np.log1p(chi2 / c2))) if robust else float(np.sum(chi2))
    return DirectionRotation(R=R, cov=cov, chi2=chi2, weights=rw, cost=cost)
