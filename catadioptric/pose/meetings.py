"""The lines that meet, in the two-view refinement (:mod:`catadioptric.pose.bundle`).

Stage 1 of :func:`~catadioptric.pose.relative_pose` finds pairs of lines whose meeting rays (where
their two planes through each view's centre meet) obey the epipolar constraint
(:func:`~catadioptric.pose.central.translation_direction_from_crossings`). The pixels of a line
pin its plane through each centre far better than where the line lies in it, and two planes
always meet: the lines alone barely tell a near-central rig's translation direction. These pairs
therefore enter the refinement as residuals of their own: from each view's centre, the ray that
meets both current 3-D lines,

    x_A = (V_1 x s_1) x (V_2 x s_2),   x_B = ((R V_1 + t^) x R s_1) x ((R V_2 + t^) x R s_2)

(``V_i`` a point of line i relative to ``c_A`` in units of the baseline, ``s_i`` its direction,
``t^`` the unit displacement between the centres), and the epipolar residual
``t^ . (R x_A x x_B)`` of the two unit rays. It is zero when the lines meet, and also when they do
not but both rays lie in one plane with the baseline (a line parallel to the baseline lies in
one plane with both centres, and so does its meeting ray with any other line): on the
benchmark's hyperbolic pair 4 only 18 of stage 1's 146 inlier meeting rays belong to lines that
meet, and asking the lines themselves to meet biased the rotation
(the research log, validate/NOTES.md: "meeting_lines"; docs/relative_pose.md, step 4).
"""
from __future__ import annotations

import numpy as np

from .._checks import CatadioptricError
from .._numeric import cross, row_norm
from .rotation import skew

__all__ = ["meeting_terms", "meeting_residuals", "check_corners"]


def meeting_terms(pb, R, y):
    """Where two lines meet (``pb.corners``, pairs of lines of different families, of the
    two-view refinement's problem ``pb``): the epipolar residual (module docstring) at rotation ``R``
    and unknowns ``y``, in units of ``pb.corner_sigma``; ``r (K,)`` and its Jacobian ``J (K, ny)``
    (rotation, translation's direction, the two families' directions and the two lines' charts;
    the scale cancels). The derivatives in the rays' own coordinates are central differences,
    chained analytically to the unknowns."""
    K = len(pb.corners)
    J = np.zeros((K, pb.ny))
    if K == 0:
        return np.zeros(0), J
    s, nv, al, rho, u, that, ntv, _ = pb.parts(y)
    l1, l2 = pb.corners[:, 0], pb.corners[:, 1]
    f1, f2 = pb.fam[l1], pb.fam[l2]
    X = _lines_in_b(pb, R, s, rho, u, that)
    r = _transversal_residual(X)
    h = 1e-7
    # the 15 coordinates' central differences in one batch: 30 perturbed copies of X (each row's
    # residual is computed alone, so the batch gives the bits of one call per copy)
    Xs = np.broadcast_to(X, (2, 15) + X.shape).copy()
    for i in range(15):
        Xs[0, i, :, i // 3, i % 3] += h
        Xs[1, i, :, i // 3, i % 3] -= h
    rs = _transversal_residual(Xs.reshape(-1, 5, 3)).reshape(2, 15, K)
    D = ((rs[0] - rs[1]) / (2 * h)).T.reshape(K, 5, 3)
    k = np.arange(K)
    # rotation (left): dX = -[X]_x w for the four rotated vectors
    J[:, 0:3] = sum(-np.einsum("ki,kij->kj", D[:, a], skew(X[:, a])) for a in range(4))
    dthat = np.stack([(pb.f1 - that * (that @ pb.f1)) / ntv, (pb.f2 - that * (that @ pb.f2)) / ntv])
    J[:, 3:5] = D[:, 4] @ dthat.T
    base = 6 + 2 * pb.F
    for a, l, f in ((0, l1, f1), (2, l2, f2)):
        du = -np.sin(al[l])[:, None] * pb.e1[f] + np.cos(al[l])[:, None] * pb.e2[f]
        J[k, base + 2 * l] = np.sum(D[:, a] * ((du / rho[l][:, None]) @ R.T), 1)
        J[k, base + 2 * l + 1] = np.sum(D[:, a] * ((-u[l] / rho[l][:, None] ** 2) @ R.T), 1)
        for j, e in enumerate((pb.e1[f], pb.e2[f])):
            ds = (e - s[f] * np.sum(s[f] * e, 1, keepdims=True)) / nv[f][:, None]
            J[k, 6 + 2 * f + j] = np.sum(D[:, a + 1] * (ds @ R.T), 1)
    sig = pb.corner_sigma
    return r / sig, J / sig[:, None]


def meeting_residuals(pb, R, y):
    """The residuals ``r (K,)`` of :func:`meeting_terms` alone (the same bits), without their Jacobian:
    what a trial step is judged by."""
    if len(pb.corners) == 0:
        return np.zeros(0)
    s, _, _, rho, u, that, _, _ = pb.parts(y)
    return _transversal_residual(_lines_in_b(pb, R, s, rho, u, that)) / pb.corner_sigma


def _lines_in_b(pb, R, s, rho, u, that):
    """``X (K, 5, 3)`` of :func:`_transversal_residual` for the corners' lines: in B's orientation,
    relative to c_A, in units of the baseline, ``U = R (P - c_A) / k``, ``T = R s``, then ``t^``."""
    l1, l2 = pb.corners[:, 0], pb.corners[:, 1]
    f1, f2 = pb.fam[l1], pb.fam[l2]
    r1, r2 = rho[l1], rho[l2]
    return np.stack([(u[l1] / r1[:, None]) @ R.T, s[f1] @ R.T, (u[l2] / r2[:, None]) @ R.T, s[f2] @ R.T,
                     np.broadcast_to(that, (len(l1), 3))], axis=1)


def _transversal_residual(X):
    """``X (K, 5, 3)``: two lines (point relative to c_A and direction, each), then the unit
    translation, all in B's orientation and units of the baseline. The epipolar residual of the
    rays from c_A and from c_B (at ``-t^`` from c_A: a point at ``U`` from c_A is at ``U + t^`` from
    c_B) that meet both lines."""
    U1, T1, U2, T2, th = (X[:, a] for a in range(5))
    xa = cross(cross(U1, T1), cross(U2, T2))
    xb = cross(cross(U1 + th, T1), cross(U2 + th, T2))
    den = np.maximum(row_norm(xa) * row_norm(xb), 1e-300)
    return np.sum(th * cross(xa, xb), axis=1) / den


def check_corners(corners, corner_sigma, line_family):
    """``(corners (K, 2) int, corner_sigma (K,))`` checked: pairs of line indices of different
    families, positive finite deviations; ``(None, None)`` for none."""
    if corners is None:
        if corner_sigma is not None:
            raise CatadioptricError("corner_sigma: expected None without corners, got deviations")
        return None, None
    c = np.asarray(corners)
    if c.size == 0:
        return None, None
    if c.ndim != 2 or c.shape[1] != 2 or not np.issubdtype(c.dtype, np.integer):
        raise CatadioptricError(f"corners: expected (K, 2) integer line indices, got an array of shape {c.shape} "
                                f"and dtype {c.dtype}")
    L = len(line_family)
    bad = (c < 0) | (c >= L)
    if bad.any():
        raise CatadioptricError(f"corners: expected line indices in [0, {L}), got {int(c[bad][0])}")
    same = line_family[c[:, 0]] == line_family[c[:, 1]]
    if same.any():
        k = int(np.flatnonzero(same)[0])
        raise CatadioptricError(f"corners: expected pairs of lines of different families, got lines {c[k].tolist()} "
                                f"of family {int(line_family[c[k, 0]])} (row {k})")
    if corner_sigma is None:
        raise CatadioptricError("corner_sigma: expected one deviation (radians) per corner, got None")
    sig = np.broadcast_to(np.asarray(corner_sigma, float), (len(c),)) if np.ndim(corner_sigma) == 0 \
        else np.asarray(corner_sigma, float).reshape(-1)
    if len(sig) != len(c):
        raise CatadioptricError(f"corner_sigma: expected {len(c)} deviations (one per corner), got {len(sig)}")
    if not np.all(np.isfinite(sig) & (sig > 0)):
        raise CatadioptricError(f"corner_sigma: expected positive finite deviations, got "
                                f"{float(sig[~(np.isfinite(sig) & (sig > 0))][0])!r}")
    return c.astype(int), sig.copy()
