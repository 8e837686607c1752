"""Vanishing points from directions, directions from vanishing points, vanishing curves.

The vanishing point of a direction ``s`` is the image of the point at infinity
of the lines ``q + lambda s`` as ``lambda -> +inf``: a reflection point whose
reflected ray points along ``+s``. The same polynomial system holds the points of
``-s`` (reflected ray along ``-s``): together they are the pair a family of
parallel lines converges to. Solved by the reflection solvers with the target
at infinity (``w = 0``); see docs/solvers.md.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ._checks import CatadioptricError, as_float_array
from ._numeric import rowdot, unit
from .projection import solve_targets

if TYPE_CHECKING:  # annotations only: cameras.py sits above this module and calls it
    from .cameras import CatadioptricCamera

__all__ = ["VanishingPoints", "VanishingCurve", "vanishing_points", "directions_from_vanishing_points",
           "vanishing_curve", "paper_directions_from_mirror_points"]


@dataclass
class VanishingPoints:
    """Vanishing points of each direction, NaN-padded along a fixed axis K.

    ``uv (..., K, 2)``, ``mirror_points (..., K, 3)``; ``sign (..., K)`` is +1 for a
    point of ``+s`` (reflected ray along ``+s``), -1 for a point of ``-s``, 0 for an
    empty slot; ``visible (..., K)``: in the patch, reached by the camera ray without
    the patch in the way, the reflected ray leaves without meeting the patch again,
    in front of the camera; ``valid = visible & (sign > 0)``: the vanishing points of
    ``s`` a user can observe. ``in_image`` also requires the pixel on the image.
    Entries are ordered: valid first, then the other ``+s`` points, then ``-s``.
    """

    uv: np.ndarray
    mirror_points: np.ndarray
    valid: np.ndarray
    sign: np.ndarray
    visible: np.ndarray
    in_image: np.ndarray

    def opposite(self) -> "VanishingPoints":
        """The points of ``-s`` as a result of their own (``valid`` = observable ``-s`` points)."""
        return _select(self, self.sign < 0, -1)


def _select(vp: VanishingPoints, mask, sign_value) -> VanishingPoints:
    """The entries of ``mask`` only (visible ones first), the others emptied."""
    order = np.argsort(~(mask & vp.visible) + 2 * ~mask, axis=-1, kind="stable")

    def take(a):
        if a.ndim == order.ndim:  # per-entry flags
            return np.take_along_axis(a, order, axis=-1)
        return np.take_along_axis(a, order[..., None], axis=-2)  # per-entry coordinates

    m = take(mask)
    uv = np.where(m[..., None], take(vp.uv), np.nan)
    r = np.where(m[..., None], take(vp.mirror_points), np.nan)
    vis = take(vp.visible) & m
    return VanishingPoints(uv, r, vis, np.where(m, sign_value, 0), vis, take(vp.in_image) & m)


def vanishing_points(cam: CatadioptricCamera, directions, *, which: str = "+s") -> VanishingPoints:
    """Vanishing points of ``directions (..., 3)`` (any non-zero length) in the mirror frame.

    ``which="+s"`` (default) returns the points of ``+s`` only (observable ones have
    ``valid``; the others are reflection points in the patch that the camera cannot
    see); ``which="both"`` also returns the points of ``-s`` (``sign == -1``).
    """
    if which not in ("+s", "both"):
        raise CatadioptricError(f"which: expected '+s' or 'both', got {which!r}")
    s = as_float_array(directions, "directions", 3)
    shape = s.shape[:-1]
    flat = s.reshape(-1, 3)
    zero = ~np.any(flat != 0, axis=-1)
    if np.any(zero):
        i = int(np.argmax(zero))
        raise CatadioptricError(f"directions: expected non-zero vectors, got a zero vector at flat index {i}")
    # any length: the solvers scale each direction to a unit homogeneous 4-vector themselves
    fs = solve_targets(cam, flat, 0.0, backward=(which == "both"))
    N, K = len(flat), cam.solver.max_solutions
    sign_flat = np.where(fs.forward, 1, -1).astype(np.int8)
    valid_flat = fs.visible & fs.forward
    key = np.where(valid_flat, 0, np.where(fs.forward, 1, 2)).astype(np.int8)
    o, sl, sel, r, uv = fs.scatter(N, K, np.ones(len(fs.owner), dtype=bool), key)
    sign = np.zeros((N, K), dtype=np.int8)
    vis = np.zeros((N, K), dtype=bool)
    inimg = np.zeros((N, K), dtype=bool)
    at = o * K + sl  # flat slot
    sign.reshape(-1)[at] = sign_flat[sel]
    vis.reshape(-1)[at] = fs.visible[sel]
    inimg.reshape(-1)[at] = fs.visible[sel] & cam.pinhole.in_image(fs.uv[sel])
    valid = vis & (sign > 0)
    rs = lambda a, tail=(): a.reshape(shape + (K,) + tail)
    return VanishingPoints(rs(uv, (2,)), rs(r, (3,)), rs(valid), rs(sign), rs(vis), rs(inimg))


def directions_from_vanishing_points(cam: CatadioptricCamera, uv) -> np.ndarray:
    """Unit, oriented directions ``(..., 3)`` in M whose vanishing point is at pixel ``uv (..., 2)``.

    The exact and unique answer is the reflected ray of the back-projected pixel: the
    direction ``s`` such that lines along ``+s`` converge to ``uv``. NaN where the pixel
    does not see the world through the mirror.
    """
    rays = cam.backproject(uv)
    return np.where(rays.valid[..., None], rays.directions, np.nan)


def paper_directions_from_mirror_points(cam: CatadioptricCamera, mirror_points) -> np.ndarray:
    """The paper's Sec. 2.3 system (for comparison only): directions ``(..., 2, 3)``.

    From a vanishing point's mirror point ``r`` the paper solves ``a1 s2 + a2 s3 = 0``,
    ``b1 s1^2 + b2 s2^2 + b3 s2 s3 + b4 s3^2 = 0`` and ``|s| = 1``. The system is even in
    ``s1`` and in ``(s2, s3)`` jointly, so it returns the two directions
    ``(+-s1, s2, s3)`` (up to a common sign), only one of which has ``r`` as a
    vanishing point, and no orientation. Use :func:`directions_from_vanishing_points`.
    """
    r = as_float_array(mirror_points, "mirror_points", 3)
    m = cam.mirror
    # frame with the camera at (0, c2, c3)
    c = cam.center
    rho = np.hypot(c[0], c[1])
    cs, sn = (c[1] / rho, c[0] / rho) if rho > 0 else (1.0, 0.0)
    R = np.array([[cs, -sn, 0], [sn, cs, 0], [0, 0, 1.0]])
    rr = r @ R.T
    c2, c3 = rho, c[2]
    x, y, z = rr[..., 0], rr[..., 1], rr[..., 2]
    A, B = m.A, m.B
    n = np.stack([x, y, A * z + B / 2], -1)
    dt = rr - np.array([0, c2, c3])
    d = np.sum(n * n, -1)[..., None] * dt - 2 * n * np.sum(n * dt, -1)[..., None]
    # kappa_9 = s3 d2 - s2 d3 = 0  ->  a1 s2 + a2 s3 = 0 with a1 = -d3, a2 = d2
    a1, a2 = -d[..., 2], d[..., 1]
    # coplanarity squared: (E x)^2 = F^2 with E = s2 e + s3 f, F = -s1 g
    e = 2 * (1 - A) * (-1.0) * z + B + 2 * c3  # E = s2 (B + 2 c3 - 2 (1 - A) z) - 2 c2 s3
    f = -2 * c2 * np.ones_like(z)
    g = y * (2 * (A - 1) * z + B + 2 * c3) - c2 * (2 * A * z + B)
    # b1 s1^2 + b2 s2^2 + b3 s2 s3 + b4 s3^2 = 0 with b1 = -g^2, b2 = e^2 x^2, b3 = 2 e f x^2, b4 = f^2 x^2
    b1, b2, b3, b4 = -g * g, e * e * x * x, 2 * e * f * x * x, f * f * x * x
    with np.errstate(divide="ignore", invalid="ignore"):
        k = -a1 / a2  # s3 = k s2
        s2sq = -b1 / (b2 + b3 * k + b4 * k * k - b1 - b1 * k * k)
        s2 = np.sqrt(s2sq)
        s3 = k * s2
        s1 = np.sqrt(np.maximum(1 - s2 * s2 - s3 * s3, 0.0))
    out = np.stack([np.stack([s1, s2, s3], -1), np.stack([-s1, s2, s3], -1)], axis=-2)
    return out @ R  # back to M (row vectors: R^T s)


@dataclass
class VanishingCurve:
    """One connected piece of a vanishing curve: ``uv (M, 2)``, ``mirror_points (M, 3)``,
    ``directions (M, 3)`` (the unit direction each vertex is the vanishing point of), and
    ``closed`` when the piece is a loop (its last vertex connects to the first)."""

    uv: np.ndarray
    mirror_points: np.ndarray
    directions: np.ndarray
    closed: bool


def vanishing_curve(cam: CatadioptricCamera, normal, *, max_step_px: float = 1.0, n_start: int = 720,
                    max_rounds: int = 60) -> list[VanishingCurve]:
    """The vanishing curve of the plane with ``normal`` (in M): the observable vanishing
    points of every direction perpendicular to it, as polylines whose consecutive
    vertices are at most ``max_step_px`` apart on the image (``cam``: an exact rig, or a camera
    model of :mod:`catadioptric.models`, whose :meth:`vanishing_curve` calls this) and within one image size around
    it (beyond, where a curve can run toward infinity, the step grows by half the distance).

    Directions are swept by angle, ``s(theta) = cos(theta) e1 + sin(theta) e2`` with
    ``(e1, e2)`` an orthonormal basis of the plane (an angle, not the paper's
    ``alpha s1 + (1 - alpha) s2``, which misses ``s1 - s2``); every vertex is an exact
    vanishing point (:func:`catadioptric.curves.trace` refines the sweep where neighbours
    are too far apart and where the curve leaves the observable region, down to 1e-9 rad).
    """
    from .curves import image_size, sweep_options, trace

    m = as_float_array(normal, "normal", 3)
    if m.shape != (3,) or not np.any(m != 0):
        raise CatadioptricError(f"normal: expected a non-zero 3-vector, got {m.tolist()}")
    sweep_options(max_step_px, n_start, max_rounds)
    m = unit(m)
    a = np.array([1.0, 0, 0]) if abs(m[0]) < 0.9 else np.array([0, 1.0, 0])
    e1 = np.cross(m, a)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(m, e1)
    dirs = lambda th: np.cos(th)[:, None] * e1 + np.sin(th)[:, None] * e2

    def evaluate(_ids, th):
        vp = cam.vanishing_points(dirs(th))  # an exact rig's solvers, or a camera model's formula
        return vp.uv, vp.mirror_points, vp.valid

    # seeds: directions of the plane seen by every 4th pixel (pieces visible over tiny angles)
    from .curves import pixel_grid_rays

    _, d, ang = pixel_grid_rays(cam, 4)
    near = np.abs(rowdot(d, m)) <= 1.5 * ang
    th = np.mod(np.arctan2(rowdot(d[near], e2), rowdot(d[near], e1)), 2 * np.pi)
    if len(th) > 512:
        th = np.sort(th)[np.linspace(0, len(th) - 1, 512).astype(int)]
    pieces = trace(evaluate, [0.0], [2 * np.pi], periodic=True, max_step_px=max_step_px, n_start=n_start,
                   max_rounds=max_rounds, seeds=(np.zeros(len(th), dtype=np.intp), th),
                   image=image_size(cam))[0]
    return [VanishingCurve(p.uv, p.mirror_points, dirs(p.params), p.closed) for p in pieces]
