"""Families found in two views at once: the lines one image alone cannot group.

A family of two or three lines in one image is not significant: any two planes meet along some
direction, so :func:`~catadioptric.detect.families.group_families` asks for three lines and a
low number of false alarms, and leaves the small families of a scene (the two edges of a
kerb at an odd angle, a marking's sides) unassigned. With the rotation ``R`` of a two-view answer
(``x_B = R x_A + t``), a line of B whose plane has normal ``n_B`` holds direction ``s`` of A's
frame when ``(R^T n_B) . s = 0``: the lines of both views can be voted on together, in A's frame,
and two lines in each view make a family of four.

:func:`joint_families` takes the lines of each view that are in no family matched across the views
(unassigned, or in a family of one view only), turns B's planes into A's frame (their covariances
grown by the rotation's own error, ``rotation_std_deg``, across each normal) and runs the same
vote (:func:`~catadioptric.detect.families.group_families`: a-contrario significance, blends
split, concurrent lines rejected per view) on the union; a family is kept when it has at least
``min_per_view`` lines in each view, is not within ``merge_deg`` of a matched family, and its
log number of false alarms over its *distinct* planes is at most ``max_log_nfa`` (a line seen in
both views from nearby places lies in nearly the same plane in both and would agree twice).
:func:`with_families` adds them to each view's detection.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._checks import CatadioptricError
from .families import (Family, GroupingOptions, LinePlanes, concurrent, group_families, log_nfa,
                       refine_direction)

__all__ = ["JointFamily", "joint_families", "with_families"]


@dataclass
class JointFamily:
    """A family found in both views: ``direction`` in A's mirror frame (``R @ direction`` in B's),
    its lines in each view (``lines_a``, ``lines_b``: indices into each detection)."""

    direction: np.ndarray
    lines_a: list
    lines_b: list


def _ends(det, idx):
    return np.array([[det.uv[i][0], det.uv[i][-1]] for i in idx]).reshape(-1, 2, 2)


def joint_families(det_a, det_b, R, *, taken_a=(), taken_b=(), rotation_std_deg: float = 0.0, min_pixels: int = 0,
                   min_per_view: int = 2, chi2_max: float = 9.0, angle_floor_deg: float = 0.1,
                   max_log_nfa: float = -6.0, concurrency_px: float = 5.0, merge_deg: float = 2.0,
                   known_directions=()) -> list[JointFamily]:
    """The families of the lines of detections ``det_a`` and ``det_b`` (module docstring) that are
    not in ``taken_a`` / ``taken_b`` (indices of lines already in matched families) and have at
    least ``min_pixels`` pixels. ``R``: the rotation from A's mirror frame to B's.
    ``known_directions``: the matched families' directions in A's frame (a family within
    ``merge_deg`` of one is not new). The other options are those of
    :func:`~catadioptric.detect.families.group_families`."""
    R = np.asarray(R, float)
    if R.shape != (3, 3) or not np.all(np.isfinite(R)):
        raise CatadioptricError(f"R: expected a finite 3x3 rotation, got an array of shape {R.shape}")
    taken_a, taken_b = set(int(i) for i in taken_a), set(int(i) for i in taken_b)
    free_a = [i for i in range(len(det_a)) if i not in taken_a and len(det_a.uv[i]) >= min_pixels]
    free_b = [i for i in range(len(det_b)) if i not in taken_b and len(det_b.uv[i]) >= min_pixels]
    if len(free_a) < min_per_view or len(free_b) < min_per_view:
        return []
    nb = det_b.normal[free_b] @ R  # rows R^T n_B
    cb = np.einsum("ji,njk,kl->nil", R, det_b.normal_cov[free_b], R)  # R^T C R
    # the rotation's own error moves B's planes in A's frame: an isotropic error across each normal
    e2 = np.radians(rotation_std_deg) ** 2
    cb = cb + e2 * (np.eye(3)[None] - nb[:, :, None] * nb[:, None, :])
    N = np.concatenate([det_a.normal[free_a], nb])
    C = np.concatenate([det_a.normal_cov[free_a], cb])
    pix = np.array([len(det_a.uv[i]) for i in free_a] + [len(det_b.uv[i]) for i in free_b])
    view = np.r_[np.zeros(len(free_a), int), np.ones(len(free_b), int)]
    label, fams = group_families(LinePlanes(N, C, pix), GroupingOptions(
        chi2_max=chi2_max, angle_floor_deg=angle_floor_deg, min_lines=2 * min_per_view, min_search_pixels=0,
        max_log_nfa=max_log_nfa, merge_deg=merge_deg))
    known = np.asarray(known_directions, float).reshape(-1, 3)
    out = []
    for f, fam in enumerate(fams):
        idx = np.flatnonzero(label == f)
        la = [free_a[i] for i in idx if view[i] == 0]
        lb = [free_b[i - len(free_a)] for i in idx if view[i] == 1]
        if len(la) < min_per_view or len(lb) < min_per_view:
            continue
        s = fam.direction
        if _log_nfa_distinct(N[idx], C[idx], s, len(N), chi2_max, angle_floor_deg) > max_log_nfa:
            continue
        if len(known) and np.degrees(np.arccos(np.clip(np.max(np.abs(known @ s)), 0.0, 1.0))) < merge_deg:
            continue
        if concurrency_px > 0 and (concurrent(det_a.cam, s, _ends(det_a, la), concurrency_px)
                                   or concurrent(det_b.cam, R @ s, _ends(det_b, lb), concurrency_px)):
            continue
        out.append(JointFamily(direction=s, lines_a=la, lines_b=lb))
    return out


def _log_nfa_distinct(N, C, s, n_free, chi2_max, angle_floor_deg):
    """The family's significance over its distinct planes: a line seen in both views from nearby
    places lies in nearly the same plane in both, and agrees with any direction in it twice, so
    planes closer than their bands of agreement count once (the most precise of them)."""
    floor2 = np.sin(np.radians(angle_floor_deg)) ** 2
    band = np.minimum(np.sqrt(chi2_max * (np.einsum("i,lij,j->l", s, C, s) + floor2)), 1.0)
    order = np.argsort(band)
    kept = []
    for i in order:
        if all(np.arccos(min(1.0, abs(float(N[i] @ N[j])))) > band[i] + band[j] for j in kept):
            kept.append(i)
    return log_nfa(band[kept], n_free)


def with_families(det, new_families, min_lines: int = 2):
    """A copy of detection ``det`` with each ``(lines, direction)`` of ``new_families`` made a new
    family (its direction refitted on its lines' planes from ``direction``), after its existing
    families (each refitted on the lines it keeps); the lines move from wherever they were, and
    an existing family left with fewer than ``min_lines`` lines is dropped. Returns
    ``(detection, indices of the new families)``."""
    from dataclasses import replace

    moved = {int(i) for ls, _ in new_families for i in ls}
    family = np.full(len(det), -1, dtype=np.int64)
    families = []
    for fam in det.families:
        keep = [i for i in fam.lines if i not in moved]
        if len(keep) < min_lines:
            continue
        s, cov = refine_direction(det.normal, det.normal_cov, np.array(keep), fam.direction)
        family[keep] = len(families)
        families.append(Family(direction=s, cov=cov, lines=keep, pixels=int(sum(len(det.uv[i]) for i in keep))))
    new = []
    for ls, s0 in new_families:
        ls = [int(i) for i in ls]
        s, cov = refine_direction(det.normal, det.normal_cov, np.array(ls), np.asarray(s0, float))
        family[ls] = len(families)
        new.append(len(families))
        families.append(Family(direction=s, cov=cov, lines=ls, pixels=int(sum(len(det.uv[i]) for i in ls))))
    return replace(det, family=family, families=families), new
