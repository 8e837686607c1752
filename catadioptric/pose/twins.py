"""A symmetric planar target's twins: the answers a chessboard's lines cannot tell apart.

A chessboard's lines (its rows and columns, on one plane) map onto themselves under a half-turn
about each of the board's three axes: the normal through its centre, and its row and column
directions through its centre (for an odd number of squares each way its colours too). The board's
motion between two views is then known only up to those turns: with ``R_i``, ``R_j`` the board's
orientations in the two cameras and ``S`` a half-turn in the board's frame, ``R_j S R_i^T = R H``,
``R = R_j R_i^T`` the motion and ``H = R_i S R_i^T = 2 a a^T - I`` the half-turn about the board's
axis ``a`` in A's frame. Which of ``R`` and ``R H`` a matching ranks first says only which lines
each view found and how the grid's equal spacing let them be matched, not which is true.

:func:`flag_twins` marks an answer whose twin (a candidate within :data:`TWIN_DEG` of ``R H``
for an axis ``a`` of its matched families) is listed: ambiguous, the twins named. Only for lines
known to be those of such a target (``--symmetric-target``, implied by ``--preset chessboard``): in
a scene the same turns are ruled out by where its lines are.
"""
from __future__ import annotations

import numpy as np

from .rotation import rotation_angle_deg

__all__ = ["TWIN_DEG", "half_turn", "target_axes", "twins", "flag_twins"]

#: a candidate is the answer's twin when within this many degrees of the answer turned by a half-turn
#: about one of the target's axes (its families are each within about a degree of the board's axes on
#: the real boards of validate/real; a quarter turn, the next rival, is 90 degrees away)
TWIN_DEG = 5.0

#: two matched directions closer than this (degrees) to parallel give no normal
_MIN_NORMAL_DEG = 30.0


def half_turn(axis) -> np.ndarray:
    """The rotation by 180 degrees about the unit ``axis (3,)``: ``2 a a^T - I``."""
    a = np.asarray(axis, float)
    a = a / np.linalg.norm(a)
    return 2.0 * np.outer(a, a) - np.eye(3)


def target_axes(pose) -> np.ndarray:
    """``(K, 3)``: the axes in A's frame about which the target's half-turns are taken: the
    directions of the answer's matched families in A and the normal of each pair of them at least
    :data:`_MIN_NORMAL_DEG` from parallel (a board's rows and columns give its three axes)."""
    # the assignment names A's families as the matching keyed them (strings); the estimates by the view's keys
    est_a = {str(k): e for k, e in (pose.estimates[0] if pose.estimates else {}).items()}
    dirs = []
    for v in pose.candidates[0].signs.values():
        a = str(v[0]) if isinstance(v, tuple) else None
        if a is not None and a in est_a:
            dirs.append(np.asarray(est_a[a].direction, float))
    axes = list(dirs)
    for i in range(len(dirs)):
        for j in range(i + 1, len(dirs)):
            n = np.cross(dirs[i], dirs[j])
            if np.linalg.norm(n) > np.sin(np.radians(_MIN_NORMAL_DEG)):
                axes.append(n / np.linalg.norm(n))
    return np.array(axes).reshape(-1, 3)


def twins(pose, tol_deg: float = TWIN_DEG) -> list[dict]:
    """The candidates of ``pose`` (after the first) within ``tol_deg`` of its answer turned by a
    half-turn about one of :func:`target_axes`: ``[{"candidate": k, "axis": a (3,), "deg": off}]``,
    the nearest axis of each."""
    R0 = np.asarray(pose.candidates[0].R, float)
    axes = target_axes(pose)
    turned = [R0 @ half_turn(a) for a in axes]
    out = []
    for k, c in enumerate(pose.candidates[1:], start=1):
        R = np.asarray(c.R, float)
        if not np.all(np.isfinite(R)) or not len(turned):
            continue
        off = [rotation_angle_deg(R @ T.T) for T in turned]
        i = int(np.argmin(off))
        if off[i] <= tol_deg:
            out.append({"candidate": k, "axis": axes[i].tolist(), "deg": float(off[i])})
    return out


def flag_twins(pose, tol_deg: float = TWIN_DEG) -> list[dict]:
    """Mark ``pose`` (lines of a target symmetric under half-turns about its axes) ambiguous when its
    answer's twin is among its candidates: ``pose.ambiguous`` set, ``"symmetric_target"`` added to
    ``pose.evidence["ambiguous_by"]``, the twins in ``pose.evidence["twins"]`` and a note. Returns the
    twins (:func:`twins`)."""
    found = twins(pose, tol_deg)
    if not found:
        return found
    ev = pose.evidence if pose.evidence is not None else {}
    pose.evidence = ev
    ev["twins"] = found
    ev["ambiguous_by"] = [*ev.get("ambiguous_by", []), "symmetric_target"]
    pose.ambiguous = True
    names = ", ".join(f"candidate {t['candidate']}" for t in found)
    pose.notes = [*pose.notes, f"ambiguous: a symmetric target's twin ({names}: the answer turned by a half-turn "
                               f"about one of the target's axes) explains the same lines; its motion is known "
                               f"only up to that turn"]
    return found
