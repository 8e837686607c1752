"""Synthetic pixels of 3-D segments (tests, benchmarks, the accuracy tables)."""
from __future__ import annotations

import numpy as np

from .._checks import CatadioptricError, as_float_array, as_scalar
from ..cameras import CatadioptricCamera
from ._common import as_rng


# --------------------------------------------------------------------------- synthetic data
def segment_pixels(cam: CatadioptricCamera, a, b, n: int, *, sigma: float = 0.0, rng=None):
    """Pixels of ``n`` points spread evenly along the 3-D segment ``a``-``b`` (mirror frame).

    Keeps the points with a valid image on the image rectangle; where a point has several,
    the one nearest the previous kept pixel (so that the pixels follow one branch of the
    curve). Adds Gaussian noise of ``sigma`` pixels (``rng``: a Generator or seed).
    Returns ``(uv (n', 2), points (n', 3))``."""
    a = as_float_array(a, "a", 3)
    b = as_float_array(b, "b", 3)
    if a.shape != (3,) or b.shape != (3,):
        raise CatadioptricError(f"a, b: expected 3-vectors, got shapes {a.shape} and {b.shape}")
    if not (isinstance(n, (int, np.integer)) and n >= 1):
        raise CatadioptricError(f"n: expected a positive integer, got {n!r}")
    sigma = as_scalar(sigma, "sigma")
    if sigma < 0:
        raise CatadioptricError(f"sigma: expected a non-negative number, got {sigma!r}")
    t = np.linspace(0.0, 1.0, int(n))
    P = a + t[:, None] * (b - a)
    pr = cam.project(P)
    good = pr.valid & pr.in_image
    uv, pts, prev = [], [], None
    for i in range(len(P)):
        k = np.nonzero(good[i])[0]
        if len(k) == 0:
            continue
        cand = pr.uv[i, k]
        j = 0 if prev is None else int(np.argmin(np.sum((cand - prev) ** 2, axis=-1)))
        prev = cand[j]
        uv.append(cand[j])
        pts.append(P[i])
    uv = np.array(uv).reshape(-1, 2)
    pts = np.array(pts).reshape(-1, 3)
    if sigma > 0 and len(uv):
        uv = uv + as_rng(rng).normal(0.0, sigma, uv.shape)
    return uv, pts


def family_pixels(cam: CatadioptricCamera, vp_pixel, line_pixels, depths, *, n: int = 50, phi=(-0.6, 1.45)):
    """Synthetic parallel lines: the direction ``s`` is the one whose ``+s`` vanishing point is
    ``vp_pixel``; line i passes through the point at ``depths[i]`` on the ray of ``line_pixels[i]``.
    Points ``q_i + tan(phi) s`` for ``n`` angles evenly spread over ``phi`` (so the curves run
    into the vanishing point), kept where they have exactly one valid image on the image;
    lines with fewer than 15 pixels are dropped. Returns ``(s, [uv_i], [q_i])``."""
    s = cam.backproject(np.asarray(vp_pixel, dtype=float)).directions
    rays = cam.backproject(np.asarray(line_pixels, dtype=float))
    t = np.tan(np.linspace(phi[0], phi[1], int(n)))
    sets, points = [], []
    for o, d, depth in zip(rays.origins, rays.directions, depths):
        q = o + depth * d
        pr = cam.project(q + t[:, None] * s)
        ok = pr.valid[:, 0] & pr.in_image[:, 0] & (pr.valid.sum(axis=1) == 1)
        if ok.sum() >= 15:
            sets.append(pr.uv[ok, 0])
            points.append(q)
    return s, sets, points
