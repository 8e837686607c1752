"""The centre line of a thin band: the two edges of a line tube paired, their midpoints kept.

The renderers draw every labelled line as a thin tube, a band of one to a few pixels across,
darker (or lighter) than what lies on either side. Its two edges have opposite gradients
(both point away from a dark band, both towards a light one). For each edge point ``p`` with
unit gradient ``n``: among the edge points ``q`` within ``max_width`` whose gradient ``m`` is
opposite (``n . m < -cos(max_angle)``) and which lie across from ``p`` (within ``max_lateral``
pixels of the line through ``p`` along ``n``), the nearest one across gives the crossing
``t = (q - p) . m / (n . m)`` of the normal through ``p`` with the tangent of the other edge at
``q``; the band's centre is ``p + t n / 2`` and its width ``|t|``. A pair counts when it is mutual
(the other edge's nearest partner lies within a pixel of ``p``). The midpoint of the two edges
is where the tube's axis is imaged (to first order in the width). Shading across the tube moves
it far less than it moves the band's darkest point (a ridge detector's answer): a band 3.2 pixels
wide whose edges have contrasts of 110 and 70 grey levels has its darkest point 1.6 pixels off
its centre and its edges' midpoint 0.15 pixel (``tests/test_detect.py``); the Gaussian of the
gradients pulls the weaker edge towards the stronger.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .edges import Edges

__all__ = ["Centres", "pair_edges", "step_edges"]

# points per block of :func:`pair_edges` (its arrays hold ``neighbours`` entries per point)
_BLOCK = 1 << 15


@dataclass
class Centres:
    """Points on the lines of the image: ``uv (N, 2)``, ``normal (N, 2)`` (unit, across the line:
    a band's first edge's gradient, a step edge's gradient), ``width (N,)`` pixels (0 for a step
    edge), ``polarity (N,)`` (+1 a light band, -1 a dark band, 0 a step edge), ``strength (N,)``
    (the weaker edge's gradient magnitude)."""

    uv: np.ndarray
    normal: np.ndarray
    width: np.ndarray
    polarity: np.ndarray
    strength: np.ndarray

    def __len__(self) -> int:
        return len(self.uv)

    @property
    def tangent(self) -> np.ndarray:
        """Unit tangents (the normals turned by 90 degrees)."""
        return np.stack([-self.normal[:, 1], self.normal[:, 0]], axis=1)

    @classmethod
    def concatenate(cls, parts) -> "Centres":
        return cls(*(np.concatenate([getattr(p, f) for p in parts]) for f in ("uv", "normal", "width", "polarity",
                                                                               "strength")))

    def one_per_pixel(self) -> "Centres":
        """Points of one polarity that fall in one pixel merged (their mean): the two edges of a band
        give two midpoints per pixel of its length."""
        if len(self) == 0:
            return self
        key = np.stack([np.rint(self.uv[:, 0]), np.rint(self.uv[:, 1]), self.polarity], axis=1).astype(np.int64)
        _, inv, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
        inv = inv.ravel()
        ref = self.normal[np.unique(inv, return_index=True)[1]][inv]
        sgn = np.where(np.sum(self.normal * ref, axis=1) < 0, -1.0, 1.0)
        mean = lambda a: np.stack([np.bincount(inv, a[:, k]) for k in range(a.shape[1])], axis=1) / counts[:, None]
        nrm = mean(self.normal * sgn[:, None])
        nrm /= np.maximum(np.linalg.norm(nrm, axis=1), 1e-300)[:, None]
        pol = np.zeros(len(counts), dtype=self.polarity.dtype)
        pol[inv] = self.polarity
        return Centres(mean(self.uv), nrm, np.bincount(inv, self.width) / counts, pol,
                       np.bincount(inv, self.strength) / counts)


def _empty() -> Centres:
    return Centres(np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0), np.zeros(0, int), np.zeros(0))


def step_edges(edges: Edges, idx) -> Centres:
    """Edge points ``idx`` of ``edges`` as points of step edges (polarity 0, width 0)."""
    idx = np.asarray(idx, dtype=np.int64)
    return Centres(edges.uv[idx], edges.normal[idx], np.zeros(len(idx)), np.zeros(len(idx), int),
                   edges.strength[idx])


def pair_edges(edges: Edges, *, max_width: float = 6.0, min_width: float = 0.5, max_lateral: float = 1.0,
               max_angle_deg: float = 30.0, neighbours: int = 32) -> tuple[Centres, np.ndarray]:
    """Centre points of the bands between pairs of opposite edges (module docstring), one per
    pixel, and a boolean mask over ``edges`` of the edge points that are part of a pair."""
    from scipy.spatial import cKDTree

    N = len(edges)
    used = np.zeros(N, dtype=bool)
    if N < 2:
        return _empty(), used
    p, n = edges.uv, edges.normal
    k = min(neighbours, N)
    tree = cKDTree(p)
    has = np.zeros(N, dtype=bool)
    partner = np.full(N, -1, dtype=np.int64)
    tb = np.zeros(N)
    # in blocks of points: the (points, k, 2) arrays of all the edge points at once took 345 MiB on a
    # 2000x2000 render; each point's partner is its own, the same in any block
    for a in range(0, N, _BLOCK):
        pa, na = p[a:a + _BLOCK], n[a:a + _BLOCK]
        M = len(pa)
        dist, idx = tree.query(pa, k=k, distance_upper_bound=max_width + max_lateral)
        ok = np.isfinite(dist) & (idx != np.arange(a, a + M)[:, None])
        idx = np.where(ok, idx, 0)
        q, m = p[idx], n[idx]  # (M, k, 2)
        d = q - pa[:, None, :]
        nm = np.einsum("ni,nki->nk", na, m)
        t_perp = np.array([-1.0, 1.0]) * na[:, ::-1]  # (M, 2): n rotated by 90 degrees
        lateral = np.abs(np.einsum("ni,nki->nk", t_perp, d))
        with np.errstate(invalid="ignore", divide="ignore"):
            t = np.einsum("nki,nki->nk", d, m) / nm
        ok &= (nm < -np.cos(np.radians(max_angle_deg))) & (lateral <= max_lateral)
        ok &= (np.abs(t) >= min_width) & (np.abs(t) <= max_width)
        score = np.where(ok, np.abs(t) + 0.25 * lateral, np.inf)
        best = np.argmin(score, axis=1)
        r = np.arange(M)
        has[a:a + M] = np.isfinite(score[r, best])
        partner[a:a + M] = np.where(has[a:a + M], idx[r, best], -1)
        tb[a:a + M] = t[r, best]
    # mutual: the partner's own partner lies within a pixel of p
    pp = np.where(partner >= 0, partner, 0)
    back = partner[pp]
    mutual = has & (back >= 0) & (np.linalg.norm(p[np.where(back >= 0, back, 0)] - p, axis=1) <= 1.0)
    sel = np.flatnonzero(mutual)
    if len(sel) == 0:
        return _empty(), used
    used[sel] = True
    used[partner[sel]] = True
    uv = p[sel] + 0.5 * tb[sel, None] * n[sel]
    # a light band lies on the bright side (+n) of its edges
    polarity = np.where(tb[sel] > 0, 1, -1)
    strength = np.minimum(edges.strength[sel], edges.strength[partner[sel]])
    c = Centres(uv=uv, normal=n[sel], width=np.abs(tb[sel]), polarity=polarity, strength=strength)
    return c.one_per_pixel(), used
