"""Images of 3-D lines (exact curves) and Pluecker coordinates.

A line ``q + lambda s`` is swept by the angle ``phi`` in ``lambda = l tan(phi)``, ``l`` the
mirror's scale (so that the sweep does not depend on the length unit): the homogeneous
point ``(q cos(phi) + l s sin(phi), cos(phi))`` runs along the whole line and
reaches the points at infinity of ``-s`` and ``+s`` at ``phi = -pi/2`` and ``+pi/2``, so
a line's image is traced in one piece of parameter, its two vanishing points included
as the limits. Segments use the sub-range of their end points.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from ._checks import CatadioptricError, as_count, as_float_array
from ._numeric import norm, unit
from .curves import Piece, sweep_options, trace
from .projection import solve_targets

if TYPE_CHECKING:  # annotations only: cameras.py sits above this module and calls it
    from .cameras import CatadioptricCamera

__all__ = ["LineImage", "line_image", "segment_image", "pluecker", "pluecker_point_direction"]


def pluecker(points, directions) -> np.ndarray:
    """Pluecker coordinates ``(s, m)`` ``(..., 6)`` of lines through ``points`` along unit ``directions``
    (``m = q x s``)."""
    q = as_float_array(points, "points", 3)
    s = as_float_array(directions, "directions", 3)
    s = s / np.linalg.norm(s, axis=-1, keepdims=True)
    return np.concatenate([s, np.cross(q, s)], axis=-1)


def pluecker_point_direction(L) -> tuple[np.ndarray, np.ndarray]:
    """The point of each line closest to the origin and its unit direction, from ``(..., 6)``."""
    L = as_float_array(L, "L", 6)
    s, m = L[..., :3], L[..., 3:]
    n = np.linalg.norm(s, axis=-1, keepdims=True)
    s, m = s / n, m / n
    return np.cross(s, m), s


@dataclass
class LineImage:
    """The image of one 3-D line or segment: its connected ``pieces`` (each a
    :class:`~catadioptric.curves.Piece`: ``uv (M, 2)`` with consecutive vertices at most the
    requested step apart on the image, ``mirror_points (M, 3)``, ``params`` = the line parameter lambda of
    each vertex, +-inf at the vanishing points), and the line's vanishing points:
    ``vanishing_uv (2, K, 2)`` / ``vanishing_valid (2, K)`` for ``+s`` (row 0) and ``-s`` (row 1)."""

    pieces: list[Piece]
    vanishing_uv: np.ndarray = field(default_factory=lambda: np.zeros((2, 0, 2)))
    vanishing_valid: np.ndarray = field(default_factory=lambda: np.zeros((2, 0), dtype=bool))

    @property
    def uv(self) -> np.ndarray:
        """All vertices of all pieces, ``(M, 2)`` (pieces concatenated)."""
        return np.concatenate([p.uv for p in self.pieces]) if self.pieces else np.zeros((0, 2))


def _evaluator(cam, q, s):
    K = cam.solver.max_solutions
    ell = cam.mirror.scale

    def evaluate(ids, phi):
        cphi, sphi = np.cos(phi), np.sin(phi)
        # lambda = l tan(phi); at |phi| = pi/2 the target is the direction +-s
        inf = np.abs(cphi) < 1e-15
        fin = ~inf
        uv = np.full((len(ids), K, 2), np.nan)
        r = np.full((len(ids), K, 3), np.nan)
        valid = np.zeros((len(ids), K), dtype=bool)
        for mask, w in ((fin, 1.0), (inf, 0.0)):
            if not np.any(mask):
                continue
            i = ids[mask]
            if w:
                with np.errstate(over="ignore", invalid="ignore"):  # beyond the float range: no image
                    tg = q[i] + (ell * sphi[mask] / cphi[mask])[:, None] * s[i]
            else:
                tg = np.sign(sphi[mask])[:, None] * s[i]
            fs = solve_targets(cam, tg, w)
            ok = fs.forward & fs.visible
            order, slot = _slots(fs.owner[ok])
            rows = np.nonzero(mask)[0][fs.owner[ok][order]]
            keep = slot < K
            uv[rows[keep], slot[keep]] = fs.uv[ok][order][keep]
            r[rows[keep], slot[keep]] = fs.points[ok][order][keep]
            valid[rows[keep], slot[keep]] = True
        return uv, r, valid

    return evaluate


def _slots(owner):
    order = np.argsort(owner, kind="stable")
    o = owner[order]
    starts = np.r_[0, np.nonzero(np.diff(o))[0] + 1] if len(o) else np.zeros(0, dtype=np.intp)
    slot = np.arange(len(o)) - np.repeat(starts, np.diff(np.r_[starts, len(o)]))
    return order, slot


def _line_seeds(cam, q, s, step, max_per_line=256):
    """Angles phi = arctan(lambda / l) of the line points that grid pixels see: the reflected ray of
    a grid pixel passing the line within the grid's angular resolution, in front of the mirror
    (at most ``max_per_line`` per line, evenly spread over the sorted lambdas)."""
    from .curves import pixel_grid_rays

    o, d, ang = pixel_grid_rays(cam, step)
    if len(o) == 0:  # no grid pixel sees the world
        return None
    i, k = _seed_pairs(o, d, ang, q, s)
    o, d, ang, q, s = o[k], d[k], ang[k], q[i], s[i]
    # closest approach of the ray o + t d and the line q + lam s (d, s unit)
    w0 = o - q
    b = np.einsum("nk,nk->n", d, s)
    sw = np.einsum("nk,nk->n", w0, s)
    e = np.sum(d * w0, axis=1)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        t = (b * sw - e) / (1.0 - b * b)
        lam = sw + t * b
        gap = norm(o + t[:, None] * d - (q + lam[:, None] * s))
        hit = (t > 0) & (gap <= 1.5 * ang * t)
    ids, lam = i[hit], lam[hit]
    if len(ids) == 0:
        return None
    order = np.lexsort((lam, ids))
    ids, lam = ids[order], lam[order]
    count = np.bincount(ids)
    first = np.cumsum(count) - count
    keep = np.ones(len(ids), bool)
    for line in np.flatnonzero(count > max_per_line):
        keep[first[line]:first[line] + count[line]] = False
        keep[first[line] + np.linspace(0, count[line] - 1, max_per_line).astype(int)] = True
    return ids[keep], np.arctan(lam[keep] / cam.mirror.scale)


def _seed_pairs(o, d, ang, q, s, block=128):
    """The (line, ray) pairs of :func:`_line_seeds` worth testing, a superset of those that pass.

    With ``c`` the mean ray origin, ``rho`` the largest distance of an origin from it and ``D``
    the line's distance from ``c``: a ray that passes within ``1.5 ang t`` of the line does so at
    ``t >= (D - rho) / (1 + 1.5 ang)``, so its direction is within ``1.5 ang + rho (1 + 1.5 ang) /
    (D - rho)`` (a sine) of the plane through ``c`` and the line. Lines nearer than ``2 rho`` keep
    every ray. The bound has a relative slack of 1e-6, far above rounding."""
    c = o.mean(axis=0)
    rho = float(np.max(norm(o - c), initial=0.0))
    n = np.cross(q - c, s)
    D = norm(n)
    far = D > 2.0 * rho
    with np.errstate(divide="ignore", invalid="ignore"):
        nh = np.where(far[:, None], n / np.where(far, D, 1.0)[:, None], 0.0)
        slack = np.where(far, rho / np.where(far, D - rho, 1.0), np.inf) * (1.0 + 1.5 * float(ang.max(initial=0.0)))
    bound_ray = 1.5 * ang * (1 + 1e-6) + 1e-12
    lines, rays = [], []
    for a in range(0, len(q), block):
        dn = np.abs(nh[a:a + block] @ d.T) - bound_ray  # (lines, rays)
        i, k = np.nonzero(dn <= slack[a:a + block, None] * (1 + 1e-6))
        lines.append(i + a)
        rays.append(k)
    return np.concatenate(lines), np.concatenate(rays)


def line_image(cam: CatadioptricCamera, points, directions, *, lam_range=None, max_step_px: float = 1.0,
               n_start: int = 64, seed_step: int = 4) -> list[LineImage]:
    """Exact images of the lines ``points[i] + lambda directions[i]`` (both ``(N, 3)`` in M).

    ``lam_range (N, 2)``: the segment ``lambda in [lo, hi]`` of each line (default: the
    whole line, ``-inf .. inf``, whose image ends at its vanishing points). Each image is
    every observable part of the line (in the patch, unobstructed, in front of the
    camera), as pieces whose consecutive vertices are at most ``max_step_px`` apart on the
    image and within one image size around it (beyond, the step grows by half the distance).
    Besides uniform samples of the angle ``phi = arctan(lambda / l)`` (``l`` the mirror's
    scale), the sweep starts from the line points seen by every ``seed_step``-th pixel (so
    that parts visible over a tiny range of lambda, e.g. near a caustic, are found).
    """
    q = as_float_array(points, "points", 3).reshape(-1, 3)
    s = as_float_array(directions, "directions", 3).reshape(-1, 3)
    if q.shape != s.shape:
        raise CatadioptricError(f"points, directions: expected the same number of lines, got {len(q)} and {len(s)}")
    sweep_options(max_step_px, n_start, 60)
    seed_step = as_count(seed_step, "seed_step", maximum=1_000_000)
    zero = ~np.any(s != 0, axis=1)
    if np.any(zero):
        raise CatadioptricError(f"directions: expected non-zero vectors, got a zero vector at index {int(np.argmax(zero))}")
    s = unit(s)
    N = len(q)
    ell = cam.mirror.scale
    if lam_range is None:
        lo, hi = np.full(N, -np.pi / 2), np.full(N, np.pi / 2)
    else:
        lr = as_float_array(lam_range, "lam_range", 2, finite=False).reshape(-1, 2)
        if len(lr) != N or np.any(np.isnan(lr)) or np.any(lr[:, 0] >= lr[:, 1]):
            raise CatadioptricError(f"lam_range: expected ({N}, 2) increasing pairs, got {lr.tolist()[:3]}...")
        lo, hi = np.arctan(lr[:, 0] / ell), np.arctan(lr[:, 1] / ell)
    if N == 0:
        return []
    pieces = trace(_evaluator(cam, q, s), lo, hi, max_step_px=max_step_px, n_start=n_start,
                   seeds=_line_seeds(cam, q, s, seed_step), image=(cam.pinhole.width, cam.pinhole.height))
    vp = cam.vanishing_points(np.concatenate([s, -s]))
    out = []
    for i in range(N):
        for p in pieces[i]:
            t = np.tan(p.params)
            p.params = ell * t
            p.params[np.abs(t) > 1e15] = np.copysign(np.inf, t[np.abs(t) > 1e15])
        out.append(LineImage(pieces[i], np.stack([vp.uv[i], vp.uv[N + i]]), np.stack([vp.valid[i], vp.valid[N + i]])))
    return out


def segment_image(cam: CatadioptricCamera, p0, p1, **kwargs) -> list[LineImage]:
    """Exact images of the segments ``p0[i] .. p1[i]`` (``(N, 3)`` each, in M)."""
    a = as_float_array(p0, "p0", 3).reshape(-1, 3)
    b = as_float_array(p1, "p1", 3).reshape(-1, 3)
    if a.shape != b.shape:
        raise CatadioptricError(f"p0, p1: expected the same number of end points, got {len(a)} and {len(b)}")
    with np.errstate(over="ignore"):
        d = b - a
    same = ~np.any(d != 0, axis=1)
    if np.any(same):
        raise CatadioptricError(f"p0, p1: expected distinct end points, got equal ones at index {int(np.argmax(same))}")
    if not np.all(np.isfinite(d)):
        raise CatadioptricError(f"p0, p1: expected end points less than the float range apart, got a segment "
                                f"longer than that at index {int(np.argmax(~np.all(np.isfinite(d), axis=1)))}")
    L = norm(d)
    return line_image(cam, a, unit(d), lam_range=np.stack([np.zeros_like(L), L], axis=1), **kwargs)
