"""What each detected line looks like: the colour on either side of its curve.

A line of the scene is the edge between two surfaces (a facade and the sky, a window and its
wall, a marking and the road); the colours on its two sides are much the same in two views taken
a few metres apart, while two different lines of one family often border different surfaces. The
families found in both views at once (:mod:`catadioptric.detect.joint_families`) use that to tell
one segment seen twice from a chance pairing of lines.

Sides: at every pixel of the line, the image is sampled along the curve's normal (in the image) at
``width / 2 + gap`` to ``width / 2 + gap + reach`` pixels on each side (``width``: the band's,
0 for a step edge); each side's colour is the median of its samples per channel (bilinear; samples
off the image are left out). The sides carry no order that two views share (a plane normal's sign
is arbitrary in each), so two lines are compared both ways and the better is kept
(:func:`side_distance`).
"""
from __future__ import annotations

import numpy as np

from .._checks import CatadioptricError

__all__ = ["line_sides", "side_distance"]


def _normals(uv: np.ndarray) -> np.ndarray:
    """Unit image normals ``(M, 2)`` of an ordered curve ``uv (M, 2)``: the tangent of a 5-point
    moving average, turned by 90 degrees."""
    if len(uv) < 2:
        return np.tile([0.0, 1.0], (len(uv), 1))
    k = min(5, len(uv))
    pad = np.pad(uv, ((k // 2, k - 1 - k // 2), (0, 0)), mode="edge")
    smooth = np.stack([np.convolve(pad[:, c], np.full(k, 1.0 / k), mode="valid") for c in range(2)], axis=1)
    t = np.gradient(smooth, axis=0)
    t /= np.maximum(np.linalg.norm(t, axis=1), 1e-12)[:, None]
    return np.stack([-t[:, 1], t[:, 0]], axis=1)


def line_sides(channels, uv: list, width, *, gap: float = 2.0, reach: float = 3.0) -> np.ndarray:
    """The colour on each side of every line: ``(L, 2, C)`` for ``channels (H, W, C)`` (or ``(H, W)``),
    ``uv``: each line's ordered pixels ``(M_i, 2)``, ``width (L,)``: each band's width in pixels
    (module docstring). A side with no sample on the image is NaN."""
    import cv2

    img = np.asarray(channels, dtype=np.float32)
    if img.ndim == 2:
        img = img[..., None]
    if img.ndim != 3:
        raise CatadioptricError(f"channels: expected an (H, W) or (H, W, C) array, got shape {img.shape}")
    width = np.asarray(width, float).reshape(-1)
    if len(width) != len(uv):
        raise CatadioptricError(f"width: expected one per line ({len(uv)}), got {len(width)}")
    if gap < 0 or reach < 0:
        raise CatadioptricError(f"gap, reach: expected numbers >= 0, got {gap!r}, {reach!r}")
    C = img.shape[2]
    out = np.full((len(uv), 2, C), np.nan)
    if not uv:
        return out
    steps = np.arange(0.0, reach + 1e-9, 1.0)
    pts, owner = [], []
    for i, u in enumerate(uv):
        u = np.asarray(u, float).reshape(-1, 2)
        n = _normals(u)
        for side, sgn in enumerate((1.0, -1.0)):
            off = sgn * (0.5 * width[i] + gap + steps)  # (S,)
            p = u[None, :, :] + off[:, None, None] * n[None]  # (S, M, 2)
            pts.append(p.reshape(-1, 2))
            owner.append(np.full(len(pts[-1]), 2 * i + side))
    P = np.concatenate(pts).astype(np.float32)
    own = np.concatenate(owner)
    # cv2.remap takes at most 32767 columns per row: one row per chunk
    vals = []
    for a in range(0, len(P), 32000):
        q = P[a:a + 32000]
        v = cv2.remap(img, q[None, :, 0], q[None, :, 1], cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT,
                      borderValue=(np.nan,) * 4)
        vals.append(v.reshape(len(q), C))
    V = np.concatenate(vals)
    H, W = img.shape[:2]
    on = (P[:, 0] >= 0) & (P[:, 0] <= W - 1) & (P[:, 1] >= 0) & (P[:, 1] <= H - 1)
    order = np.argsort(own, kind="stable")
    own_s, V_s, on_s = own[order], V[order], on[order]
    cuts = np.flatnonzero(np.diff(own_s)) + 1
    for grp, vv, oo in zip(np.split(own_s, cuts), np.split(V_s, cuts), np.split(on_s, cuts)):
        if oo.any():
            out[grp[0] // 2, grp[0] % 2] = np.median(vv[oo], axis=0)
    return out


def side_distance(a, b) -> np.ndarray:
    """How different two lines look: ``a``, ``b`` the colours either side of each, ``(..., 2, C)``
    (:func:`line_sides`); the mean over the two sides of the colour distance (Euclidean, in the
    channels' units), in the order of the sides that agrees better (a plane normal's sign, which
    orders the sides, is arbitrary in each view). NaN where a side is unknown."""
    a = np.asarray(a, float)
    b = np.asarray(b, float)
    if a.shape[-2:] != b.shape[-2:] or a.shape[-2] != 2:
        raise CatadioptricError(f"a, b: expected sides of shape (..., 2, C) alike, got {a.shape} and {b.shape}")
    same = np.linalg.norm(a - b, axis=-1).mean(axis=-1)
    swapped = np.linalg.norm(a - b[..., ::-1, :], axis=-1).mean(axis=-1)
    return np.minimum(same, swapped)
