"""Translations from lines with the rotation known (the paper's Pluecker constraint, Sec. 4.3).

A ray with Pluecker coordinates ``(v, o x v)`` meets a line ``(s, m)`` when their reciprocal
product vanishes: ``s . (o x v) + v . m = 0``. A line known in one frame and moved by
``x' = R x + t`` has ``(R s, R m + t x R s)``, which is linear in ``t``.
"""
from __future__ import annotations

import numpy as np

from .._checks import CatadioptricError, as_float_array, as_rotation
from .._numeric import cross

__all__ = ["translation_from_lines", "relative_translation_from_lines", "triangulate_line", "triangulate_lines", "ray_depths"]


def translation_from_lines(R, world_lines, ray_lines, line_index) -> np.ndarray:
    """Translation ``t`` of ``x_M = R x_W + t`` from pixels of known world lines (absolute pose, the
    paper's Sec. 5.3).

    ``world_lines (L, 6)``: Pluecker ``(s, m)`` of lines in W; ``ray_lines (M, 6)``: Pluecker
    coordinates in M of the reflected rays of pixels that image them (``ray_lines[j]`` images
    ``world_lines[line_index[j]]``). Each ray meets its line:
    ``t . (R s x s_j) = -(s_j . R m + m_j . R s)``; least squares over all rays.
    At least three rays over two non-parallel lines are needed.
    """
    R = as_rotation(R, "R")
    W = as_float_array(world_lines, "world_lines", 6).reshape(-1, 6)
    P = as_float_array(ray_lines, "ray_lines", 6).reshape(-1, 6)
    idx = np.asarray(line_index, dtype=int).reshape(-1)
    if len(idx) != len(P):
        raise CatadioptricError(f"line_index: expected {len(P)} entries (one per ray), got {len(idx)}")
    if len(P) < 3:
        raise CatadioptricError(f"ray_lines: expected at least 3 rays, got {len(P)}")
    if np.any((idx < 0) | (idx >= len(W))):
        raise CatadioptricError(f"line_index: expected indices into {len(W)} world lines, got "
                                f"{int(idx[(idx < 0) | (idx >= len(W))][0])}")
    Rs = W[idx, :3] @ R.T
    Rm = W[idx, 3:] @ R.T
    sj, mj = P[:, :3], P[:, 3:]
    A = np.cross(Rs, sj)
    b = -(np.sum(sj * Rm, axis=1) + np.sum(mj * Rs, axis=1))
    t, *_ = np.linalg.lstsq(A, b, rcond=None)
    return t


def _rows_a_to_b(R, lines_a, rays_b, owner_b):
    """Equations ``t . c = d`` (one per ray of view B) from lines known in frame A."""
    s = lines_a[owner_b, :3] @ R.T
    m = lines_a[owner_b, 3:] @ R.T
    v, mv = rays_b[:, :3], rays_b[:, 3:]
    c = np.cross(s, v)
    d = -(np.sum(s * mv, axis=1) + np.sum(v * m, axis=1))
    return c, d


def _rows_b_to_a(R, lines_b, rays_a, owner_a):
    """Equations ``t . c = d`` (one per ray of view A) from lines known in frame B."""
    s = lines_b[owner_a, :3]
    m = lines_b[owner_a, 3:]
    v, mv = rays_a[:, :3], rays_a[:, 3:]
    Rv = v @ R.T
    c = np.cross(s, Rv)
    d = np.sum((s @ R) * mv, axis=1) + np.sum(Rv * m, axis=1)
    return c, d


def relative_translation_from_lines(R, lines_a, lines_b, rays_a, owner_a, rays_b, owner_b, *,
                                    robust: bool = True, iters: int = 10):
    """Translation ``t`` of ``x_B = R x_A + t`` from lines matched across two views, both ways.

    ``lines_a, lines_b (L, 6)``: Pluecker ``(s, m)`` of the same L lines fitted in each view's
    frame (NaN rows for a line not fitted in that view); ``rays_a (Ma, 6)`` with ``owner_a (Ma,)``:
    the reflected rays of view A's pixels and the line each images (likewise for B). Each line
    of A moved into B meets the rays of its pixels in B, and each line of B moved back meets
    those in A: one equation linear in ``t`` per ray, scaled to a distance (metres) by the sine
    of the angle between ray and line. Least squares, iteratively reweighted (Huber) when
    ``robust``. Returns ``(t, residuals (Ma + Mb,))`` in metres.
    """
    R = as_rotation(R, "R")
    La = as_float_array(lines_a, "lines_a", 6, finite=False).reshape(-1, 6)
    Lb = as_float_array(lines_b, "lines_b", 6, finite=False).reshape(-1, 6)
    if La.shape != Lb.shape:
        raise CatadioptricError(f"lines_a, lines_b: expected the same lines, got {len(La)} and {len(Lb)}")
    Pa = as_float_array(rays_a, "rays_a", 6).reshape(-1, 6)
    Pb = as_float_array(rays_b, "rays_b", 6).reshape(-1, 6)
    oa = np.asarray(owner_a, dtype=int).reshape(-1)
    ob = np.asarray(owner_b, dtype=int).reshape(-1)
    if len(oa) != len(Pa) or len(ob) != len(Pb):
        raise CatadioptricError(f"owner_a, owner_b: expected one line index per ray ({len(Pa)}, {len(Pb)}), "
                                f"got {len(oa)}, {len(ob)}")
    c1, d1 = _rows_a_to_b(R, La, Pb, ob)
    c2, d2 = _rows_b_to_a(R, Lb, Pa, oa)
    c = np.concatenate([c1, c2])
    d = np.concatenate([d1, d2])
    ok = np.all(np.isfinite(c), axis=1) & np.isfinite(d)
    sine = np.linalg.norm(c, axis=1)
    ok &= sine > 1e-6
    if ok.sum() < 3:
        raise CatadioptricError(f"lines_a, lines_b: expected at least 3 rays meeting lines fitted in the other "
                                f"view, got {int(ok.sum())}")
    c = c[ok] / sine[ok, None]
    d = d[ok] / sine[ok]
    w = np.ones(len(d))
    t = np.zeros(3)
    for _ in range(iters if robust else 1):
        sw = np.sqrt(w)
        t, *_ = np.linalg.lstsq(c * sw[:, None], d * sw, rcond=None)
        r = c @ t - d
        scale = 1.4826 * np.median(np.abs(r)) + 1e-12
        k = 1.345 * scale
        w = np.where(np.abs(r) <= k, 1.0, k / np.maximum(np.abs(r), 1e-300))
    res = np.full(len(ok), np.nan)
    res[ok] = c @ t - d
    return t, res


def ray_depths(q, s, o, d) -> np.ndarray:
    """How far along each ray ``o + lambda d`` (``d`` made unit) its point nearest the line through
    ``q`` along unit ``s`` lies, ``(M,)``: negative where the ray meets the line behind its origin
    (the line is behind that view); 0 for a ray parallel to the line. ``q, s``: one line ``(3,)``,
    or each ray's own ``(M, 3)``."""
    d = np.asarray(d, float)
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    s = np.asarray(s, float)
    w = np.asarray(o, float) - q
    b = np.sum(d * s, axis=1)
    den = 1.0 - b * b
    with np.errstate(invalid="ignore", divide="ignore"):
        lam = (b * np.sum(w * s, axis=1) - np.sum(d * w, axis=1)) / den
    return np.where(den > 1e-12, lam, 0.0)


def triangulate_line(s, o, d, prior=None, iters: int = 1):
    """The point (normal to ``s``) of the line along unit ``s`` that best meets rays ``o, d``, and
    whether the rays fix it (``(q, well_posed)``). A line parallel to the baseline lies in one
    plane with both centres: two near-central views then see only that plane, and the point
    along it comes from ``prior`` (a point, taken where the rays leave it free).

    Each ray's miss is weighed as the angle it subtends from the ray's origin (the metric miss over
    the ray's depth to the line, :func:`ray_depths`, the depths of the unweighted solve; ``iters``
    reweighted solves), because pixels measure angles: weighed in metres, the rays of a view far
    from the line (a start whose baseline is tens of metres, to a line a metre from the other view)
    count the near view's misses at a fraction of their weight, and where the two views' planes
    nearly coincide (a line nearly parallel to the baseline) the line follows the far view. More
    than one reweighting can run away: the miss in angle of a line through a view's centre is
    undefined, and a line whose distance the rays barely fix moves towards it. Many lines at once:
    :func:`triangulate_lines`."""
    o = np.asarray(o, float).reshape(-1, 3)
    q, well = triangulate_lines(np.asarray(s, float)[None], o, d, np.zeros(len(o), dtype=int),
                                prior=None if prior is None else np.asarray(prior, float)[None], iters=iters)
    return q[0], bool(well[0])


def triangulate_lines(s, o, d, line, prior=None, iters: int = 1):
    """:func:`triangulate_line` of many lines at once: unit directions ``s (G, 3)``, rays ``o, d
    (M, 3)`` of line ``line (M,)`` (indices into ``s``), ``prior (G, 3)`` or None. Returns ``q (G,
    3)`` and ``well_posed (G,)``; each line's answer is that of :func:`triangulate_line` on its own
    rays (its least squares by its 2 x 2 normal equations; a line without rays at its origin's
    foot, not well posed)."""
    from scipy import ndimage

    s = np.asarray(s, float).reshape(-1, 3)
    o = np.asarray(o, float).reshape(-1, 3)
    d = np.asarray(d, float).reshape(-1, 3)
    line = np.asarray(line, int).reshape(-1)
    G = len(s)
    if len(o) != len(d) or len(line) != len(d):
        raise CatadioptricError(f"o, d, line: expected one origin, direction and line index per ray, got {len(o)}, "
                                f"{len(d)} and {len(line)}")
    if len(line) and (line.min() < 0 or line.max() >= G):
        bad = line[(line < 0) | (line >= G)][0]
        raise CatadioptricError(f"line: expected indices into the {G} directions s, got {int(bad)}")
    e1 = cross(s, np.where(np.abs(s[:, :1]) < 0.8, [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]))
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    e2 = cross(s, e1)
    # reciprocal product of the line (s, x e1' + y e2') with the ray (d, o x d), e' spanning m
    m1, m2 = cross(e1, s), cross(e2, s)  # moments of unit offsets along e1, e2
    sl = s[line]
    A0 = np.stack([np.sum(d * m1[line], 1), np.sum(d * m2[line], 1)], axis=1)
    rhs0 = -np.sum(cross(o, d) * sl, 1)
    sine = np.maximum(np.linalg.norm(cross(d, sl), axis=1), 1e-9)
    A0, rhs0 = A0 / sine[:, None], rhs0 / sine  # rows: the metric miss of each ray
    w = np.ones(len(d))
    eye = np.eye(2)
    for it in range(iters + 1):
        A, rhs = A0 * w[:, None], rhs0 * w
        N = np.stack([np.bincount(line, A[:, i] * A[:, j], G) for i in (0, 1) for j in (0, 1)], 1).reshape(G, 2, 2)
        g = np.stack([np.bincount(line, A[:, i] * rhs, G) for i in (0, 1)], 1)
        ev = np.linalg.eigvalsh(N)
        well = ev[:, 0] > 1e-4 * ev[:, 1]
        xy = (np.linalg.pinv(N) @ g[:, :, None])[:, :, 0]
        if prior is not None and not well.all():  # a ridge towards the prior, felt only along the free direction
            pr = np.asarray(prior, float).reshape(-1, 3)
            p = np.stack([np.sum(pr * e1, 1), np.sum(pr * e2, 1)], axis=1)
            lam = 1e-3 * ev[:, 1]
            ridge = np.linalg.solve(N + lam[:, None, None] * eye, (g + lam[:, None] * p)[:, :, None])[:, :, 0]
            xy = np.where(well[:, None], xy, ridge)
        q = xy[:, :1] * e1 + xy[:, 1:] * e2
        if it == iters or not len(line):
            break
        depth = np.abs(ray_depths(q[line], sl, o, d))
        med = np.asarray(ndimage.median(depth, labels=line, index=np.arange(G)), float).reshape(G)
        w = 1.0 / np.maximum(depth, 1e-3 * np.maximum(med, 1e-12)[line])
    return q, well
