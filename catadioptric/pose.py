"""Rotation and translation of a rig from directions and lines (the paper's Sec. 5.2-5.3).

Conventions (docs/conventions.md): a world point has mirror coordinates
``x_M = R x_W + t``; a direction ``s_W`` becomes ``R s_W``. Lines are Pluecker
``(s, m)`` with ``m = q x s``.
"""
from __future__ import annotations

import itertools

import numpy as np

from ._checks import CatadioptricError, as_float_array

__all__ = ["rotation_from_directions", "rotation_with_sign_search", "translation_from_lines",
           "rotation_angle_deg", "relative_rotation"]


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def rotation_from_directions(a, b, weights=None) -> np.ndarray:
    """The rotation ``R`` minimising ``sum_i w_i |b_i - R a_i|^2`` (orthogonal Procrustes, det +1).

    ``a, b (N, 3)``: the same directions in two frames (any length; normalised here).
    N >= 2 non-parallel directions are needed; with N = 2 the cross product is added, as in
    the paper's minimal case.
    """
    a = as_float_array(a, "a", 3).reshape(-1, 3)
    b = as_float_array(b, "b", 3).reshape(-1, 3)
    if a.shape != b.shape:
        raise CatadioptricError(f"a, b: expected the same number of directions, got {len(a)} and {len(b)}")
    if len(a) < 2:
        raise CatadioptricError(f"a: expected at least 2 directions, got {len(a)}")
    a, b = _unit(a), _unit(b)
    w = np.ones(len(a)) if weights is None else np.asarray(weights, float).reshape(-1)
    if len(a) == 2:
        a = np.vstack([a, _unit(np.cross(a[0], a[1]))])
        b = np.vstack([b, _unit(np.cross(b[0], b[1]))])
        w = np.r_[w, np.sqrt(w[0] * w[1])]
    if np.linalg.matrix_rank(a, tol=1e-9) < 2:
        raise CatadioptricError("a: expected at least two non-parallel directions, got parallel ones")
    H = (b * w[:, None]).T @ a
    U, _, Vt = np.linalg.svd(H)
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt))])
    return U @ D @ Vt


def rotation_with_sign_search(a, b, weights=None) -> tuple[np.ndarray, np.ndarray]:
    """Procrustes when the directions ``b`` are known up to sign (a family of parallel lines
    fixes a direction, not its orientation): tries every sign pattern (the first kept) and
    returns ``(R, signs)`` with the smallest residual. Exponential in N; N <= 16."""
    a = as_float_array(a, "a", 3).reshape(-1, 3)
    b = as_float_array(b, "b", 3).reshape(-1, 3)
    if len(b) > 16:
        raise CatadioptricError(f"b: expected at most 16 directions for the sign search, got {len(b)}")
    best = (np.inf, None, None)
    for pattern in itertools.product((1.0, -1.0), repeat=max(len(b) - 1, 0)):
        sg = np.r_[1.0, pattern]
        bb = b * sg[:, None]
        R = rotation_from_directions(a, bb, weights)
        res = np.sum(np.linalg.norm(_unit(bb) - _unit(a) @ R.T, axis=1) ** 2)
        if res < best[0]:
            best = (res, R, sg)
    return best[1], best[2]


def translation_from_lines(R, world_lines, ray_lines, line_index) -> np.ndarray:
    """Translation ``t`` of ``x_M = R x_W + t`` from pixels of known world lines (the paper's Sec. 5.3).

    ``world_lines (L, 6)``: Pluecker ``(s, m)`` of lines in W; ``ray_lines (M, 6)``: Pluecker
    coordinates in M of the reflected rays of pixels that image them (``ray_lines[j]`` images
    ``world_lines[line_index[j]]``). Each ray meets its line:
    ``t . (R s x s_j) = -(s_j . R m + m_j . R s)``; least squares over all rays.
    At least three rays over two lines are needed.
    """
    R = as_float_array(R, "R", (3, 3))
    W = as_float_array(world_lines, "world_lines", 6).reshape(-1, 6)
    P = as_float_array(ray_lines, "ray_lines", 6).reshape(-1, 6)
    idx = np.asarray(line_index, dtype=int).reshape(-1)
    if len(idx) != len(P):
        raise CatadioptricError(f"line_index: expected {len(P)} entries (one per ray), got {len(idx)}")
    if len(P) < 3:
        raise CatadioptricError(f"ray_lines: expected at least 3 rays, got {len(P)}")
    Rs = W[idx, :3] @ R.T
    Rm = W[idx, 3:] @ R.T
    sj, mj = P[:, :3], P[:, 3:]
    A = np.cross(Rs, sj)
    b = -(np.sum(sj * Rm, axis=1) + np.sum(mj * Rs, axis=1))
    t, *_ = np.linalg.lstsq(A, b, rcond=None)
    return t


def rotation_angle_deg(R) -> float:
    """The angle of a rotation matrix in degrees."""
    R = np.asarray(R, float)
    # atan2 of the sine (from the skew part) and the cosine (from the trace): accurate at small angles
    sin = 0.5 * np.linalg.norm([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    return float(np.degrees(np.arctan2(sin, (np.trace(R) - 1) / 2)))


def relative_rotation(dirs_a, dirs_b, weights=None, *, signs_known: bool = False) -> np.ndarray:
    """Rotation ``R_BA`` with ``s_B = R_BA s_A`` between two views' mirror frames, from matched
    directions (e.g. families of parallel lines seen in both views)."""
    if signs_known:
        return rotation_from_directions(dirs_a, dirs_b, weights)
    return rotation_with_sign_search(dirs_a, dirs_b, weights)[0]
