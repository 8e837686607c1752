"""Lines grown along their own curves: each line's plane taken back to every point of the image
(band centres and step edges, :mod:`catadioptric.detect.centres`), so that what the chains lost
(a line broken by noise into pieces shorter than a chain's minimum, a junction, a change of
polarity) is taken back.

For each line with plane normal ``n``: the points within ``threshold`` pixels of its curve
(:func:`catadioptric.linefit.planes.plane_distances`) whose gradient lies across the curve (the
curve's normal in the image, ``Jd^T n``, within ``max_turn_deg`` of the point's normal) are
ordered along the plane with the line's own points; the run of them that holds the line's own
points, with no step longer than ``max_gap`` pixels, is the grown line. Its plane is refitted
(:func:`~catadioptric.linefit.planes.refine_plane`) and the points farther than ``threshold``
dropped; the line stays as it was if it would lose points or its rms grow by more than half the
threshold. A line that growing made a part of a longer one (most of its points within 0.7 px of
the longer line's, the planes within 5 degrees) is then dropped.

Measured on the benchmark's views: docs/detect.md, step 7, "Growing".
"""
from __future__ import annotations

import numpy as np

from .._checks import CatadioptricError
from ..linefit.planes import Rays, plane_distances, refine_plane
from .curves import LinePiece, concat_rays

__all__ = ["grow_lines"]

_SAME_PX = 0.7  # a point this close to a line's own point is that point
_SAME_DEG = 5.0


def _grow_one(p: LinePiece, uv: np.ndarray, normal: np.ndarray, rays: Rays, threshold: float, max_gap: float,
              cos_turn: float) -> LinePiece:
    from scipy.spatial import cKDTree

    n = p.normal
    r = plane_distances(n, rays)
    g = np.einsum("mki,k->mi", rays.Jd, n)  # the curve's normal in the image at each point
    cosang = np.abs(np.sum(g * normal, axis=1)) / np.maximum(np.linalg.norm(g, axis=1), 1e-300)
    cand = np.flatnonzero((r <= threshold) & (cosang >= cos_turn))
    if len(cand):
        cand = cand[cKDTree(p.uv).query(uv[cand])[0] > _SAME_PX]
    if len(cand) == 0:
        return p
    all_uv = np.concatenate([p.uv, uv[cand]])
    all_rays = concat_rays([p.rays, rays.take(cand)])
    own = np.r_[np.ones(p.length, bool), np.zeros(len(cand), bool)]
    e1 = p.rays.d[0] - (p.rays.d[0] @ n) * n
    e1 /= max(np.linalg.norm(e1), 1e-300)
    ang = np.arctan2(all_rays.d @ np.cross(n, e1), all_rays.d @ e1)
    o = np.argsort(ang)
    step = np.linalg.norm(np.diff(all_uv[o], axis=0), axis=1)
    cut = np.flatnonzero(step > max_gap)
    starts, ends = np.r_[0, cut + 1], np.r_[cut + 1, len(o)]
    held = [(a, b) for a, b in zip(starts, ends) if own[o[a:b]].any()]
    sel = np.union1d(o[held[0][0]: held[-1][1]], np.flatnonzero(own))
    if len(sel) <= p.length:
        return p
    n2 = refine_plane(all_rays.take(sel), n)
    r2 = plane_distances(n2, all_rays.take(sel))
    keep = np.isfinite(r2) & (r2 <= threshold)
    sel = sel[keep]
    if len(sel) <= p.length:
        return p
    rms = float(np.sqrt(np.mean(r2[keep] ** 2)))
    if rms > p.rms + 0.5 * threshold:
        return p
    return LinePiece(uv=all_uv[sel], rays=all_rays.take(sel), normal=n2, rms=rms, sources=list(p.sources),
                     polarity=p.polarity)


def grow_lines(lines: list[LinePiece], uv: np.ndarray, normal: np.ndarray, rays: Rays, *, threshold: float = 1.0,
               max_gap: float = 3.0, max_turn_deg: float = 25.0) -> list[LinePiece]:
    """``lines`` grown over the image's points ``uv (N, 2)`` with unit gradient ``normal (N, 2)``
    and ``rays`` (module docstring); longest first."""
    from scipy.spatial import cKDTree

    uv = np.asarray(uv, float).reshape(-1, 2)
    normal = np.asarray(normal, float).reshape(-1, 2)
    if len(uv) != len(normal) or len(uv) != len(rays.d):
        raise CatadioptricError(f"uv, normal, rays: expected one row per point, got {len(uv)}, {len(normal)}, "
                                f"{len(rays.d)}")
    cos_turn = float(np.cos(np.radians(max_turn_deg)))
    grown = sorted((_grow_one(p, uv, normal, rays, threshold, max_gap, cos_turn) for p in lines),
                   key=lambda q: -q.length)
    kept, trees = [], []
    cos_same = np.cos(np.radians(_SAME_DEG))
    for q in grown:
        if any(abs(float(q.normal @ k.normal)) > cos_same and np.mean(t.query(q.uv)[0] <= _SAME_PX) >= 0.8
               for k, t in zip(kept, trees)):
            continue
        kept.append(q)
        trees.append(cKDTree(q.uv))
    return kept
