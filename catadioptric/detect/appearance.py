"""The colours either side of each detected line (:func:`side_colours`), for the matching of lines
across views (:mod:`catadioptric.appearance`).

At every pixel of a line, the direction in the image in which ``n . d`` grows (``n`` the line's
plane normal, ``d`` the pixel's ray: ``n^T dd/duv``) points to the side ``n . d > 0``; the image is
sampled (bilinear) at ``offset`` pixels that way and the opposite way, and each side's colour is
the median over the line's pixels (robust to what crosses it: a window frame, a pole). The offset
clears the edge's blur and a band's half width: ``max(MIN_OFFSET_PX, width / 2 + 2)`` pixels.
"""
from __future__ import annotations

import numpy as np

from ..appearance import LineAppearance
from .edges import bilinear

__all__ = ["side_colours", "MIN_OFFSET_PX"]

#: the nearest a side is sampled from a line's curve (pixels): beyond the blur of a step edge
#: (the gradients' Gaussian of 1 pixel, a render's or a lens's own blur of about as much)
MIN_OFFSET_PX = 3.0


def side_colours(chan: np.ndarray, rays_per_line: list, normals: np.ndarray, widths, noise: float
                 ) -> LineAppearance:
    """The :class:`~catadioptric.appearance.LineAppearance` of lines whose pixels' rays are
    ``rays_per_line[i]`` (:class:`~catadioptric.linefit.planes.Rays`, with their derivatives), with
    plane normals ``normals (N, 3)`` and band widths ``widths (N,)`` (pixels, 0 for a step edge), in
    the image ``chan (H, W, C)`` (levels of an 8-bit scale); ``noise``: its noise (grey levels)."""
    normals = np.asarray(normals, float).reshape(-1, 3)
    C = chan.shape[2]
    N = len(normals)
    sides = np.full((N, 2, C), np.nan)
    offsets = np.maximum(MIN_OFFSET_PX, 0.5 * np.asarray(widths, float).reshape(-1) + 2.0) if N else np.zeros(0)
    for i, rays in enumerate(rays_per_line):
        ok = rays.ok
        if not np.any(ok):
            continue
        g = np.einsum("k,mkj->mj", normals[i], rays.Jd[ok])  # d(n . d)/duv
        gn = np.linalg.norm(g, axis=1)
        good = gn > 0
        if not np.any(good):
            continue
        step = g[good] / gn[good, None] * offsets[i]
        uv = rays.uv[ok][good]
        for s, sign in enumerate((1.0, -1.0)):
            at = uv + sign * step
            sides[i, s] = [np.median(bilinear(chan[..., c], at)) for c in range(C)]
    return LineAppearance(normal=normals.copy(), sides=sides, offset_px=offsets, noise=float(noise))
