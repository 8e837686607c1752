"""A camera turned in place: its rotation from the lines it sees again unchanged.

A central camera that only turned (a tripod) sees every line of the scene's still part again
in the plane ``R n`` (``n``: the line's interpretation plane in view A) and over the same arc of
that plane; a camera that moved sees so only lines far enough for its baseline not to show. Such
"twins" decide between the rotations a Manhattan scene's directions allow when the matching of
meeting points cannot (real photographs, where a person and a board moved between the shots:
``validate/real``), and they give the rotation itself, from many lines at once.

:func:`static_rotation` takes the candidate rotations (the family assignments of the matching,
each from a handful of family directions, often half a degree off), and for each:

1. twins under the candidate with a loose floor on the planes' angle (:data:`FLOORS_PX` times the
   camera's angle per pixel), the rotation again from their normals (weighted Procrustes), and so
   down the floors;
2. the twins under that rotation with the final floor (:data:`FINAL_FLOOR_PX`, a camera model's
   own error: the real camera of ``validate/real`` is calibrated to 0.385 px rms).

The answer is the candidate with the most twins, when it has at least :data:`TWINS_MIN` and
every rival (a rotation more than ``same_deg`` away) at most 1 / :data:`TWINS_OVER_RIVAL` as many.
Measured on the six static pairs of ``validate/real`` (no mask; their candidates without a prior):
the right rotation shows 25-48 twins, 0.02-0.05 degree from the identity; its rivals at most 8,
the closest ratio 25 to 7 on the pair where a person and the board hide part of the room (a
half-turn about the vertical maps a room's opposite corners onto each other's planes).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .central import arc_on_plane, arc_overlap, rad_per_px
from .rotation import rotation_angle_deg, rotation_from_directions, skew

__all__ = ["StaticRotation", "static_rotation", "TWINS_MIN", "TWINS_OVER_RIVAL", "FLOORS_PX", "FINAL_FLOOR_PX"]

#: the answer needs at least this many twins, and this many times as many as any rival rotation
TWINS_MIN = 10
TWINS_OVER_RIVAL = 3.0
#: the floors on the angle between twin planes while the rotation is refined (pixels, times the
#: camera's median angle between neighbouring pixels), then the floor of the final count
FLOORS_PX = (9.0, 4.5, 2.25)
FINAL_FLOOR_PX = 1.0
#: chi-square bound on a twin's planes' angle over its deviation (2 degrees of freedom, 99 %)
CHI2_MAX = 9.21
#: a twin's two arcs overlap by at least this fraction of the shorter (the same segment, not another
#: line of the plane)
OVERLAP = 0.5


@dataclass
class StaticRotation:
    """The rotation of a camera turned in place. ``index``: the candidate it was refined from;
    ``R``; ``cov (3, 3)``: of its left rotation vector (from the twins' normal covariances, scaled
    by their chi-square per degree of freedom when above one); ``twins``: ``(line of A, line of B)``
    pairs seen again unchanged; ``rivals``: the rival rotations tried, ``rival_twins``: the most twins
    of one."""

    index: int
    R: np.ndarray
    cov: np.ndarray
    twins: list
    rivals: int
    rival_twins: int

    def note(self) -> str:
        return (f"decisive as a camera turned in place: its rotation alone shows {len(self.twins)} lines of A again "
                f"unchanged in B, the {self.rivals} rival rotations at most {self.rival_twins}; the rotation from "
                f"those lines' planes, t zero (its direction is not observable)")


@dataclass
class _Lines:
    """One view's lines held by its families: normals ``(L, 3)``, their variance ``(L,)`` (half
    the trace of the normal's covariance), covariances ``(L, 3, 3)``, line indices, rays ``[(M, 3)]``."""

    normals: np.ndarray
    var: np.ndarray
    covs: np.ndarray
    ids: list
    rays: list


def _lines(view, est) -> _Lines:
    normals, covs, ids, rays = [], [], [], []
    for fam in est.values():
        C = fam.normal_covs if fam.normal_covs is not None else np.zeros((len(fam.lines), 3, 3))
        for k, line in enumerate(fam.lines):
            r = view.cam.backproject(view.uv[line][fam.inliers[k]])
            normals.append(fam.normals[k])
            covs.append(C[k])
            ids.append(line)
            rays.append(r.directions[r.valid])
    normals = np.array(normals).reshape(-1, 3)
    covs = np.array(covs).reshape(-1, 3, 3)
    return _Lines(normals, 0.5 * np.trace(covs, axis1=1, axis2=2), covs, ids, rays)


def _twins(A: _Lines, B: _Lines, R, floor_rad) -> list:
    """``(i, m, sign)``: line ``i`` of A and ``m`` of B in planes ``sign R n_A = n_B`` within
    :data:`CHI2_MAX` deviations (at least ``floor_rad``), their arcs overlapping; one to one, the
    closest first."""
    if not len(A.normals) or not len(B.normals):
        return []
    nA = A.normals @ R.T
    dots = nA @ B.normals.T
    ang = np.arccos(np.clip(np.abs(dots), 0.0, 1.0))
    var = A.var[:, None] + B.var[None, :] + floor_rad**2
    ok = ang**2 <= CHI2_MAX * var
    out, used_a, used_b = [], set(), set()
    cand = sorted(zip(*np.nonzero(ok)), key=lambda im: ang[im])
    for i, m in cand:
        if i in used_a or m in used_b or len(A.rays[i]) < 2 or len(B.rays[m]) < 2:
            continue
        nb = B.normals[m]
        if arc_overlap(arc_on_plane(A.rays[i] @ R.T, nb), arc_on_plane(B.rays[m], nb)) >= OVERLAP:
            out.append((int(i), int(m), 1.0 if dots[i, m] >= 0 else -1.0))
            used_a.add(i)
            used_b.add(m)
    return out


def _refit(A: _Lines, B: _Lines, pairs, floor_rad):
    """The rotation from the twins' normals (weighted Procrustes) and its covariance."""
    i = np.array([p[0] for p in pairs])
    m = np.array([p[1] for p in pairs])
    s = np.array([p[2] for p in pairs])
    w = 1.0 / (A.var[i] + B.var[m] + floor_rad**2)
    R = rotation_from_directions(A.normals[i], s[:, None] * B.normals[m], weights=w)
    # information of the left rotation vector: r = s n_B - R n_A, dr/dw = [R n_A]_x
    info = np.zeros((3, 3))
    chi2 = 0.0
    for k in range(len(i)):
        Ra = R @ A.normals[i[k]]
        C = B.covs[m[k]] + R @ A.covs[i[k]] @ R.T + floor_rad**2 * (np.eye(3) - np.outer(Ra, Ra))
        W = np.linalg.pinv(C, hermitian=True)
        J = skew(Ra)
        info += J.T @ W @ J
        r = s[k] * B.normals[m[k]] - Ra
        chi2 += float(r @ W @ r)
    cov = np.linalg.pinv(info, hermitian=True) * max(1.0, chi2 / max(2 * len(i) - 3, 1))
    return R, cov


def _refined(A: _Lines, B: _Lines, R, unit):
    """The candidate ``R`` refined down the floors; ``(R, cov, twins)`` under the final floor."""
    cov = np.full((3, 3), np.nan)
    for f in FLOORS_PX:
        pairs = _twins(A, B, R, f * unit)
        if len(pairs) < 3:
            break
        R, cov = _refit(A, B, pairs, f * unit)
    pairs = _twins(A, B, R, FINAL_FLOOR_PX * unit)
    if len(pairs) >= 3:
        R, cov = _refit(A, B, pairs, FINAL_FLOOR_PX * unit)
    return R, cov, pairs


def static_rotation(view_a, view_b, ea, eb, rotations, *, same_deg: float = 5.0) -> StaticRotation | None:
    """The rotation of a camera turned in place among ``rotations`` (candidates, best first), or
    None when none shows :data:`TWINS_MIN` twins and :data:`TWINS_OVER_RIVAL` times any rival's.

    ``view_a``, ``view_b``: :class:`~catadioptric.pose.families.ViewLines` of a central camera;
    ``ea``, ``eb``: each view's :class:`~catadioptric.pose.families.FamilyEstimate` dicts (keyed
    independently: twins are sought among all the lines of every family)."""
    A, B = _lines(view_a, ea), _lines(view_b, eb)
    unit = rad_per_px(view_a.cam)
    refined = [(*_refined(A, B, np.asarray(R0, float), unit), k) for k, R0 in enumerate(rotations)]
    refined.sort(key=lambda f: -len(f[2]))
    found = []  # the most twins first; a rotation within same_deg of one kept is the same answer
    for f in refined:
        if not any(rotation_angle_deg(f[0] @ g[0].T) <= same_deg for g in found):
            found.append(f)
    if not found:
        return None
    R, cov, pairs, k = found[0]
    rival = max((len(f[2]) for f in found[1:]), default=0)
    if len(pairs) < TWINS_MIN or rival * TWINS_OVER_RIVAL > len(pairs):
        return None
    twins = [(A.ids[i], B.ids[m]) for i, m, _ in pairs]
    return StaticRotation(k, R, cov, twins, len(found) - 1, rival)
